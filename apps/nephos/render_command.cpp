// nephos render: the options of render::RenderRequest (docs/render.md), and one line per frame.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <memory>

#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/optics/optics.hpp"
#include "nephos/render/job.hpp"

namespace nephos::app {

namespace {

struct RenderOptions {
  WeatherOptions weather;
  std::string sensor = "geo:-75.2";
  std::string size = "1000x1000";
  std::string types = "low_stratus,low_cumulus,altostratus,cirrus";
  std::string bands = "vis,nir,lwir";
  int steps = 25;
  int samples = 1;
  bool sample_grid = false;
  bool no_atmosphere = false, no_shadows = false, no_filter = false;
  int texture = 0;
  std::string displace_hours;  // empty: per-type defaults
  double advance_hours = 0;
  int frames = 1;
  std::string time;
  std::string config;
  std::string out = "out";
  std::string scene = "full";
  int abi_step = 1;
  std::string format = "netcdf";
};

render::RenderRequest request_of(const RenderOptions& o, const GlobalOptions& g) {
  render::RenderRequest r;
  r.weather = weather_source(o.weather);
  r.scene.types.clear();
  for (const auto& t : split_distinct(o.types, "types")) r.scene.types.push_back(weather::cloud_type_from_name(t));
  r.scene.texture = o.texture;
  if (!o.displace_hours.empty())
    r.scene.displace_hours = parse_numbers(o.displace_hours, 1, "displace_hours", "hours")[0];
  r.scene.config = o.config;
  r.scene.seed = g.seed;
  r.view.sensor = o.sensor;
  std::tie(r.view.width, r.view.height) = parse_size(o.size, "size");
  r.view.bands = split_list(o.bands, "bands");
  r.view.steps = o.steps;
  r.view.samples = o.samples;
  r.view.sample_grid = o.sample_grid;
  r.view.atmosphere = !o.no_atmosphere;
  r.view.shadows = !o.no_shadows;
  r.view.filter = !o.no_filter;
  if (!o.time.empty()) r.view.time = parse_time(o.time, "time");
  r.advance_hours = o.advance_hours;
  r.frames = o.frames;
  r.out = o.out;
  r.view.scene = o.scene;
  r.view.abi_step = o.abi_step;
  r.format = o.format;
  return r;
}

int run(const RenderOptions& o, const GlobalOptions& g) {
  const auto t_start = std::chrono::steady_clock::now();
  const render::RenderRequest r = request_of(o, g);
  render::run_render(
      r, [&](int frame, const std::filesystem::path&, const render::RenderScene& scene, const render::RenderedView& v) {
        std::string summary;
        for (const auto& [name, secs] : v.image.seconds_per_type)
          summary += fmt::format(" {} {:.0f} ms,", name, secs * 1e3);
        if (!summary.empty()) summary.pop_back();
        std::cout << fmt::format("frame {}: {}x{} px, {} ray{} per pixel, {} steps, texture {}^3:{} ({})\n", frame,
                                 v.image.width, v.image.height, r.view.samples, r.view.samples == 1 ? "" : "s",
                                 r.view.steps, scene.params().texture_size, summary, threads_text());
      });
  spdlog::info("wrote {} in {:.1f} s", r.out.string(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count());
  return 0;
}

}  // namespace

Command add_render_command(CLI::App& app, const GlobalOptions& g) {
  auto o = std::make_shared<RenderOptions>();
  auto* rend = app.add_subcommand("render", "Render 3D fractal clouds from a sensor (GEO, LEO or any camera)");
  add_weather_source_options(rend, o->weather);
  rend->add_option("--sensor", o->sensor,
                   "geo:LON | leo:LAT,LON,ALT_KM,FOV_DEG | abi:east | abi:west | abi:LON (the GOES-R fixed grid) | "
                   "camera TOML file")
      ->capture_default_str();
  rend->add_option("--size", o->size, "Focal-plane array WIDTHxHEIGHT [pixels]")->capture_default_str();
  rend->add_option("--types", o->types, "Cloud types, comma-separated")->capture_default_str();
  rend->add_option(
          "--bands", o->bands,
          "Bands, comma-separated: " + optics::band_names() + " (GOES-16 ABI bands 1-16, also named C01..C16), or all")
      ->capture_default_str();
  rend->add_option("--steps", o->steps, "Ray-marching steps per shell")->capture_default_str();
  rend->add_option("--samples", o->samples,
                   "Rays per pixel, a square k^2 (1, 4, 9, ... 256): the mean of one ray per sub-pixel of a k x k "
                   "grid, each at a hashed point of its sub-pixel (stratified)")
      ->capture_default_str();
  rend->add_flag("--sample-grid", o->sample_grid,
                 "With --samples: each ray at its sub-pixel's centre (a regular grid) instead of stratified");
  rend->add_flag("--no-atmosphere", o->no_atmosphere,
                 "No gases, Rayleigh scattering or emission of the air between scene and sensor (a vacuum; for "
                 "comparison)");
  rend->add_flag("--no-shadows", o->no_shadows,
                 "Direct sunlight not dimmed by the clouds towards the Sun (for speed comparisons)");
  rend->add_flag("--no-filter", o->no_filter,
                 "Point samples of the fractal clouds, detail finer than a pixel not filtered (aliased; for "
                 "comparison and supersampled references)");
  rend->add_option("--texture", o->texture,
                   "Fractal texture size N (N^3 voxels, power of two 8..1024; default 256 or the config's [textures] "
                   "size)");
  rend->add_option("--displace-hours", o->displace_hours, "Wind displacement of all fractals [h] (default: per type)");
  rend->add_option("--advance-hours", o->advance_hours, "Propagate the displacement maps by H hours (per frame)");
  rend->add_option("--frames", o->frames, "Number of frames (each advanced by --advance-hours)")->capture_default_str();
  rend->add_option("--time", o->time,
                   "UTC of the (first) frame, for the Sun and the L1b files, ISO 8601 (default: the weather's valid "
                   "time plus the wind's advance)");
  rend->add_option("--config", o->config, "TOML with [clouds.*], [textures], [displacement], [masks.*] parameters");
  rend->add_option("--out", o->out, "Output directory")->capture_default_str();
  rend->add_option("--scene", o->scene, "abi sensors: full | conus | meso:LAT,LON (the sector; --size is ignored)")
      ->capture_default_str();
  rend->add_option("--abi-step", o->abi_step, "abi sensors: coarsen the fixed grid by N (quick looks)")
      ->capture_default_str();
  rend->add_option("--format", o->format,
                   "netcdf (render.nc, render.exr, PNGs) | abi-l1b (one ABI L1b NetCDF file per band; abi sensors)")
      ->capture_default_str();
  return {rend, [o, &g] { return run(*o, g); }};
}

}  // namespace nephos::app
