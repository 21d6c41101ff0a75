#pragma once
// Leveled logging to stderr through spdlog. Library code logs with spdlog::info/debug/warn;
// the CLI picks the level (--verbose / --quiet).
#include <spdlog/spdlog.h>

namespace nephos {
enum class Verbosity { quiet, normal, verbose };
/// Installs the stderr logger and sets its level; quiet also disables progress bars.
void init_logging(Verbosity verbosity);
Verbosity verbosity();
}  // namespace nephos
