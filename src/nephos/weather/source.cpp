#include "nephos/weather/source.hpp"

#include <spdlog/spdlog.h>

#include <cstdlib>

#include "nephos/core/error.hpp"
#include "nephos/weather/reader.hpp"
#include "nephos/weather/synthetic.hpp"

namespace nephos::weather {

std::filesystem::path default_weather_file() {
  const char* env = std::getenv("NEPHOS_DATA_DIR");
  return std::filesystem::path(env ? env : NEPHOS_DATA_DIR) / "gfs_20110110_12z_f120_2p5deg.grib2";
}

WeatherGrid load_weather(const WeatherSource& source, std::uint64_t seed) {
  if (source.synthetic) {
    if (source.valid_time)
      throw ValueError("synthetic weather has no file to choose a time from", {.key = "weather_time"});
    SyntheticWeatherParams p;
    p.seed = seed;
    spdlog::info("weather: synthetic atmosphere, seed {}", seed);
    return make_synthetic_weather(p);
  }
  const std::filesystem::path file = source.file.empty() ? default_weather_file() : source.file;
  spdlog::info("weather: {}", file.string());
  return source.valid_time ? open_weather(file, *source.valid_time) : open_weather(file);
}

}  // namespace nephos::weather
