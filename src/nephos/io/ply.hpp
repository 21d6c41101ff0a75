#pragma once
// Point clouds as PLY (Stanford polygon format, binary little-endian 1.0): one "vertex" element
// with float x, y, z, uchar red, green, blue, alpha and float radius. Read by Blender, ParaView,
// CloudCompare and MeshLab (which ignore or offer the extra property). Written atomically.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace nephos::io {

struct PlyPoints {
  std::vector<float> x, y, z;
  std::vector<std::uint8_t> rgba;  ///< 4 per point
  std::vector<float> radius;
  std::vector<std::string> comments;  ///< header comment lines (no newlines)
};

/// Throws ValueError if the arrays disagree in length, IoError if the file cannot be written.
void write_ply(const std::filesystem::path& path, const PlyPoints& points);

/// Reads back what write_ply writes (for tests and tools); FormatError for anything else.
PlyPoints read_ply(const std::filesystem::path& path);

}  // namespace nephos::io
