// nephos render: the 3D fractal clouds of the weather, ray-marched from a GEO, LEO or any
// camera, in the visible, near-IR and thermal-IR bands of GOES-16 ABI (docs/render.md).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <memory>

#include <optional>
#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/atomic_file.hpp"
#include "nephos/core/config.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"

#include "nephos/clouds/cloud_model.hpp"
#include "nephos/earth/sun.hpp"
#include "nephos/optics/optics.hpp"
#include "nephos/render/outputs.hpp"
#include "nephos/render/renderer.hpp"
#include "nephos/render/sensor.hpp"
#include "nephos/weather/masks.hpp"

namespace fs = std::filesystem;

namespace nephos::app {

namespace {

struct RenderOptions {
  WeatherSource weather;
  std::string sensor = "geo:-75.2";
  std::string size = "1000x1000";
  std::string types = "low_stratus,low_cumulus,altostratus,cirrus";
  std::string bands = "vis,nir,lwir";
  int steps = 25;
  int samples = 1;             // rays per pixel, k^2
  bool sample_grid = false;    // sub-pixel rays at the sub-pixels' centres instead of stratified
  int texture = 0;             // 0: the config's [textures] size (default 256)
  std::string displace_hours;  // empty: per-type defaults
  double advance_hours = 0;
  int frames = 1;
  std::string time;
  std::string config;
  std::string out = "out";
};

int run_render(const RenderOptions& o, const GlobalOptions& g) {
  const auto t_start = std::chrono::steady_clock::now();
  // Parse everything before any work, so that bad input fails fast and writes nothing.
  const auto [width, height] = parse_size(o.size);
  std::vector<weather::CloudType> types;
  for (const auto& t : split_distinct(o.types, "--types")) types.push_back(weather::cloud_type_from_name(t));
  render::RenderParams rp;
  rp.set_bands(split(o.bands, "--bands"), "--bands");
  rp.set_steps(o.steps, "--steps");
  rp.set_rays_per_pixel(o.samples, "--samples");
  rp.stratified_samples = !o.sample_grid;
  rp.sample_seed = g.seed;
  if (o.frames < 1) throw ValueError("must be >= 1", {.key = "--frames"});
  require_range(o.advance_hours, -clouds::CloudModelParams::max_displace_hours,
                clouds::CloudModelParams::max_displace_hours, "--advance-hours", "the advance per frame [h]");
  std::optional<double> displace_hours;
  if (!o.displace_hours.empty()) displace_hours = parse_numbers(o.displace_hours, 1, "--displace-hours", "hours")[0];
  clouds::CloudModelParams cp;
  weather::MaskParams mp;
  if (!o.config.empty()) {
    const ParamDict dict = ParamDict::from_file(o.config);
    cp = clouds::CloudModelParams::from(dict);
    mp = weather::MaskParams::from(dict);
    dict.check_unused();
  }
  cp.set_texture_size(o.texture != 0 ? o.texture : cp.texture_size, "--texture");
  const int tex = cp.texture_size;
  if (displace_hours) cp.set_displace_hours(*displace_hours, "--displace-hours");
  const render::Sensor sensor = render::parse_sensor(o.sensor, width, height);
  // The image and, while the previews are written, one byte per pixel and channel more.
  require_memory(render::render_memory_bytes(width, height, rp) + 3.0 * width * height, "--size",
                 fmt::format("a {}x{} image with {} rays per pixel", width, height, o.samples));

  const weather::WeatherGrid w = load_weather(o.weather, g.seed);
  const UtcTime time = o.time.empty() ? w.metadata().valid_time : parse_time(o.time, "--time");
  const earth::SunPosition sun = earth::sun_position(time);
  spdlog::info("sensor: {}", sensor.description);
  spdlog::info("time {}: subsolar point {:.2f}, {:.2f}", time.iso(), sun.subsolar_lat_deg, sun.subsolar_lon_deg);
  const weather::WeatherMasks masks = weather::compute_masks(w, mp);
  clouds::CloudScene scene = clouds::build_scene(w, masks, cp, types, g.seed);
  if (o.advance_hours != 0) clouds::advance_scene(scene, o.advance_hours, cp);

  const fs::path out(o.out);
  ensure_directory(out);
  for (int frame = 0; frame < o.frames; ++frame) {
    if (frame > 0) clouds::advance_scene(scene, o.advance_hours, cp);
    const render::RenderImage img = render::render(scene, sensor, sun, rp, &w);
    const fs::path dir = o.frames == 1 ? out : out / fmt::format("frame_{:03d}", frame);
    ensure_directory(dir);
    render::FrameMetadata meta{w.metadata().source,
                               sensor.description,
                               time.iso(),
                               sun.subsolar_lat_deg,
                               sun.subsolar_lon_deg,
                               g.seed,
                               o.steps,
                               tex,
                               o.samples,
                               o.samples == 1  ? "centre"
                               : o.sample_grid ? "grid"
                                               : "stratified",
                               {}};
    for (auto t : types) meta.types.emplace_back(weather::name(t));
    render::write_render_netcdf(dir / "render.nc", img, meta);
    render::write_render_exr(dir / "render.exr", img);
    render::write_render_previews(dir, img);
    std::string summary;
    for (const auto& [name, secs] : img.seconds_per_type) summary += fmt::format(" {} {:.0f} ms,", name, secs * 1e3);
    if (!summary.empty()) summary.pop_back();
    std::cout << fmt::format("frame {}: {}x{} px, {} ray{} per pixel, {} steps, texture {}^3:{} ({})\n", frame, width,
                             height, o.samples, o.samples == 1 ? "" : "s", o.steps, tex, summary, threads_text());
  }
  spdlog::info("wrote {} in {:.1f} s", out.string(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count());
  return 0;
}

}  // namespace

Command add_render_command(CLI::App& app, const GlobalOptions& g) {
  auto o = std::make_shared<RenderOptions>();
  auto* rend = app.add_subcommand("render", "Render 3D fractal clouds from a sensor (GEO, LEO or any camera)");
  add_weather_source_options(rend, o->weather);
  rend->add_option("--sensor", o->sensor, "geo:LON | leo:LAT,LON,ALT_KM,FOV_DEG | camera TOML file")
      ->capture_default_str();
  rend->add_option("--size", o->size, "Focal-plane array WIDTHxHEIGHT [pixels]")->capture_default_str();
  rend->add_option("--types", o->types, "Cloud types, comma-separated")->capture_default_str();
  rend->add_option(
          "--bands", o->bands,
          "Bands, comma-separated: " + optics::band_names() + " (GOES-16 ABI bands 2, 3, 13, 1, 5, 6, 7, 14, 15)")
      ->capture_default_str();
  rend->add_option("--steps", o->steps, "Ray-marching steps per shell")->capture_default_str();
  rend->add_option("--samples", o->samples,
                   "Rays per pixel, a square k^2 (1, 4, 9, ... 256): the mean of one ray per sub-pixel of a k x k "
                   "grid, each at a hashed point of its sub-pixel (stratified)")
      ->capture_default_str();
  rend->add_flag("--sample-grid", o->sample_grid,
                 "With --samples: each ray at its sub-pixel's centre (a regular grid) instead of stratified");
  rend->add_option("--texture", o->texture,
                   "Fractal texture size N (N^3 voxels, power of two 8..1024; default 256 or the config's [textures] "
                   "size)");
  rend->add_option("--displace-hours", o->displace_hours, "Wind displacement of all fractals [h] (default: per type)");
  rend->add_option("--advance-hours", o->advance_hours, "Propagate the displacement maps by H hours (per frame)");
  rend->add_option("--frames", o->frames, "Number of frames (each advanced by --advance-hours)")->capture_default_str();
  rend->add_option("--time", o->time, "UTC time for the Sun, ISO 8601 (default: the weather's valid time)");
  rend->add_option("--config", o->config, "TOML with [clouds.*], [textures], [displacement], [masks.*] parameters");
  rend->add_option("--out", o->out, "Output directory")->capture_default_str();
  return {rend, [o, &g] { return run_render(*o, g); }};
}

}  // namespace nephos::app
