// nephos bench render|fly|particles|lbm: the benchmarks, each printing its figures beside its
// anchor (bench/).
#include <memory>

#include "command.hpp"
#include "fly_bench.hpp"
#include "lbm_bench.hpp"
#include "particles_bench.hpp"
#include "render_bench.hpp"

namespace nephos::app {

std::vector<Command> add_bench_commands(CLI::App& app, const GlobalOptions& g) {
  auto* bench = app.add_subcommand("bench", "Benchmarks that print measured figures beside their anchors");
  bench->require_subcommand(1);
  auto rbo = std::make_shared<bench::RenderBenchOptions>();
  auto* bench_render = bench->add_subcommand("render", "Table 3 configurations of the fractal renderer");
  bench_render->add_option("--type", rbo->type, "Cloud type to render")->capture_default_str();
  bench_render->add_option("--repeat", rbo->repeat, "Timed repetitions per configuration (median reported)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  bench_render->add_flag("--quick", rbo->quick, "Smaller images (for CI smoke runs); figures not comparable");
  auto fbo = std::make_shared<bench::FlyBenchOptions>();
  auto* bench_fly = bench->add_subcommand("fly", "Sprite-cloud frame times for the thesis's test matrix");
  bench_fly
      ->add_option("--frames", fbo->frames,
                   "Frames per case (600: the thesis's 20-second tests at 30 frames per second)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  bench_fly->add_option("--tests", fbo->tests, "Which of the thesis's tests A-E to run (letters, e.g. E)")
      ->capture_default_str();
  bench_fly->add_option("--plot", fbo->plot, "PNG bar plot of p95 frame times (empty: none)")->capture_default_str();
  bench_fly
      ->add_option("--paired-block", fbo->paired_block,
                   "Test E's paired measure: frames per block of each renderer in turn (1: frame by frame)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  auto pbo = std::make_shared<bench::ParticlesBenchOptions>();
  auto* bench_part =
      bench->add_subcommand("particles", "Particle generation rate and frame times, with and without LOD");
  bench_part->add_option("--frames", pbo->frames, "Frames per case (median reported)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  bench_part
      ->add_option("--max-count", pbo->max_count,
                   "Largest particle count: 100000 or more (10^5 and 10^6 by default; 10^5 alone below 10^6)")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{100000}, std::size_t{1000000000}));
  auto lbo = std::make_shared<bench::LbmBenchOptions>();
  auto* bench_lbm = bench->add_subcommand("lbm", "Lattice-Boltzmann kernels beside the memory roofline");
  bench_lbm->add_option("--size", lbo->size, "Lattice edge (N^3 cells, 8..1024)")
      ->capture_default_str()
      ->check(CLI::Range(8, 1024));
  bench_lbm->add_option("--repeat", lbo->repeat, "Timed repetitions (median reported)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  bench_lbm
      ->add_option(
          "--kernels", lbo->kernels,
          "Comma-separated subset of bgk, water, water16 (FP16 storage), percolation, lighting, raycast (the last "
          "three run together)")
      ->capture_default_str();
  return {{bench_render, [rbo, &g] { return bench::run_render_bench(*rbo, g.seed); }},
          {bench_fly, [fbo, &g] { return bench::run_fly_bench(*fbo, g.seed); }},
          {bench_part, [pbo, &g] { return bench::run_particles_bench(*pbo, g.seed); }},
          {bench_lbm, [lbo, &g] { return bench::run_lbm_bench(*lbo, g.seed); }}};
}

}  // namespace nephos::app
