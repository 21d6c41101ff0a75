#pragma once
// `nephos info`: a weather file described in nephos's terms.
#include <filesystem>
#include <string>

namespace nephos::weather {
/// Reads `path` and returns a human-readable report: grid, times, levels per field, cloud
/// cover layers, and which nephos capabilities the file supports (and what is missing for the
/// others). Throws like open_weather().
std::string describe_weather_file(const std::filesystem::path& path);
}  // namespace nephos::weather
