#include "cli_support.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "nephos/core/parallel.hpp"
#include "nephos/core/parse.hpp"

namespace nephos::app {

std::string threads_text() {
  const int n = thread_count();
  return fmt::format("{} thread{}", n, n == 1 ? "" : "s");
}

void add_weather_source_options(CLI::App* c, WeatherOptions& options) {
  c->add_option("--weather", options.file, "GRIB file (default: the embedded GFS sample)");
  c->add_option("--weather-time", options.valid_time,
                "Which valid time (ISO 8601 UTC) of a file that holds several (default: its first)");
  c->add_flag("--synthetic", options.synthetic, "Use a synthetic atmosphere from --seed instead of a file");
}

weather::WeatherSource weather_source(const WeatherOptions& options) {
  weather::WeatherSource s;
  s.file = options.file;
  if (!options.valid_time.empty()) s.valid_time = parse_time(options.valid_time, "weather_time");
  s.synthetic = options.synthetic;
  return s;
}

std::string option_for_key(const CLI::App& command, const std::string& key,
                           const std::map<std::string, std::string>& flags) {
  if (const auto f = flags.find(key); f != flags.end()) return f->second;
  std::string flag = "--" + key;
  std::replace(flag.begin(), flag.end(), '_', '-');
  for (const CLI::App* app = &command; app; app = app->get_parent())
    if (app->get_option_no_throw(flag)) return flag;
  return {};
}

}  // namespace nephos::app
