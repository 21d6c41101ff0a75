#pragma once
// What the subcommands share: the weather-source options and how a request field's name is
// shown as the option that sets it.
#include <CLI/CLI.hpp>
#include <string>

#include "nephos/weather/source.hpp"

namespace nephos::app {

/// "1 thread" / "N threads", for summary lines.
std::string threads_text();

/// --weather FILE, --weather-time T and --synthetic as given.
struct WeatherOptions {
  std::string file;        ///< empty: the embedded sample
  std::string valid_time;  ///< ISO 8601; empty: the file's first
  bool synthetic = false;
};
void add_weather_source_options(CLI::App* c, WeatherOptions& options);
/// The request's weather source (the time parsed; errors name "weather_time").
weather::WeatherSource weather_source(const WeatherOptions& options);

/// The option of `command` (or of the program) that sets a request field: `flags[key]` if
/// listed, else "--" + the key with '_' as '-' if that option exists; empty if none does.
std::string option_for_key(const CLI::App& command, const std::string& key,
                           const std::map<std::string, std::string>& flags);

}  // namespace nephos::app
