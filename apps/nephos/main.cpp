// nephos command-line program: parses the command line, runs the chosen subcommand (each in
// its own *_command(s).cpp) and is, with the Python layer, the only place that catches
// exceptions: nephos::Error -> one line naming file/field/key, exit code 2.
#include <fmt/format.h>
#include <hdf5.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>
#include <new>
#include <set>
#include <string>
#include <vector>

#include "cli_support.hpp"
#include "command.hpp"
#if NEPHOS_HAVE_MPI
#include "nephos/lbm/mpi/slabs.hpp"
#endif
#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/log.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/core/progress.hpp"

using namespace nephos;

namespace {

constexpr int exit_input_error = 2;

// An empty value (`--weather ""`, often an unset shell variable) is never what a user meant: it
// would silently pick the option's default, or write into the working directory for --out. Every
// text option of every subcommand refuses it, except those named in `allowed`, where empty means
// something (bench fly --plot "": no plot).
void reject_empty_values(CLI::App& app, const std::set<std::string>& allowed) {
  const CLI::Validator non_empty(
      [](std::string& value) { return value.empty() ? std::string("an empty value is not allowed") : std::string(); },
      "", "non-empty");
  for (CLI::Option* option : app.get_options())
    if (option->get_type_name() == "TEXT" && !allowed.count(option->get_name())) option->check(non_empty);
  for (CLI::App* sub : app.get_subcommands({})) reject_empty_values(*sub, allowed);
}

// The error as the command line shows it: a request field's name as the option that sets it
// (size: --size). Keys of configuration files (they carry the file) and keys no option of the
// command sets stay as they are.
Error as_shown(const Error& e, const app::Command& command) {
  ErrorContext context = e.context();
  if (context.key.empty() || !context.file.empty() || context.key.rfind("--", 0) == 0) return e;
  const std::string option = app::option_for_key(*command.app, context.key, command.flags);
  if (option.empty()) return e;
  context.key = option;
  return Error(e.message(), context);
}

}  // namespace

int main(int argc, char** argv) {
  // NetCDF-4 writes through HDF5, whose exit-time clean-up closes what is still open. After a
  // file failed to close (a full disk), that clean-up crashed the process after its error
  // message (HDF5 1.10.8): so no clean-up at exit. Every file is closed explicitly before then.
  // Must precede any HDF5 call.
  H5dont_atexit();
  // Under mpirun (several processes) MPI is initialised for `nephos lbm`; plain runs never
  // touch MPI.
#if NEPHOS_HAVE_MPI
  lbm::mpi::Session mpi(argc, argv);
  const int rank = mpi.rank(), ranks = mpi.size();
#else
  const int rank = 0, ranks = 1;
#endif
  // One line per message, written at once: under mpirun every process reports (a failure on
  // one stops all of them, each with the first failing process's message), and the lines of
  // processes other than 0 say which process they come from.
  auto report = [&](const char* kind, const std::string& message) {
    const std::string who = rank > 0 ? fmt::format(" (rank {} of {})", rank, ranks) : "";
    std::cerr << fmt::format("nephos{}: {}: {}\n", who, kind, message) << std::flush;
  };
  CLI::App app{"nephos: real weather data to three-dimensional clouds"};
  app.require_subcommand(1);
  // The program's options are also taken after the subcommand (nephos lbm --seed 7 ...).
  app.fallthrough();
  app.set_version_flag("--version", std::string("nephos ") + NEPHOS_VERSION);
  app::GlobalOptions g;
  app.add_flag("-v,--verbose", g.verbose, "Log debug detail");
  app.add_flag("-q,--quiet", g.quiet, "Log only warnings and errors; no progress bars");
  // CLI11's NonNegativeNumber prints its range as 0 to 1.8e308 in full; and it alone would let
  // --seed -1 through as 2^64 - 1.
  const CLI::Validator non_negative(
      [](std::string& value) {
        return !value.empty() && value[0] == '-' ? std::string("must not be negative, got " + value) : std::string();
      },
      "", "non-negative");
  app.add_option("--threads", g.threads, "Worker threads (0 = all cores)")->check(non_negative);
  app.add_option("--seed", g.seed, "Seed for all randomness (counter-based; results do not depend on threads)")
      ->check(non_negative);

  const std::vector<app::Command> commands = [&] {
    std::vector<app::Command> c{app::add_info_command(app),        app::add_masks_command(app, g),
                                app::add_render_command(app, g),   app::add_lbm_command(app, g),
                                app::add_fly_command(app, g),      app::add_view_command(app, g),
                                app::add_particles_command(app, g)};
    for (auto& b : app::add_bench_commands(app, g)) c.push_back(std::move(b));
    return c;
  }();

  reject_empty_values(app, {"--plot"});
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // One line, as every other input error (CLI11's own adds a second).
    std::string message = e.what();
    std::replace(message.begin(), message.end(), '\n', ' ');
    report("error", message + " (--help lists the options)");
    return exit_input_error;
  }

  const app::Command* chosen = nullptr;
  for (const auto& command : commands)
    if (*command.app) chosen = &command;
  try {
    init_logging(g.quiet ? Verbosity::quiet : g.verbose ? Verbosity::verbose : Verbosity::normal);
    Progress::set_enabled(!g.quiet);
    set_threads(g.threads);
    remove_temporaries_on_interrupt();  // Ctrl-C or kill leaves no NAME.tmpPID behind
    if (chosen) return chosen->run();
  } catch (const Error& e) {
    report("error", chosen ? as_shown(e, *chosen).what() : e.what());
    return exit_input_error;
  } catch (const std::bad_alloc&) {
    // The commands check their big allocations against the machine's memory first; this is
    // what is left when the memory other programs hold makes the difference.
    report("error",
           "out of memory (other programs may hold what this run needs; try a smaller --size, --grid, --texture or "
           "--count)");
    return 1;
  } catch (const std::exception& e) {
    report("internal error", e.what());
    return 1;
  }
  return 0;
}
