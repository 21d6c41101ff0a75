#include "nephos/core/log.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace nephos {
namespace {
Verbosity g_verbosity = Verbosity::normal;
}

void init_logging(Verbosity v) {
  g_verbosity = v;
  auto logger = spdlog::get("nephos");
  if (!logger) {
    logger = spdlog::stderr_color_mt("nephos");
    logger->set_pattern("%^[%l]%$ %v");
    spdlog::set_default_logger(logger);
  }
  switch (v) {
    case Verbosity::quiet:
      spdlog::set_level(spdlog::level::warn);
      break;
    case Verbosity::normal:
      spdlog::set_level(spdlog::level::info);
      break;
    case Verbosity::verbose:
      spdlog::set_level(spdlog::level::debug);
      break;
  }
}

Verbosity verbosity() { return g_verbosity; }
}  // namespace nephos
