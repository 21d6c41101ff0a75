#include "nephos/weather/reader.hpp"

#include <fmt/format.h>

#include <map>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/weather/grib_reader.hpp"

namespace nephos::weather {

namespace {
// Built-in readers are in the map from its construction (thread-safe static initialisation).
std::map<std::string, ReaderFactory>& registry() {
  static std::map<std::string, ReaderFactory> r{{"grib", grib_reader_factory()}};
  return r;
}
}  // namespace

void register_reader(const std::string& name, ReaderFactory factory) { registry()[name] = std::move(factory); }

std::vector<std::string> reader_names() {
  std::vector<std::string> out;
  for (const auto& [k, v] : registry()) out.push_back(k);
  return out;
}

std::unique_ptr<WeatherReader> make_reader(const std::string& name) {
  auto& r = registry();
  auto it = r.find(name);
  if (it == r.end()) {
    std::string known;
    for (const auto& n : reader_names()) known += (known.empty() ? "" : ", ") + n;
    throw ValueError("unknown weather reader '" + name + "' (known: " + known + ")");
  }
  return it->second();
}

namespace {
std::unique_ptr<WeatherReader> reader_for(const std::filesystem::path& path) {
  require_input_file(path, "a weather file (GRIB)");
  for (const auto& n : reader_names()) {
    auto reader = make_reader(n);
    if (reader->can_read(path)) return reader;
  }
  throw FormatError("not a GRIB file (no GRIB messages found) and no other reader recognises it",
                    {.file = path.string()});
}
}  // namespace

WeatherGrid open_weather(const std::filesystem::path& path) { return reader_for(path)->read(path); }

WeatherGrid open_weather(const std::filesystem::path& path, const UtcTime& valid_time) {
  return reader_for(path)->read_at(path, valid_time);
}

WeatherGrid WeatherReader::read_at(const std::filesystem::path& path, const UtcTime& valid_time) const {
  WeatherGrid w = read(path);
  if (w.metadata().valid_time != valid_time)
    throw FormatError(fmt::format("no fields valid at {}; the file's valid time: {}", valid_time.iso(),
                                  w.metadata().valid_time.iso()),
                      {.file = path.string()});
  return w;
}

std::vector<WeatherGrid> open_weather_times(const std::filesystem::path& path) {
  return reader_for(path)->read_all_times(path);
}

}  // namespace nephos::weather
