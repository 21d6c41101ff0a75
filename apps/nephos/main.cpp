// nephos command-line program. Only this file (and the Python layer) catches exceptions:
// nephos::Error -> one-line message naming file/field/key, exit code 2.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/config.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/log.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/core/progress.hpp"
#include "nephos/weather/info.hpp"
#include "nephos/weather/masks.hpp"
#include "nephos/weather/masks_io.hpp"
#include "nephos/weather/reader.hpp"
#include "nephos/weather/synthetic.hpp"

namespace fs = std::filesystem;
using namespace nephos;

namespace {

constexpr int exit_input_error = 2;

/// The embedded default weather (a trimmed real GFS file, see data/README.md).
fs::path default_weather() {
  if (const char* env = std::getenv("NEPHOS_DATA_DIR")) return fs::path(env) / "gfs_20110110_12z_f120_2p5deg.grib2";
  return fs::path(NEPHOS_DATA_DIR) / "gfs_20110110_12z_f120_2p5deg.grib2";
}

struct GlobalOptions {
  bool verbose = false, quiet = false;
  int threads = 0;
  std::uint64_t seed = 1;
};

struct MasksOptions {
  std::string weather;
  std::string out = "out";
  std::string config;
  bool synthetic = false;
  int png_width = 1440;
};

weather::WeatherGrid load_weather(const std::string& path, bool synthetic, std::uint64_t seed) {
  if (synthetic) {
    weather::SyntheticWeatherParams p;
    p.seed = seed;
    spdlog::info("weather: synthetic atmosphere, seed {}", seed);
    return weather::make_synthetic_weather(p);
  }
  const fs::path file = path.empty() ? default_weather() : fs::path(path);
  spdlog::info("weather: {}", file.string());
  return weather::open_weather(file);
}

int run_masks(const MasksOptions& o, const GlobalOptions& g) {
  const auto t0 = std::chrono::steady_clock::now();
  weather::MaskParams params;
  if (!o.config.empty()) {
    const ParamDict dict = ParamDict::from_file(o.config);
    params = weather::MaskParams::from(dict);
    dict.check_unused();
  }
  const weather::WeatherGrid w = load_weather(o.weather, o.synthetic, g.seed);
  const auto& m = w.metadata();
  spdlog::info("valid {} (run {} + {:g} h), {}", m.valid_time.iso(), m.reference_time.iso(), m.forecast_step_h,
               w.grid().describe());
  const weather::WeatherMasks masks = weather::compute_masks(w, params);

  const fs::path out(o.out);
  ensure_directory(out);
  weather::write_masks_netcdf(out / "masks.nc", masks, w, params);
  for (int t = 0; t < weather::cloud_type_count; ++t) {
    const auto type = static_cast<weather::CloudType>(t);
    weather::write_mask_png(out / (std::string(weather::name(type)) + ".png"), masks.grid, masks[type], o.png_width);
  }
  std::cout << fmt::format("{:<12} {:>10}\n", "mask", "cover");
  for (int t = 0; t < weather::cloud_type_count; ++t) {
    const auto type = static_cast<weather::CloudType>(t);
    std::cout << fmt::format("{:<12} {:>10.3f}\n", weather::name(type), weather::area_mean(masks.grid, masks[type]));
  }
  const auto agreement = weather::compare_with_gfs_cloud_cover(masks, w);
  if (!agreement.empty()) {
    std::cout << "\nagreement with GFS cloud cover (area-weighted):\n";
    std::cout << fmt::format("{:<7} {:<30} {:>10} {:>10} {:>12}\n", "layer", "mask", "mask cover", "GFS cover",
                             "correlation");
    for (const auto& a : agreement)
      std::cout << fmt::format("{:<7} {:<30} {:>10.3f} {:>10.3f} {:>12.3f}\n", weather::name(a.layer), a.mask,
                               a.mask_cover, a.gfs_cover, a.correlation);
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  spdlog::info("wrote {}/masks.nc and 4 PNGs in {:.2f} s ({} threads)", out.string(), secs, thread_count());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"nephos: real weather data to three-dimensional clouds"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("nephos ") + NEPHOS_VERSION);
  GlobalOptions g;
  app.add_flag("-v,--verbose", g.verbose, "Log debug detail");
  app.add_flag("-q,--quiet", g.quiet, "Log only warnings and errors; no progress bars");
  app.add_option("--threads", g.threads, "Worker threads (0 = all cores)")->check(CLI::NonNegativeNumber);
  app.add_option("--seed", g.seed, "Seed for all randomness (counter-based; results do not depend on threads)");

  std::string info_file;
  auto* info = app.add_subcommand("info", "Describe a weather file in nephos's terms");
  info->add_option("file", info_file, "GRIB1/GRIB2 file")->required();

  MasksOptions mo;
  auto* masks = app.add_subcommand("masks", "Cloud weather masks (Table 1) as PNGs and CF-NetCDF");
  masks->add_option("--weather", mo.weather, "GRIB file (default: the embedded GFS sample)");
  masks->add_flag("--synthetic", mo.synthetic, "Use a synthetic atmosphere from --seed instead of a file");
  masks->add_option("--out", mo.out, "Output directory")->capture_default_str();
  masks->add_option("--config", mo.config, "TOML file with [cloud_fraction] and [masks.*] parameters");
  masks->add_option("--png-width", mo.png_width, "Width of the PNG previews [pixels]")
      ->capture_default_str()
      ->check(CLI::Range(16, 16384));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : exit_input_error;
  }

  try {
    init_logging(g.quiet ? Verbosity::quiet : g.verbose ? Verbosity::verbose : Verbosity::normal);
    Progress::set_enabled(!g.quiet);
    set_threads(g.threads);
    if (*info) {
      std::cout << weather::describe_weather_file(info_file);
      return 0;
    }
    if (*masks) return run_masks(mo, g);
  } catch (const Error& e) {
    std::cerr << "nephos: error: " << e.what() << "\n";
    return exit_input_error;
  } catch (const std::exception& e) {
    std::cerr << "nephos: internal error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
