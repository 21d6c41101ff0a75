#pragma once
// Write-then-rename: outputs appear whole or not at all. Write to temp_path(), then commit();
// if commit() is never reached (an exception), the destructor removes the temporary.
#include <filesystem>

namespace nephos {

class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path destination);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& destination() const { return destination_; }
  /// Renames the temporary onto the destination. Throws IoError on failure.
  void commit();

 private:
  std::filesystem::path destination_;
  std::filesystem::path temp_;
  bool committed_ = false;
};

/// Creates `dir` (and parents) if needed; throws IoError naming it on failure.
void ensure_directory(const std::filesystem::path& dir);

}  // namespace nephos
