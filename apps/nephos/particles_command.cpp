// nephos particles: particle-system clouds from WRF or GFS cloud top and optical thickness,
// moved, thinned with distance, lit and drawn (docs/particles.md).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <memory>

#include <cmath>
#include <fstream>
#include <optional>
#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/progress.hpp"

#include "nephos/earth/earth.hpp"
#include "nephos/particles/particles_io.hpp"
#include "nephos/particles/scene.hpp"
#include "nephos/particles/wrf_reader.hpp"
#include "nephos/realtime/gl/flight_job.hpp"
#include "nephos/realtime/gl/sprite_renderer.hpp"
#include "nephos/weather/reader.hpp"
#include "nephos/weather/source.hpp"

namespace fs = std::filesystem;

namespace nephos::app {

namespace {

struct ParticlesOptions {
  std::vector<std::string> weather;
  std::string wrf;
  std::string region;  // default: the whole WRF domain; for GFS the North Atlantic and Europe
  std::size_t count = 200000;
  int frames = 4;
  double frame_minutes = 30;
  std::string camera;  // X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG; default: south of the region
  std::string size = "1280x720";
  double k = 1;
  double lod_l0_km = 0;
  bool no_lod = false;
  std::string transmission = "two-stream";
  int refine = 0;  // 0: GFS cells split to <= 30 km, WRF as it is
  bool no_ply = false;
  std::string background = "sky";  // or "transparent"
  std::string out = "out/particles";
};

int run_particles(const ParticlesOptions& o, const GlobalOptions& g) {
  const auto [width, height] = parse_size(o.size, "size");
  if (o.frames < 1) throw ValueError("must be >= 1", {.key = "frames"});
  if (o.count < 1) throw ValueError("must be >= 1", {.key = "count"});
  const bool transparent = realtime::transparent_background(o.background);
  // Per particle: its state, motion, shading, sort keys and instance data, about 256 B.
  require_memory(256.0 * static_cast<double>(o.count), "count", fmt::format("{} particles", o.count));
  require_range(o.frame_minutes, 1e-3, 1e6, "frame_minutes", "the time between frames [min]");
  require_range(o.lod_l0_km, 0, 1e5, "lod_l0_km", "eq. 13's L0 [km] (0: a quarter of the region)");
  std::vector<double> camera;  // X_KM, Y_KM, ALT_KM, HEADING_DEG, PITCH_DEG; empty: the scene's default
  if (!o.camera.empty()) {
    camera = parse_numbers(o.camera, 5, "camera", "X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG");
    require_range(camera[2], 0, 1e5, "camera", "the camera's altitude [km]");
    require_range(camera[4], -90, 90, "camera", "the camera's pitch [deg]");
  }
  if (!o.wrf.empty() && !o.weather.empty()) throw ValueError("give --weather or --wrf, not both", {.key = "wrf"});
  particles::ParticleWeather pw;
  if (!o.wrf.empty()) {
    std::optional<particles::LatLonRegion> region;
    if (!o.region.empty()) region = particles::LatLonRegion::parse(o.region, "region");
    pw = particles::read_wrf(o.wrf, region);
  } else {
    std::vector<weather::WeatherGrid> grids;
    if (o.weather.empty()) grids.push_back(weather::open_weather(weather::default_weather_file()));
    for (const auto& f : o.weather)  // every valid time of every file
      for (auto& w : weather::open_weather_times(f)) grids.push_back(std::move(w));
    pw = particles::from_weather_grids(
        grids, o.region.empty() ? particles::default_gfs_region : particles::LatLonRegion::parse(o.region, "region"));
  }
  const int factor = o.refine > 0    ? o.refine
                     : o.wrf.empty() ? particles::refine_factor_for(pw.grid, particles::default_refined_cell_m)
                                     : 1;
  if (o.refine < 0) throw ValueError("must be >= 0", {.key = "refine"});
  if (factor > 1) {
    // The refined frames: three column fields and four per wind level, 4 B each.
    const double columns = static_cast<double>(pw.grid.cols) * pw.grid.rows * factor * factor;
    require_memory(columns * static_cast<double>(pw.frames.size()) * (3 + 4 * pw.frames.front().wind.levels) * 4.0,
                   "refine", fmt::format("the weather refined {} x {}", factor, factor));
    pw = particles::refine(pw, factor);
  }
  particles::SceneParams sp;
  sp.generation.count = o.count;
  sp.generation.k = o.k;
  sp.generation.seed = g.seed;
  sp.lod = !o.no_lod;
  sp.lod_params.l0_m = o.lod_l0_km * 1000;
  if (o.transmission == "beer")
    sp.illumination.transmission = particles::Transmission::beer;
  else if (o.transmission != "two-stream")
    throw ValueError("must be 'two-stream' or 'beer', got '" + o.transmission + "'", {.key = "transmission"});
  spdlog::info("particle weather: {} columns x {} rows of {:.1f} x {:.1f} km, {} time(s), max optical thickness {:.1f}",
               pw.grid.cols, pw.grid.rows, pw.grid.dx_m / 1000, pw.grid.dy_m / 1000, pw.frames.size(),
               pw.frames.front().columns.max_tau());
  const auto t_gen = std::chrono::steady_clock::now();
  particles::ParticleScene scene(std::move(pw), sp);
  const double gen_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_gen).count();
  const auto& w = scene.weather();

  realtime::Camera cam = scene.default_camera();
  if (!camera.empty()) {
    const auto& c = camera;
    const double h = c[3] * earth::deg, p = c[4] * earth::deg;
    cam.position = {c[0] * 1000, c[1] * 1000, c[2] * 1000};
    cam.forward = {std::sin(h) * std::cos(p), std::cos(h) * std::cos(p), std::sin(p)};
  }
  const double t_last = w.frames.back().time_s;
  auto frame_time = [&](int f) {
    if (w.frames.size() > 1 && o.frames > 1) return t_last * f / (o.frames - 1);
    return f * o.frame_minutes * 60.0;
  };

  const fs::path out(o.out);
  realtime::SpriteRenderer renderer(width, height, g.seed);  // before any output: it checks --size
  ensure_directory(out);
  particles::write_columns_netcdf(out / "columns.nc", w, 0);
  if (transparent) renderer.set_background(realtime::SpriteRenderer::Background::transparent);
  AtomicFile csv(out / "frames.csv");
  std::ofstream table(csv.temp_path());
  table << "frame,time_utc,time_s,particles,drawn,motion_ms,lod_ms,light_ms,sort_ms,draw_ms\n";
  Progress progress("particles", static_cast<std::size_t>(o.frames));
  for (int f = 0; f < o.frames; ++f) {
    const double t = frame_time(f);
    const auto t0 = std::chrono::steady_clock::now();
    scene.move_to(t);
    const double motion_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    particles::FrameTimings tm;
    const realtime::PointSprites sprites = scene.sprites(t, cam.position, &tm);
    const realtime::FrameStats st = renderer.draw_points(sprites, cam);
    table << fmt::format("{},{},{:.0f},{},{},{:.2f},{:.2f},{:.2f},{:.2f},{:.2f}\n", f, scene.time_at(t).iso(), t,
                         scene.current().size(), tm.drawn, motion_ms, tm.lod_ms, tm.light_ms, tm.sort_ms,
                         st.milliseconds);
    realtime::write_frame_png(out / fmt::format("frame_{:04d}.png", f), renderer, transparent);
    if (!o.no_ply)
      particles::write_particles_ply(out / fmt::format("particles_{:04d}.ply", f), scene.current(), scene.shade_all(t),
                                     w, scene.time_at(t));
    progress.advance();
  }
  csv.commit(table);
  std::cout << fmt::format(
      "particles: {} particles from {} ({} x {} columns) generated in {:.2f} s; {} frames of {}x{} in {}\n",
      scene.initial().size(), w.source, w.grid.cols, w.grid.rows, gen_s, o.frames, width, height, out.string());
  return 0;
}
}  // namespace

Command add_particles_command(CLI::App& app, const GlobalOptions& g) {
  auto o = std::make_shared<ParticlesOptions>();
  auto* part = app.add_subcommand("particles", "Particle-system clouds from WRF or GFS (cloud top, optical thickness)");
  part->add_option("--weather", o->weather, "GRIB weather file(s), one per time (default: the embedded GFS sample)");
  part->add_option("--wrf", o->wrf, "WRF output (wrfout NetCDF), all its times");
  part->add_option("--region", o->region, "LAT0,LON0,LAT1,LON1 [deg] (default: GFS 30,-50,65,10; WRF all)");
  part->add_option("--count", o->count, "Particles")->capture_default_str();
  part->add_option("--frames", o->frames, "Frames (spread over the weather's times)")->capture_default_str();
  part->add_option("--frame-minutes", o->frame_minutes, "Minutes between frames when the weather has one time")
      ->capture_default_str();
  part->add_option("--camera", o->camera, "X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG (default: south of the region)");
  part->add_option("--size", o->size, "Frame WIDTHxHEIGHT")->capture_default_str();
  part->add_option("--k", o->k, "Eq. 5's K: selection probability min(1, K tau / tau_max)")->capture_default_str();
  part->add_option("--lod-l0-km", o->lod_l0_km, "Eq. 13's L0 [km] (0: a quarter of the region)")->capture_default_str();
  part->add_flag("--no-lod", o->no_lod, "Draw every particle");
  part->add_option("--transmission", o->transmission, "two-stream or beer")->capture_default_str();
  part->add_option("--refine", o->refine, "Split each weather cell NxN (0: GFS to <= 30 km cells, WRF unchanged)")
      ->capture_default_str();
  part->add_flag("--no-ply", o->no_ply, "Do not write the particle set as PLY");
  part->add_option("--background", o->background,
                   "sky, or transparent: RGBA frames (alpha = cloud coverage) to composite over a map or terrain")
      ->capture_default_str();
  part->add_option("--out", o->out, "Output directory")->capture_default_str();
  return {part, [o, &g] { return run_particles(*o, g); }};
}

}  // namespace nephos::app
