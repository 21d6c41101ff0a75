#include "nephos/lbm/decomposition.hpp"

namespace nephos::lbm {

Grid3 SingleProcess::lattice(const Grid3& grid, const std::filesystem::path& resume) {
  return resume.empty() ? grid : WaterModel::checkpoint_grid(resume);
}

WaterModel SingleProcess::water_model(const Grid3& grid, const WaterModelParams& params, std::uint64_t seed,
                                      const std::filesystem::path& resume) {
  if (!resume.empty()) return WaterModel::load(resume);
  WaterModel model(grid, params);
  model.initialise(make_silos(grid, params, seed), seed);
  return model;
}

PercolationRun SingleProcess::percolate(const Grid3& grid, const std::vector<float>& vapour,
                                        const PercolationParams& params, std::uint64_t seed,
                                        const std::function<void(int, std::size_t)>& after_step) {
  Percolation perc(grid, vapour, params, seed);
  PercolationRun run;
  run.steps = perc.run({.after_step = after_step});
  run.density = perc.coarse_density();
  return run;
}

LightingRun SingleProcess::light(const Grid3& grid, const std::vector<float>& density, const LightingParams& params,
                                 const std::function<void(const LightingSolver&)>& after_step) {
  LightingSolver solver(grid, density, params);
  LightingRun run;
  run.steps = solver.solve(after_step ? std::function<void(LightingSolver&)>([&](LightingSolver& s) { after_step(s); })
                                      : std::function<void(LightingSolver&)>());
  run.residual = solver.residual();
  run.light = solver.light();
  return run;
}

}  // namespace nephos::lbm
