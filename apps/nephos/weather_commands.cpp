// nephos info (what a weather file or checkpoint holds) and nephos masks (the cloud weather
// masks of Table 1 as PNGs and CF-NetCDF).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <memory>

#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/config.hpp"
#include "nephos/core/error.hpp"
#include "nephos/lbm/water_model.hpp"
#include "nephos/weather/info.hpp"
#include "nephos/weather/masks.hpp"
#include "nephos/weather/masks_job.hpp"

namespace nephos::app {

namespace {

// The command's options; their defaults are the request's (weather/masks_job.hpp).
struct MasksOptions {
  inline static const weather::MasksRequest defaults{};
  WeatherOptions weather;
  std::string out = defaults.out.string();
  std::string config;
  int png_width = defaults.png_width;
};

int run_masks(const MasksOptions& o, const GlobalOptions& g) {
  const auto t0 = std::chrono::steady_clock::now();
  weather::MasksRequest r;
  r.weather = weather_source(o.weather);
  r.config = o.config;
  r.png_width = o.png_width;
  r.out = o.out;
  r.seed = g.seed;
  const weather::MasksResult res = weather::run_masks(r);
  std::cout << fmt::format("{:<12} {:>10}\n", "mask", "cover");
  for (int t = 0; t < weather::cloud_type_count; ++t)
    std::cout << fmt::format("{:<12} {:>10.3f}\n", weather::name(static_cast<weather::CloudType>(t)),
                             res.cover[static_cast<std::size_t>(t)]);
  if (!res.agreement.empty()) {
    std::cout << "\nagreement with GFS cloud cover (area-weighted):\n";
    std::cout << fmt::format("{:<7} {:<30} {:>10} {:>10} {:>12}\n", "layer", "mask", "mask cover", "GFS cover",
                             "correlation");
    for (const auto& a : res.agreement)
      std::cout << fmt::format("{:<7} {:<30} {:>10.3f} {:>10.3f} {:>12.3f}\n", weather::name(a.layer), a.mask,
                               a.mask_cover, a.gfs_cover, a.correlation);
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  spdlog::info("wrote {}/masks.nc and 4 PNGs in {:.2f} s ({})", r.out.string(), secs, threads_text());
  return 0;
}

}  // namespace

Command add_info_command(CLI::App& app) {
  auto info_file = std::make_shared<std::string>();
  auto* info = app.add_subcommand("info", "Describe a weather file in nephos's terms, or an lbm checkpoint");
  info->add_option("file", *info_file, "GRIB1/GRIB2 file, or a checkpoint of nephos lbm")->required();
  return {info, [info_file] {
            std::cout << (lbm::WaterModel::is_checkpoint(*info_file) ? lbm::WaterModel::describe_checkpoint(*info_file)
                                                                     : weather::describe_weather_file(*info_file));
            return 0;
          }};
}

Command add_masks_command(CLI::App& app, const GlobalOptions& g) {
  auto o = std::make_shared<MasksOptions>();
  auto* masks = app.add_subcommand("masks", "Cloud weather masks (Table 1) as PNGs and CF-NetCDF");
  add_weather_source_options(masks, o->weather);
  masks->add_option("--out", o->out, "Output directory")->capture_default_str();
  masks->add_option("--config", o->config,
                    "model configuration (as render --config): its [cloud_fraction] and [masks.*] tables");
  masks
      ->add_option(
          "--png-width", o->png_width,
          fmt::format("Width of the PNG previews [pixels], {}-{}", weather::min_png_width, weather::max_png_width))
      ->capture_default_str();
  return {masks, [o, &g] { return run_masks(*o, g); }};
}

}  // namespace nephos::app
