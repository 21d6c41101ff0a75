#include "nephos/io/ply.hpp"

#include <bit>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"

namespace nephos::io {

static_assert(std::endian::native == std::endian::little, "PLY output assumes a little-endian host");

namespace {
constexpr const char* vertex_properties =
    "property float x\nproperty float y\nproperty float z\n"
    "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n"
    "property float radius\n";
constexpr std::size_t record_bytes = 3 * 4 + 4 + 4;
}  // namespace

void write_ply(const std::filesystem::path& path, const PlyPoints& p) {
  const std::size_t n = p.x.size();
  if (p.y.size() != n || p.z.size() != n || p.radius.size() != n || p.rgba.size() != 4 * n)
    throw ValueError("PLY point arrays differ in length", {.file = path.string()});
  AtomicFile file(path);
  std::ofstream out(file.temp_path(), std::ios::binary);
  if (!out) throw IoError(std::string("cannot open for writing: ") + std::strerror(errno), {.file = path.string()});
  out << "ply\nformat binary_little_endian 1.0\n";
  for (const auto& c : p.comments) out << "comment " << c << "\n";
  out << "element vertex " << n << "\n" << vertex_properties << "end_header\n";
  std::vector<char> buf(record_bytes * n);
  for (std::size_t i = 0; i < n; ++i) {
    char* r = buf.data() + i * record_bytes;
    std::memcpy(r, &p.x[i], 4);
    std::memcpy(r + 4, &p.y[i], 4);
    std::memcpy(r + 8, &p.z[i], 4);
    std::memcpy(r + 12, &p.rgba[4 * i], 4);
    std::memcpy(r + 16, &p.radius[i], 4);
  }
  out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  file.commit(out);
}

PlyPoints read_ply(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("cannot open", {.file = path.string()});
  std::string line, header;
  PlyPoints p;
  std::size_t n = 0;
  bool ended = false;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 && line != "ply") throw FormatError("not a PLY file", {.file = path.string(), .line = 1});
    if (line.rfind("comment ", 0) == 0) {
      p.comments.push_back(line.substr(8));
      continue;
    }
    if (line.rfind("element vertex ", 0) == 0) n = std::stoull(line.substr(15));
    if (line.rfind("property", 0) == 0) header += line + "\n";
    if (line == "end_header") {
      ended = true;
      break;
    }
  }
  if (!ended || header != vertex_properties)
    throw FormatError("not a nephos point PLY (x y z red green blue alpha radius)", {.file = path.string()});
  std::vector<char> buf(record_bytes * n);
  in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
  if (static_cast<std::size_t>(in.gcount()) != buf.size())
    throw FormatError("file is shorter than its vertex count says", {.file = path.string()});
  p.x.resize(n), p.y.resize(n), p.z.resize(n), p.radius.resize(n), p.rgba.resize(4 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const char* r = buf.data() + i * record_bytes;
    std::memcpy(&p.x[i], r, 4);
    std::memcpy(&p.y[i], r + 4, 4);
    std::memcpy(&p.z[i], r + 8, 4);
    std::memcpy(&p.rgba[4 * i], r + 12, 4);
    std::memcpy(&p.radius[i], r + 16, 4);
  }
  return p;
}

}  // namespace nephos::io
