#include "cli_support.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <sstream>

#include "nephos/core/error.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/io/png.hpp"
#include "nephos/weather/reader.hpp"
#include "nephos/weather/synthetic.hpp"
#include "view.hpp"

namespace nephos::app {

std::string threads_text() {
  const int n = thread_count();
  return fmt::format("{} thread{}", n, n == 1 ? "" : "s");
}

std::filesystem::path default_weather() {
  if (const char* env = std::getenv("NEPHOS_DATA_DIR"))
    return std::filesystem::path(env) / "gfs_20110110_12z_f120_2p5deg.grib2";
  return std::filesystem::path(NEPHOS_DATA_DIR) / "gfs_20110110_12z_f120_2p5deg.grib2";
}

std::vector<std::string> split(const std::string& list, const std::string& key) {
  std::vector<std::string> out;
  std::string item;
  std::stringstream ss(list);
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  if (out.empty()) throw ValueError("empty list", {.key = key});
  return out;
}

std::vector<std::string> split_distinct(const std::string& list, const std::string& key) {
  std::vector<std::string> items = split(list, key);
  for (std::size_t i = 0; i < items.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (items[i] == items[j]) throw ValueError("'" + items[i] + "' is listed twice", {.key = key});
  return items;
}

std::pair<int, int> parse_size(const std::string& s) {
  int w = 0, h = 0;
  char x = 0;
  std::stringstream ss(s);
  if (!(ss >> w >> x >> h) || x != 'x' || w < 1 || h < 1 || w > 20000 || h > 20000 || !ss.eof())
    throw ValueError("expected WIDTHxHEIGHT (1..20000), got '" + s + "'", {.key = "--size"});
  return {w, h};
}

UtcTime parse_time(const std::string& text, const char* key) {
  try {
    return UtcTime::parse(text);
  } catch (const ValueError& e) {
    throw ValueError(e.message(), {.key = key});
  }
}

weather::WeatherGrid open_weather_file(const std::string& path, const std::string& valid_time) {
  const std::filesystem::path file = path.empty() ? default_weather() : std::filesystem::path(path);
  spdlog::info("weather: {}", file.string());
  if (valid_time.empty()) return weather::open_weather(file);
  return weather::open_weather(file, parse_time(valid_time, "--weather-time"));
}

void add_weather_source_options(CLI::App* c, WeatherSource& source) {
  c->add_option("--weather", source.file, "GRIB file (default: the embedded GFS sample)");
  c->add_option("--weather-time", source.valid_time,
                "Which valid time (ISO 8601 UTC) of a file that holds several (default: its first)");
  c->add_flag("--synthetic", source.synthetic, "Use a synthetic atmosphere from --seed instead of a file");
}

weather::WeatherGrid load_weather(const WeatherSource& source, std::uint64_t seed) {
  if (source.synthetic) {
    if (!source.valid_time.empty())
      throw ValueError("synthetic weather has no file to choose a time from", {.key = "--weather-time"});
    weather::SyntheticWeatherParams p;
    p.seed = seed;
    spdlog::info("weather: synthetic atmosphere, seed {}", seed);
    return weather::make_synthetic_weather(p);
  }
  return open_weather_file(source.file, source.valid_time);
}

void add_background_option(CLI::App* c, std::string& value) {
  c->add_option("--background", value,
                "sky, or transparent: RGBA frames (alpha = cloud coverage) to composite over a map or terrain")
      ->capture_default_str();
}

bool transparent_background(const std::string& value) {
  if (value != "sky" && value != "transparent")
    throw ValueError("expected sky or transparent, got '" + value + "'", {.key = "--background"});
  return value == "transparent";
}

void write_frame_png(const std::filesystem::path& path, const realtime::SpriteRenderer& renderer, bool transparent) {
  if (transparent)
    io::write_png(path, renderer.width(), renderer.height(), 4, realtime::straight_alpha(renderer.read_pixels()));
  else
    app::write_rgb_png(path.string(), renderer.width(), renderer.height(), renderer.read_pixels());
}

}  // namespace nephos::app
