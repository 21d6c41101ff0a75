#pragma once
// A thin, typed-error wrapper over netCDF-C for writing CF-compliant NetCDF-4 files.
// The file is written under a temporary name and renamed by close(); a writer destroyed
// without close() (an exception) leaves nothing behind.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace nephos {
class AtomicFile;
}

namespace nephos::io {

enum class NcType { f32, f64, i32, i16, i8 };

class NetcdfWriter {
 public:
  static constexpr int global = -1;  ///< NC_GLOBAL: attributes of the file itself

  explicit NetcdfWriter(const std::filesystem::path& path);
  ~NetcdfWriter();
  NetcdfWriter(const NetcdfWriter&) = delete;
  NetcdfWriter& operator=(const NetcdfWriter&) = delete;

  int add_dimension(const std::string& name, std::size_t length);
  /// A variable over the named dimensions (slowest first). Every variable with dimensions is
  /// compressed (shuffle, deflate level 1).
  /// @param chunks  the chunk's length along each dimension, each clamped to the dimension's own;
  ///                empty for netCDF-C's default chunks
  int add_variable(const std::string& name, NcType type, const std::vector<std::string>& dims,
                   const std::vector<std::size_t>& chunks = {});
  void put_attribute(int var, const std::string& name, const std::string& value);
  void put_attribute(int var, const std::string& name, double value);
  void put_attribute(int var, const std::string& name, const std::vector<double>& values);
  void put_attribute_f32(int var, const std::string& name, const std::vector<float>& values);
  void put_attribute_i8(int var, const std::string& name, const std::vector<std::int8_t>& values);
  void put_attribute_i16(int var, const std::string& name, const std::vector<std::int16_t>& values);
  /// An unsigned 64-bit integer (NetCDF-4's NC_UINT64): exact where a double would round (seeds
  /// beyond 2^53).
  void put_attribute_u64(int var, const std::string& name, std::uint64_t value);
  /// Leaves define mode; then write data.
  void end_definitions();
  void write(int var, const float* data);
  void write(int var, const double* data);
  void write(int var, const std::int32_t* data);
  void write(int var, const std::int8_t* data);
  void write(int var, const std::int16_t* data);
  /// Closes and renames into place.
  void close();

 private:
  void check(int status, const std::string& what) const;
  struct Dimension {
    std::string name;
    int id;
    std::size_t length;
  };
  const Dimension& dimension(const std::string& name) const;
  std::filesystem::path path_;
  std::unique_ptr<AtomicFile> file_;
  int ncid_ = -1;
  std::vector<Dimension> dims_;
};

}  // namespace nephos::io
