// nephos lbm: the lattice-Boltzmann convective cloud, water model, percolation, lighting and
// ray casting, in one process or across MPI ranks (docs/lbm.md).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <memory>

#include <algorithm>
#include <cmath>
#include <limits>
#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/atomic_file.hpp"
#include "nephos/core/config.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/progress.hpp"

#include "lbm_mpi.hpp"
#include "nephos/io/png.hpp"
#include "nephos/io/vdb_writer.hpp"
#include "nephos/lbm/lbm_io.hpp"
#include "nephos/lbm/lighting.hpp"
#include "nephos/lbm/percolation.hpp"
#include "nephos/lbm/raycast.hpp"
#include "nephos/lbm/water_model.hpp"

namespace fs = std::filesystem;

namespace nephos::app {

namespace {

struct LbmOptions {
  std::string grid = "128x128x128";
  static constexpr int silos_unset = std::numeric_limits<int>::min();
  int silos = silos_unset;  // unset: the parameter file's (default 4)
  long iterations = 20;
  long checkpoint_every = 0;
  int percolation = 5;         // K; 0: skip the stage
  std::string sun = "135,45";  // azimuth, elevation [deg]
  std::string size = "640x480";
  std::string resume;
  std::string config;
  std::string storage;  // empty: the parameter file's (default fp32)
  std::string out = "out/lbm";
};

int run_lbm(const LbmOptions& o, const GlobalOptions& g) {
  const auto t_start = std::chrono::steady_clock::now();
  if (o.iterations < 0) throw ValueError("must be >= 0", {.key = "--iterations"});
  const auto image_size = parse_size(o.size);
  const auto sun = parse_numbers(o.sun, 2, "--sun", "AZIMUTH,ELEVATION in degrees");
  // The sunlight enters through the faces it illuminates from above: a sun on or below the
  // horizon lights nothing.
  if (!(sun[1] > 0 && sun[1] <= 90))
    throw ValueError(fmt::format("the sun's elevation must be in (0, 90] deg, got {:g}", sun[1]), {.key = "--sun"});
  if (o.checkpoint_every < 0) throw ValueError("must be >= 0 (0: never)", {.key = "--checkpoint-every"});
  lbm::LightingParams lp;
  lp.sun_azimuth_deg = sun[0];
  lp.sun_elevation_deg = sun[1];

  lbm::WaterModelParams params;
  if (!o.config.empty()) {
    const ParamDict dict = ParamDict::from_file(o.config);
    params = lbm::WaterModelParams::from(dict);
    dict.check_unused();
  }
  if (o.silos != LbmOptions::silos_unset) params.set_silos(o.silos, "--silos");
  if (!o.storage.empty()) params.storage = lbm::parse_storage(o.storage);
  if (!o.resume.empty() && !o.storage.empty())
    throw ValueError("a resumed run keeps the storage of its checkpoint", {.key = "--storage"});
  const bool mpi = mpi_launched();  // every stage on slabs across the ranks
  {
    // What the stages hold at once, per cell [B] (docs/lbm.md): the water model's populations
    // and fields (one process), the percolation's five bits per refined site, the lighting's
    // two copies of 19 directions plus coefficients, and the output fields. Under MPI the
    // ranks share the three stages (slabs), and rank 0 gathers the fields.
    const lbm::Grid3 lattice =
        o.resume.empty() ? lbm::Grid3::parse(o.grid) : lbm::WaterModel::checkpoint_grid(o.resume);
    const double share = mpi ? 1.0 / mpi_size() : 1.0;
    const double water = params.bytes_per_cell() * share;
    const double percolation = (5.0 * std::pow(o.percolation, 3) / 8 + 8) * share, lighting = (2 * 19 * 4 + 8) * share,
                 fields = 5 * 4;
    require_memory(static_cast<double>(lattice.cells()) * (std::max({water, percolation, lighting}) + fields), "--grid",
                   fmt::format("the {} lattice with percolation K = {}", lattice.describe(), o.percolation));
  }
  const fs::path out(o.out);
  std::vector<float> vapour, temperature;
  std::vector<float> local_vapour;  // under MPI: this rank's slab of the vapour
  lbm::Grid3 grid;
  long done = 0, steps_total = 0;
  double t_water = 0;
  if (mpi) {
    ensure_directory(out);  // on every rank: a failure must stop all of them, not leave them waiting
    if (mpi_rank() != 0) Progress::set_enabled(false);  // one progress line per stage, rank 0's
    auto r = run_water_mpi(o.resume.empty() ? lbm::Grid3::parse(o.grid) : lbm::Grid3{}, params, g.seed,
                           {o.iterations, o.checkpoint_every, o.resume, out});
    grid = r.grid;
    vapour = std::move(r.vapour);  // rank 0 only
    temperature = std::move(r.temperature);
    local_vapour = std::move(r.local_vapour);
    done = r.steps_done - r.first_step;
    steps_total = r.steps_done;
    t_water = r.seconds;
    if (mpi_rank() == 0)
      spdlog::info("water model on {} MPI processes{}", mpi_size(),
                   o.resume.empty() ? "" : fmt::format(", resumed at step {} from {}", r.first_step, o.resume));
  } else {
    lbm::WaterModel model =
        o.resume.empty() ? lbm::WaterModel(lbm::Grid3::parse(o.grid), params) : lbm::WaterModel::load(o.resume);
    if (o.resume.empty()) {
      model.initialise(lbm::make_silos(model.grid(), params, g.seed), g.seed);
      spdlog::info("water model {} with {} silos (seed {})", model.grid().describe(), params.silos, g.seed);
    } else {
      spdlog::info("resumed {} at step {} from {}", model.grid().describe(), model.steps_done(), o.resume);
    }
    ensure_directory(out);
    grid = model.grid();
    auto check = [&] {
      const auto bad = model.bad_density();
      if (!bad) return;
      const auto ck = out / "checkpoint_failed.bin";
      model.save(ck);
      throw NumericError(fmt::format("{}; state saved to {}", *bad, ck.string()));
    };
    const long first = model.steps_done();
    t_water = step_water_model(model, o.iterations, o.checkpoint_every, out, check,
                               [&](const fs::path& path) { model.save(path); });
    vapour = model.vapour();
    temperature = model.temperature();
    done = model.steps_done() - first;
    steps_total = model.steps_done();
  }
  // Percolation and lighting: under MPI each rank works on its slab (halo rows exchanged with
  // its neighbours, docs/lbm.md) and rank 0 gathers the fields; otherwise on the whole lattice.
  std::vector<float> percolated;
  double t_perc = 0;
  int perc_steps = 0;
  if (o.percolation > 0) {
    const auto tp = std::chrono::steady_clock::now();
    lbm::PercolationParams pp;
    pp.refinement = o.percolation;
    pp.rho10 = params.rho10;
    // Steps to the end of activity are not known in advance: the line counts them.
    Progress progress("percolation", Progress::OpenEnded{});
    auto on_step = [&](int, std::size_t active) {
      progress.set_detail(fmt::format("{} active sites", active));
      progress.advance();
    };
    if (mpi) {
      auto r = run_percolation_mpi(grid, local_vapour, pp, g.seed, on_step);
      perc_steps = r.steps;
      percolated = std::move(r.local_density);  // this rank's slab until gathered
    } else {
      lbm::Percolation perc(grid, vapour, pp, g.seed);
      perc_steps = perc.run({.after_step = on_step});
      percolated = perc.coarse_density();
    }
    t_perc = std::chrono::duration<double>(std::chrono::steady_clock::now() - tp).count();
  }
  // Lighting (lattice-Boltzmann photon transport) of the cloud density, then ray casting.
  std::vector<float> cloud = percolated;
  if (cloud.empty()) {  // without percolation: condensate where the vapour exceeds rho10
    const std::vector<float>& v = mpi ? local_vapour : vapour;
    cloud.resize(v.size());
    for (std::size_t c = 0; c < v.size(); ++c)
      cloud[c] = static_cast<float>(std::clamp((v[c] - params.rho10) / (0.1 * params.rho10), 0.0, 1.0));
  }
  const auto tl = std::chrono::steady_clock::now();
  std::vector<float> light;
  int light_steps = 0;
  double light_residual = 0;
  {
    // Steps to the steady state are not known in advance: the line counts them and shows the
    // photon-balance residual against its tolerance.
    Progress progress("lighting", Progress::OpenEnded{});
    auto on_step = [&](const lbm::LightingSolver& s) {
      progress.set_detail(fmt::format("residual {:.1e} (to {:.0e})", s.residual(), lp.tolerance));
      progress.advance();
    };
    if (mpi) {
      auto r = run_lighting_mpi(grid, cloud, lp, on_step);
      light_steps = r.steps;
      light_residual = r.residual;
      light = gather_slabs(grid, r.local_light);
      cloud = gather_slabs(grid, cloud);
      if (!percolated.empty()) percolated = gather_slabs(grid, percolated);
    } else {
      lbm::LightingSolver lighting(grid, cloud, lp);
      light_steps = lighting.solve(on_step);
      light_residual = lighting.residual();
      light = lighting.light();
    }
  }
  if (mpi && mpi_rank() != 0) return 0;  // rank 0 casts the rays and writes the outputs
  const double t_light = std::chrono::duration<double>(std::chrono::steady_clock::now() - tl).count();
  const auto tr = std::chrono::steady_clock::now();
  lbm::RaycastParams rp;
  std::tie(rp.width, rp.height) = image_size;
  rp.sun_azimuth_deg = lp.sun_azimuth_deg;
  rp.sun_elevation_deg = lp.sun_elevation_deg;
  const auto image = lbm::raycast(grid, cloud, light, rp);
  io::write_png(out / "render.png", rp.width, rp.height, 3, image);
  const double t_ray = std::chrono::duration<double>(std::chrono::steady_clock::now() - tr).count();

  std::vector<lbm::LatticeField> fields{
      {"vapour_density", "water vapour density (lattice units; condensation above rho10)", "1", &vapour},
      {"temperature", "temperature (lattice units)", "1", &temperature}};
  if (!percolated.empty())
    fields.push_back(
        {"percolated_density", "cloud fraction of each cell after Nagel-Raschke percolation", "1", &percolated});
  fields.push_back(
      {"light", "steady-state photon density (sum over lattice directions; sunlight injected at 1)", "1", &light});
  lbm::write_lattice_netcdf(out / "lbm.nc", grid, fields,
                            {{"title", "nephos lattice-Boltzmann convective cloud"},
                             {"steps", std::to_string(steps_total)},
                             {"seed", std::to_string(g.seed)}});
  // The volumes for Blender/Houdini: "density" is the cloud the renderers expect.
  const int nx = grid.nx, ny = grid.ny, nz = grid.nz;
  io::write_vdb(out / "clouds.vdb", {{"density", nx, ny, nz, &cloud, 1.0, true, 0.0f},
                                     {"vapour", nx, ny, nz, &vapour, 1.0, false, -1.0f},
                                     {"temperature", nx, ny, nz, &temperature, 1.0, false, -1.0f},
                                     {"light", nx, ny, nz, &light, 1.0, false, 0.0f}});
  std::cout << fmt::format("water model {}: {} steps in {:.2f} s ({:.3f} s/step, {})\n", grid.describe(), done, t_water,
                           done > 0 ? t_water / static_cast<double>(done) : 0.0, threads_text());
  if (o.percolation > 0)
    std::cout << fmt::format("percolation K={}: {} steps in {:.2f} s\n", o.percolation, perc_steps, t_perc);
  std::cout << fmt::format("lighting: {} steps to residual {:.1e} in {:.2f} s\n", light_steps, light_residual, t_light);
  std::cout << fmt::format("ray casting {}x{}: {:.2f} s\n", rp.width, rp.height, t_ray);
  spdlog::info("wrote {} in {:.1f} s", (out / "lbm.nc").string(),
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
  return {lbmc, [o, &g] { return run_lbm(*o, g); }};
}

}  // namespace nephos::app
