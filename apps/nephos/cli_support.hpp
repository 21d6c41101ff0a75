#pragma once
// What the subcommands share: parsing of list, size and time options (errors name the option),
// the weather file or synthetic atmosphere, the --background option and frame PNGs.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "nephos/core/time.hpp"
#include "nephos/realtime/gl_renderer.hpp"
#include "nephos/weather/weather_grid.hpp"

namespace nephos::app {

/// "1 thread" / "N threads", for summary lines.
std::string threads_text();

/// The embedded default weather (a trimmed real GFS file, see data/README.md).
std::filesystem::path default_weather();

/// A comma-separated list (empty items dropped); ValueError naming `key` if nothing is left.
std::vector<std::string> split(const std::string& list, const std::string& key);
/// split() of a list whose items must be distinct (bands, cloud types).
std::vector<std::string> split_distinct(const std::string& list, const std::string& key);
/// WIDTHxHEIGHT, each 1..20000; ValueError naming --size otherwise.
std::pair<int, int> parse_size(const std::string& s);
/// A UTC time option (ISO 8601); its errors name the option.
UtcTime parse_time(const std::string& text, const char* key);

/// The weather file (default: the embedded sample), at `valid_time` (ISO 8601) when the file
/// holds several valid times and one is asked for.
weather::WeatherGrid open_weather_file(const std::string& path, const std::string& valid_time);

/// --weather FILE, --weather-time T and --synthetic, as nephos masks and nephos render take them.
struct WeatherSource {
  std::string file;        ///< empty: the embedded sample
  std::string valid_time;  ///< a valid time of a file that holds several (ISO 8601)
  bool synthetic = false;  ///< an atmosphere made from --seed instead of a file
};
void add_weather_source_options(CLI::App* c, WeatherSource& source);
/// open_weather_file(), or with `synthetic` an atmosphere made from `seed`.
weather::WeatherGrid load_weather(const WeatherSource& source, std::uint64_t seed);

/// --background of nephos fly and nephos particles.
void add_background_option(CLI::App* c, std::string& value);
/// --background: false for "sky", true for "transparent".
bool transparent_background(const std::string& value);
/// The renderer's last frame as a PNG: RGB over the sky, or RGBA (straight alpha) without it.
void write_frame_png(const std::filesystem::path& path, const realtime::SpriteRenderer& renderer, bool transparent);

}  // namespace nephos::app
