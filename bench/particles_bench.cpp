#include "particles_bench.hpp"
#include "machine.hpp"
#include "stats.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <iostream>
#include <vector>

#include "nephos/core/parallel.hpp"
#include "nephos/particles/scene.hpp"
#include "nephos/realtime/gl/sprite_renderer.hpp"
#include "nephos/weather/reader.hpp"

namespace nephos::bench {
namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

int run_particles_bench(const ParticlesBenchOptions& o, std::uint64_t seed) {
  const auto grid = weather::open_weather(std::string(NEPHOS_DATA_DIR) + "/gfs_20110110_12z_f120_2p5deg.grib2");
  const particles::ParticleWeather coarse = particles::from_weather_grids({grid}, particles::default_gfs_region);
  // As `nephos particles` does by default: cells split to <= 30 km.
  const particles::ParticleWeather pw =
      particles::refine(coarse, particles::refine_factor_for(coarse.grid, particles::default_refined_cell_m));
  realtime::SpriteRenderer renderer(o.width, o.height, seed);
  std::cout << fmt::format(
      "nephos bench particles: embedded GFS sample, region 30N-65N 50W-10E refined to {} x {} columns, {} threads, "
      "{}x{} frames on headless {} on {}, median of {} frames\n"
      "(the particle-cloud paper publishes no timings to compare with)\n",
      pw.grid.cols, pw.grid.rows, thread_count(), o.width, o.height, renderer.gl_version(), renderer.gl_renderer(),
      o.frames);
  std::cout << describe_machine() << "\n";
  std::cout << fmt::format("{:>9} {:>4} {:>14} {:>8} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>9}\n", "particles", "LOD",
                           "generated/s", "drawn", "frame ms", "motion", "lod", "light", "sort", "draw", "frames/s");
  for (std::size_t n : {std::size_t{100000}, std::size_t{1000000}}) {
    if (n > o.max_count) continue;
    std::vector<double> gen;
    for (int r = 0; r < 3; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      const auto p = particles::generate(pw.grid, pw.frames[0].columns, {n, 1.0, seed + static_cast<unsigned>(r)});
      gen.push_back(ms_since(t0));
    }
    const double rate = static_cast<double>(n) / (median(gen) / 1000);
    for (bool lod : {true, false}) {
      particles::SceneParams sp;
      sp.generation.count = n;
      sp.generation.seed = seed;
      sp.lod = lod;
      particles::ParticleScene scene(pw, sp);
      const realtime::Camera cam = scene.default_camera();
      std::vector<double> total, motion, lodms, light, sort, draw;
      std::size_t drawn = 0;
      for (int f = 0; f < o.frames; ++f) {
        const double t = 600.0 * f;
        const auto t0 = std::chrono::steady_clock::now();
        scene.move_to(t);
        motion.push_back(ms_since(t0));
        particles::FrameTimings tm;
        const auto sprites = scene.sprites(t, cam.position, &tm);
        draw.push_back(renderer.draw_points(sprites, cam).milliseconds);
        total.push_back(ms_since(t0));
        lodms.push_back(tm.lod_ms), light.push_back(tm.light_ms), sort.push_back(tm.sort_ms);
        drawn = tm.drawn;
      }
      std::cout << fmt::format(
          "{:>9} {:>4} {:>14.3g} {:>8} {:>9.1f} {:>9.1f} {:>8.1f} {:>8.1f} {:>8.1f} {:>8.1f} {:>9.1f}\n", n,
          lod ? "on" : "off", rate, drawn, median(total), median(motion), median(lodms), median(light), median(sort),
          median(draw), 1000 / median(total));
    }
  }
  return 0;
}

}  // namespace nephos::bench
