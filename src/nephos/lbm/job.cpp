#include "nephos/lbm/job.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/config.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/progress.hpp"
#include "nephos/io/png.hpp"
#include "nephos/io/vdb_writer.hpp"
#include "nephos/lbm/lbm_io.hpp"
#include "nephos/lbm/raycast.hpp"

namespace nephos::lbm {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Everything a request can get wrong that needs no lattice: numbers, sun, storage with resume.
void check(const LbmRequest& r) {
  if (r.iterations < 0) throw ValueError("must be >= 0", {.key = "iterations"});
  if (r.checkpoint_every < 0) throw ValueError("must be >= 0 (0: never)", {.key = "checkpoint_every"});
  if (r.percolation < 0 || r.percolation > 16) throw ValueError("must be 0..16 (0: skip)", {.key = "percolation"});
  require_image_size(r.width, r.height, "size");
  LightingParams lp;
  lp.set_sun(r.sun_azimuth_deg, r.sun_elevation_deg, "sun");
  if (!r.resume.empty() && r.storage)
    throw ValueError("a resumed run keeps the storage of its checkpoint", {.key = "storage"});
}

// What the stages hold at once, per cell [B] (docs/lbm.md): the water model's populations and
// fields, the percolation's five bits per refined site, the lighting's two copies of 19
// directions plus coefficients, and the output fields. Slabs share the first three.
void check_memory(const Grid3& lattice, const WaterModelParams& params, int k, int processes) {
  const double share = 1.0 / processes;
  const double water = params.bytes_per_cell() * share;
  const double percolation = (5.0 * std::pow(k, 3) / 8 + 8) * share, lighting = (2 * 19 * 4 + 8) * share,
               fields = 5 * 4;
  require_memory(static_cast<double>(lattice.cells()) * (std::max({water, percolation, lighting}) + fields), "grid",
                 fmt::format("the {} lattice with percolation K = {}", lattice.describe(), k));
}

// The water stage: steps to `iterations` with a progress line, the densities checked every 10
// steps and at the end (a bad one saves out/checkpoint_failed.bin and stops), checkpoints
// every `checkpoint_every` steps.
void run_water(WaterModel& model, const LbmRequest& r, Decomposition& d) {
  auto check_densities = [&] {
    const auto bad = d.bad_density(model);
    if (!bad) return;
    const auto ck = r.out / "checkpoint_failed.bin";
    d.save_checkpoint(model, ck);
    throw NumericError(fmt::format("{}; state saved to {}", *bad, ck.string()));
  };
  {
    Progress progress("water model", static_cast<std::size_t>(std::max(0L, r.iterations - model.steps_done())));
    while (model.steps_done() < r.iterations) {
      model.step();
      progress.advance();
      if (model.steps_done() % 10 == 0) check_densities();
      if (r.checkpoint_every > 0 && model.steps_done() % r.checkpoint_every == 0)
        d.save_checkpoint(model, r.out / "checkpoint.bin");
    }
  }
  check_densities();
}

// The ray-cast image, lbm.nc and clouds.vdb (process 0).
void write_outputs(const LbmRequest& r, LbmResult& res) {
  const auto t0 = Clock::now();
  RaycastParams rp;
  rp.width = r.width, rp.height = r.height;
  rp.sun_azimuth_deg = r.sun_azimuth_deg;
  rp.sun_elevation_deg = r.sun_elevation_deg;
  io::write_png(r.out / "render.png", rp.width, rp.height, 3, raycast(res.grid, res.cloud, res.light, rp));
  res.raycast_s = seconds_since(t0);
  std::vector<LatticeField> fields{
      {"vapour_density", "water vapour density (lattice units; condensation above rho10)", "1", &res.vapour},
      {"temperature", "temperature (lattice units)", "1", &res.temperature}};
  if (!res.percolated.empty())
    fields.push_back(
        {"percolated_density", "cloud fraction of each cell after Nagel-Raschke percolation", "1", &res.percolated});
  fields.push_back(
      {"light", "steady-state photon density (sum over lattice directions; sunlight injected at 1)", "1", &res.light});
  write_lattice_netcdf(r.out / "lbm.nc", res.grid, fields,
                       {{"title", "nephos lattice-Boltzmann convective cloud"},
                        {"steps", std::to_string(res.steps_done)},
                        {"seed", std::to_string(r.seed)}});
  // The volumes for Blender/Houdini: "density" is the cloud the renderers expect.
  const int nx = res.grid.nx, ny = res.grid.ny, nz = res.grid.nz;
  io::write_vdb(r.out / "clouds.vdb", {{"density", nx, ny, nz, &res.cloud, 1.0, true, 0.0f},
                                       {"vapour", nx, ny, nz, &res.vapour, 1.0, false, -1.0f},
                                       {"temperature", nx, ny, nz, &res.temperature, 1.0, false, -1.0f},
                                       {"light", nx, ny, nz, &res.light, 1.0, false, 0.0f}});
}

}  // namespace

WaterModelParams water_params(const std::filesystem::path& config, std::optional<int> silos,
                              std::optional<Storage> storage) {
  WaterModelParams p;
  if (!config.empty()) {
    const ParamDict dict = ParamDict::from_file(config);
    p = WaterModelParams::from(dict);
    dict.check_unused();
  }
  if (silos) p.set_silos(*silos, "silos");
  if (storage) p.storage = *storage;
  return p;
}

std::vector<float> condensate_fraction(const std::vector<float>& vapour, double rho10) {
  std::vector<float> cloud(vapour.size());
  for (std::size_t c = 0; c < vapour.size(); ++c)
    cloud[c] = static_cast<float>(std::clamp((vapour[c] - rho10) / (0.1 * rho10), 0.0, 1.0));
  return cloud;
}

LbmResult run_lbm(const LbmRequest& r, Decomposition& d) {
  check(r);
  const WaterModelParams params = water_params(r.config, r.silos, r.storage);
  check_memory(d.lattice(r.grid, r.resume), params, r.percolation, d.processes());
  d.on_every_process([&] { ensure_directory(r.out); });  // a failure must stop every process
  LbmResult res;
  std::vector<float> vapour;  // this process's slab (the whole lattice with one process)
  {
    res.grid = d.lattice(r.grid, r.resume);
    WaterModel model = d.water_model(res.grid, params, r.seed, r.resume);
    if (r.resume.empty())
      spdlog::info("water model {} with {} silos (seed {}{})", res.grid.describe(), params.silos, r.seed,
                   d.processes() > 1 ? fmt::format(", {} MPI processes", d.processes()) : "");
    else
      spdlog::info("resumed {} at step {} from {}", res.grid.describe(), model.steps_done(), r.resume.string());
    res.first_step = model.steps_done();
    const auto t0 = Clock::now();
    run_water(model, r, d);
    res.water_s = seconds_since(t0);
    res.steps_done = model.steps_done();
    vapour = model.vapour();
    res.vapour = d.gather(res.grid, vapour);
    res.temperature = d.gather(res.grid, model.temperature());
  }
  PercolationParams pp;
  pp.refinement = std::max(r.percolation, 1);
  pp.rho10 = params.rho10;
  std::vector<float> cloud;
  if (r.percolation > 0) {
    const auto t0 = Clock::now();
    // Steps to the end of activity are not known in advance: the line counts them.
    Progress progress("percolation", Progress::OpenEnded{});
    PercolationRun run = d.percolate(res.grid, vapour, pp, r.seed, [&](int, std::size_t active) {
      progress.set_detail(fmt::format("{} active sites", active));
      progress.advance();
    });
    res.percolation_steps = run.steps;
    cloud = std::move(run.density);
    res.percolation_s = seconds_since(t0);
  } else {
    cloud = condensate_fraction(vapour, params.rho10);
  }
  LightingParams lp;
  lp.set_sun(r.sun_azimuth_deg, r.sun_elevation_deg, "sun");
  {
    const auto t0 = Clock::now();
    // Steps to the steady state are not known in advance: the line counts them and shows the
    // photon-balance residual against its tolerance.
    Progress progress("lighting", Progress::OpenEnded{});
    LightingRun run = d.light(res.grid, cloud, lp, [&](const LightingSolver& s) {
      progress.set_detail(fmt::format("residual {:.1e} (to {:.0e})", s.residual(), lp.tolerance));
      progress.advance();
    });
    res.lighting_steps = run.steps;
    res.lighting_residual = run.residual;
    res.light = d.gather(res.grid, run.light);
    res.lighting_s = seconds_since(t0);
  }
  res.cloud = d.gather(res.grid, cloud);
  if (r.percolation > 0) res.percolated = res.cloud;
  if (d.process() == 0) write_outputs(r, res);
  return res;
}

}  // namespace nephos::lbm
