#include "nephos/particles/job.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <fstream>

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

namespace nephos::particles {

namespace {

// Per particle: its state, motion, shading, sort keys and instance data, about 256 B.
constexpr double bytes_per_particle = 256;

void check(const ParticlesRequest& r) {
  require_image_size(r.width, r.height, "size");
  if (r.frames < 1) throw ValueError("must be >= 1", {.key = "frames"});
  if (r.count < 1) throw ValueError("must be >= 1", {.key = "count"});
  require_memory(bytes_per_particle * static_cast<double>(r.count), "count", fmt::format("{} particles", r.count));
  require_range(r.frame_minutes, 1e-3, 1e6, "frame_minutes", "the time between frames [min]");
  require_range(r.lod_l0_km, 0, 1e5, "lod_l0_km",
                "eq. 13's L0 [km] (0: 60 % of the camera's distance to the region's centre)");
  if (r.camera) {
    for (double v : *r.camera)
      if (!std::isfinite(v))
        throw ValueError(
            fmt::format("expected five finite numbers (X_KM, Y_KM, ALT_KM, HEADING_DEG, PITCH_DEG), got {}", v),
            {.key = "camera"});
    require_range((*r.camera)[2], 0, 1e5, "camera", "the camera's altitude [km]");
    require_range((*r.camera)[4], -90, 90, "camera", "the camera's pitch [deg]");
  }
  if (!r.wrf.empty() && !r.weather.empty())
    throw ValueError("weather files and WRF output both given: give one", {.key = "wrf"});
  if (r.refine < 0) throw ValueError("must be >= 0", {.key = "refine"});
}

// The request's weather as particle weather: WRF's own grid, or GFS's cells over the region,
// refined as asked (by default GFS's to cells of at most 30 km).
ParticleWeather particle_weather(const ParticlesRequest& r) {
  ParticleWeather pw;
  if (!r.wrf.empty()) {
    pw = read_wrf(r.wrf, r.region);
  } else {
    std::vector<weather::WeatherGrid> grids;
    if (r.weather.empty()) grids.push_back(weather::open_weather(weather::default_weather_file()));
    for (const auto& f : r.weather)  // every valid time of every file
      for (auto& w : weather::open_weather_times(f)) grids.push_back(std::move(w));
    pw = from_weather_grids(grids, r.region.value_or(default_gfs_region));
  }
  const int factor = r.refine > 0 ? r.refine : r.wrf.empty() ? refine_factor_for(pw.grid, default_refined_cell_m) : 1;
  if (factor > 1) {
    // The refined frames: three column fields and four per wind level, 4 B each.
    const double columns = static_cast<double>(pw.grid.cols) * pw.grid.rows * factor * factor;
    require_memory(columns * static_cast<double>(pw.frames.size()) * (3 + 4 * pw.frames.front().wind.levels) * 4.0,
                   "refine", fmt::format("the weather refined {} x {}", factor, factor));
    pw = refine(pw, factor);
  }
  return pw;
}

SceneParams scene_params(const ParticlesRequest& r) {
  SceneParams sp;
  sp.generation.count = r.count;
  sp.generation.k = r.k;
  sp.generation.seed = r.seed;
  sp.lod = r.lod;
  sp.lod_params.l0_m = r.lod_l0_km * 1000;
  sp.illumination.transmission = r.transmission;
  return sp;
}

// The request's camera, or the scene's default (south of the region, looking north).
realtime::Camera camera_for(const ParticlesRequest& r, const ParticleScene& scene) {
  realtime::Camera cam = scene.default_camera();
  if (r.camera) {
    const auto& c = *r.camera;
    const double h = c[3] * earth::deg, p = c[4] * earth::deg;
    cam.position = {c[0] * 1000, c[1] * 1000, c[2] * 1000};
    cam.forward = {std::sin(h) * std::cos(p), std::cos(h) * std::cos(p), std::sin(p)};
  }
  return cam;
}

}  // namespace

Transmission transmission_named(const std::string& name, const std::string& key) {
  if (name == "two-stream") return Transmission::two_stream;
  if (name == "beer") return Transmission::beer;
  throw ValueError("must be 'two-stream' or 'beer', got '" + name + "'", {.key = key});
}

ParticlesResult run_particles(const ParticlesRequest& r) {
  check(r);
  ParticleWeather pw = particle_weather(r);
  spdlog::info("particle weather: {} columns x {} rows of {:.1f} x {:.1f} km, {} time(s), max optical thickness {:.1f}",
               pw.grid.cols, pw.grid.rows, pw.grid.dx_m / 1000, pw.grid.dy_m / 1000, pw.frames.size(),
               pw.frames.front().columns.max_tau());
  const auto t_gen = std::chrono::steady_clock::now();
  ParticleScene scene(std::move(pw), scene_params(r));
  ParticlesResult res;
  res.generation_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_gen).count();
  const ParticleWeather& w = scene.weather();
  res.particles = scene.initial().size(), res.source = w.source;
  res.cols = w.grid.cols, res.rows = w.grid.rows, res.cell_dx_m = w.grid.dx_m, res.cell_dy_m = w.grid.dy_m;
  const realtime::Camera cam = camera_for(r, scene);
  // Frames spread over the weather's times, or frame_minutes apart when it has one.
  const double t_last = w.frames.back().time_s;
  auto frame_time = [&](int f) {
    if (w.frames.size() > 1 && r.frames > 1) return t_last * f / (r.frames - 1);
    return f * r.frame_minutes * 60.0;
  };
  realtime::SpriteRenderer renderer(r.width, r.height, r.seed);  // before any output
  ensure_directory(r.out);
  write_columns_netcdf(r.out / "columns.nc", w, 0);
  if (r.transparent) renderer.set_background(realtime::SpriteRenderer::Background::transparent);
  AtomicFile csv(r.out / "frames.csv");
  std::ofstream table(csv.temp_path());
  table << "frame,time_utc,time_s,particles,drawn,motion_ms,lod_ms,light_ms,sort_ms,draw_ms\n";
  Progress progress("particles", static_cast<std::size_t>(r.frames));
  for (int f = 0; f < r.frames; ++f) {
    const double t = frame_time(f);
    const auto t0 = std::chrono::steady_clock::now();
    scene.move_to(t);
    const double motion_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    FrameTimings tm;
    const realtime::PointSprites sprites = scene.sprites(t, cam.position, &tm);
    const realtime::FrameStats st = renderer.draw_points(sprites, cam);
    const std::string time_utc = scene.time_at(t).iso();
    table << fmt::format("{},{},{:.0f},{},{},{:.2f},{:.2f},{:.2f},{:.2f},{:.2f}\n", f, time_utc, t,
                         scene.current().size(), tm.drawn, motion_ms, tm.lod_ms, tm.light_ms, tm.sort_ms,
                         st.milliseconds);
    res.frames.push_back({t, time_utc, scene.current().size(), tm.drawn});
    realtime::write_frame_png(r.out / fmt::format("frame_{:04d}.png", f), renderer, r.transparent);
    if (r.ply)
      write_particles_ply(r.out / fmt::format("particles_{:04d}.ply", f), scene.current(), scene.shade_all(t), w,
                          scene.time_at(t));
    progress.advance();
  }
  csv.commit(table);
  return res;
}

}  // namespace nephos::particles
