#pragma once
// PNG output through libpng, written atomically (temporary file, then rename).
#include <cstdint>
#include <filesystem>
#include <vector>

namespace nephos::io {

/// Writes 8-bit pixels, row-major from the top row; channels: 1 (grey), 3 (RGB) or 4 (RGBA).
void write_png(const std::filesystem::path& path, int width, int height, int channels,
               const std::vector<std::uint8_t>& pixels);

/// Reads an 8-bit PNG (for tests and tools); returns pixels and sets width/height/channels.
std::vector<std::uint8_t> read_png(const std::filesystem::path& path, int& width, int& height, int& channels);

}  // namespace nephos::io
