// nephos lbm: the options of lbm::LbmRequest (docs/lbm.md), on one process or, under mpirun,
// on slabs across the processes; a summary line per stage.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <limits>
#include <memory>

#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/progress.hpp"
#include "nephos/lbm/job.hpp"
#if NEPHOS_HAVE_MPI
#include "nephos/lbm/mpi/slabs.hpp"
#endif

namespace nephos::app {

namespace {

struct LbmOptions {
  std::string grid = "128x128x128";
  static constexpr int silos_unset = std::numeric_limits<int>::min();
  int silos = silos_unset;  // unset: the parameter file's (default 4)
  long iterations = 20;
  long checkpoint_every = 0;
  int percolation = 5;
  std::string sun = "135,45";
  std::string size = "640x480";
  std::string resume;
  std::string config;
  std::string storage;  // empty: the parameter file's (default fp32)
  std::string out = "out/lbm";
};

lbm::LbmRequest request_of(const LbmOptions& o, const GlobalOptions& g) {
  lbm::LbmRequest r;
  if (o.resume.empty()) r.grid = lbm::Grid3::parse(o.grid);
  if (o.silos != LbmOptions::silos_unset) r.silos = o.silos;
  r.iterations = o.iterations;
  r.checkpoint_every = o.checkpoint_every;
  r.percolation = o.percolation;
  const auto sun = parse_numbers(o.sun, 2, "sun", "AZIMUTH,ELEVATION in degrees");
  r.sun_azimuth_deg = sun[0], r.sun_elevation_deg = sun[1];
  std::tie(r.width, r.height) = parse_size(o.size, "size");
  r.resume = o.resume;
  r.config = o.config;
  if (!o.storage.empty()) r.storage = lbm::parse_storage(o.storage);
  r.out = o.out;
  r.seed = g.seed;
  return r;
}

std::unique_ptr<lbm::Decomposition> decomposition() {
#if NEPHOS_HAVE_MPI
  if (lbm::mpi::launched()) {
    auto d = lbm::mpi::slabs();
    if (d->process() != 0) Progress::set_enabled(false);  // one progress line per stage, process 0's
    return d;
  }
#endif
  return std::make_unique<lbm::SingleProcess>();
}

int run(const LbmOptions& o, const GlobalOptions& g) {
  const auto t_start = std::chrono::steady_clock::now();
  const lbm::LbmRequest r = request_of(o, g);
  const auto d = decomposition();
  const lbm::LbmResult res = lbm::run_lbm(r, *d);
  if (d->process() != 0) return 0;
  const long done = res.steps_done - res.first_step;
  std::cout << fmt::format("water model {}: {} steps in {:.2f} s ({:.3f} s/step, {})\n", res.grid.describe(), done,
                           res.water_s, done > 0 ? res.water_s / static_cast<double>(done) : 0.0, threads_text());
  if (r.percolation > 0)
    std::cout << fmt::format("percolation K={}: {} steps in {:.2f} s\n", r.percolation, res.percolation_steps,
                             res.percolation_s);
  std::cout << fmt::format("lighting: {} steps to residual {:.1e} in {:.2f} s\n", res.lighting_steps,
                           res.lighting_residual, res.lighting_s);
  std::cout << fmt::format("ray casting {}x{}: {:.2f} s\n", r.width, r.height, res.raycast_s);
  spdlog::info("wrote {} in {:.1f} s", (r.out / "lbm.nc").string(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count());
  return 0;
}

}  // namespace

Command add_lbm_command(CLI::App& app, const GlobalOptions& g) {
  auto o = std::make_shared<LbmOptions>();
  auto* lbmc = app.add_subcommand(
      "lbm", "Lattice-Boltzmann convective clouds: water model, percolation, LB lighting, ray casting");
  lbmc->add_option("--grid", o->grid, "Lattice NXxNYxNZ (z up)")->capture_default_str();
  lbmc->add_option("--silos", o->silos, "Number of initial vapour silos (default 4)");
  lbmc->add_option("--iterations", o->iterations, "Total water-model steps")->capture_default_str();
  lbmc->add_option("--checkpoint-every", o->checkpoint_every,
                   "Write checkpoint.bin in the --out directory every N steps (0: never)");
  lbmc->add_option("--percolation", o->percolation, "Percolation refinement K (0: skip)")
      ->capture_default_str()
      ->check(CLI::Range(0, 16));
  lbmc->add_option("--sun", o->sun, "Sun AZIMUTH,ELEVATION [deg] (azimuth from +x towards +y)")->capture_default_str();
  lbmc->add_option("--size", o->size, "Rendered image WIDTHxHEIGHT")->capture_default_str();
  lbmc->add_option("--resume", o->resume, "Continue from a checkpoint file");
  lbmc->add_option("--config", o->config, "TOML with a [water] table");
  lbmc->add_option("--storage", o->storage,
                   "Population storage of the water model: fp32 (default) or fp16 (half the memory; see docs/lbm.md)");
  lbmc->add_option("--out", o->out, "Output directory")->capture_default_str();
  return {lbmc, [o, &g] { return run(*o, g); }};
}

}  // namespace nephos::app
