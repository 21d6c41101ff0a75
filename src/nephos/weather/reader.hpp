#pragma once
// Weather readers: an open set (GRIB today; others later), so a virtual base with a name-keyed
// registry. open_weather() picks the reader that recognises a file by its content.
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "nephos/weather/weather_grid.hpp"

namespace nephos::weather {

class WeatherReader {
 public:
  virtual ~WeatherReader() = default;
  virtual std::string name() const = 0;
  /// Cheap content sniffing (magic bytes), never throws.
  virtual bool can_read(const std::filesystem::path& path) const = 0;
  /// Reads the file; a file with several valid times at the first (a warning names the
  /// others). Throws IoError (cannot read) or FormatError (content not usable).
  virtual WeatherGrid read(const std::filesystem::path& path) const = 0;
  /// The fields valid at `valid_time` (FormatError naming the file's times if it has none;
  /// default: read(), checked against the time).
  virtual WeatherGrid read_at(const std::filesystem::path& path, const UtcTime& valid_time) const;
  /// Every valid time the file holds, one grid each, in time order (default: read()).
  virtual std::vector<WeatherGrid> read_all_times(const std::filesystem::path& path) const { return {read(path)}; }
};

using ReaderFactory = std::function<std::unique_ptr<WeatherReader>()>;
/// Registers a reader under `name` (built-in readers are registered on first use).
void register_reader(const std::string& name, ReaderFactory factory);
/// The reader registered as `name`; ValueError listing the known names otherwise.
std::unique_ptr<WeatherReader> make_reader(const std::string& name);
std::vector<std::string> reader_names();

/// Reads a weather file with whichever registered reader recognises it.
/// Throws IoError if the file is missing/unreadable, FormatError if no reader recognises it.
WeatherGrid open_weather(const std::filesystem::path& path);
/// The same at one valid time of a file that holds several (FormatError naming the file's times
/// if it has no pressure-level fields at that time).
WeatherGrid open_weather(const std::filesystem::path& path, const UtcTime& valid_time);
/// The same for every valid time in the file (forecast steps or analysis hours concatenated),
/// one grid each, in time order.
std::vector<WeatherGrid> open_weather_times(const std::filesystem::path& path);

}  // namespace nephos::weather
