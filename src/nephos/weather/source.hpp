#pragma once
// Where a run's weather comes from: a file (by default the embedded GFS sample), one valid time
// of it, or a synthetic atmosphere. The request every front end fills in the same way.
#include <cstdint>
#include <filesystem>
#include <optional>

#include "nephos/core/time.hpp"
#include "nephos/weather/weather_grid.hpp"

namespace nephos::weather {

struct WeatherSource {
  std::filesystem::path file;         ///< GRIB file; empty: the embedded sample (default_weather_file())
  std::optional<UtcTime> valid_time;  ///< one valid time of a file that holds several (default: its first)
  bool synthetic = false;             ///< an atmosphere made from the seed instead of a file
};

/// The embedded GFS sample: $NEPHOS_DATA_DIR/gfs_20110110_12z_f120_2p5deg.grib2, or the one in
/// the source tree's data/ when the variable is unset.
std::filesystem::path default_weather_file();

/// The weather a source names: the file read at its valid time, or the synthetic atmosphere
/// made from `seed`. ValueError with key "weather_time" for a valid time of synthetic weather;
/// the readers' IoError and FormatError otherwise.
WeatherGrid load_weather(const WeatherSource& source, std::uint64_t seed);

}  // namespace nephos::weather
