#pragma once
// The subcommands of the nephos program. Each registers itself on the CLI11 app with its own
// options (parsed into a structure it owns) and returns how to run it; main() parses the
// command line and runs the one chosen. Commands throw nephos::Error on bad input; main()
// alone catches (one line naming the file, field or key; exit code 2).
#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace nephos::app {

/// The program's own options (before or after the subcommand); filled in by parsing, read when
/// a command runs.
struct GlobalOptions {
  bool verbose = false, quiet = false;
  int threads = 0;
  std::uint64_t seed = 1;
};

/// A registered subcommand: chosen when `*app` is true after parsing; `run` returns the exit
/// code. Its requests' errors name their fields; `flags` lists the options that set a field
/// whose option is not "--" + its name with '_' as '-' (e.g. speed_kt: --speed).
struct Command {
  CLI::App* app;
  std::function<int()> run;
  std::map<std::string, std::string> flags = {};
};

Command add_info_command(CLI::App& app);                                         // weather_commands.cpp
Command add_masks_command(CLI::App& app, const GlobalOptions& g);                // weather_commands.cpp
Command add_render_command(CLI::App& app, const GlobalOptions& g);               // render_command.cpp
Command add_lbm_command(CLI::App& app, const GlobalOptions& g);                  // lbm_command.cpp
Command add_fly_command(CLI::App& app, const GlobalOptions& g);                  // flight_commands.cpp
Command add_view_command(CLI::App& app, const GlobalOptions& g);                 // flight_commands.cpp
Command add_particles_command(CLI::App& app, const GlobalOptions& g);            // particles_command.cpp
std::vector<Command> add_bench_commands(CLI::App& app, const GlobalOptions& g);  // bench_commands.cpp

}  // namespace nephos::app
