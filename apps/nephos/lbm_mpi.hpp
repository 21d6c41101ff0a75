#pragma once
// Running the lattice-Boltzmann pipeline across MPI processes: the lattice is cut into slabs
// along y, one per rank. The water model's slabs exchange one halo row of populations before
// streaming and one of densities before the force computation; the percolation's two refined
// rows of activation before each step; the lighting's the photons that crossed a cut after
// each step. Results are bit-identical to one process.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include "nephos/lbm/lighting.hpp"
#include "nephos/lbm/percolation.hpp"
#include "nephos/lbm/water_model.hpp"

namespace nephos::app {

/// The water stage's loop, the same in one process and on every rank: steps `model` up to
/// `iterations` with a progress line, calls `check` (the densities) every 10 steps and at the
/// end, and `save` with out_dir/checkpoint.bin every `checkpoint_every` steps (0: never).
/// Returns the seconds it took.
double step_water_model(lbm::WaterModel& model, long iterations, long checkpoint_every,
                        const std::filesystem::path& out_dir, const std::function<void()>& check,
                        const std::function<void(const std::filesystem::path&)>& save);

/// True when this process was started by mpirun/mpiexec with more than one rank.
bool mpi_launched();
void mpi_init(int& argc, char**& argv);
void mpi_finalize();
int mpi_rank();
int mpi_size();

/// The first row of rank r's slab of a lattice `ny` rows long cut among `size` ranks (r = size:
/// ny).
int slab_begin(int ny, int r, int size);
/// The whole field on rank 0 (empty on the others) from every rank's slab ([z][y - begin][x]).
std::vector<float> gather_slabs(const lbm::Grid3& grid, const std::vector<float>& local);

struct WaterResult {
  lbm::Grid3 grid;                         ///< the whole lattice
  std::vector<float> vapour, temperature;  ///< whole lattice, on rank 0 only
  std::vector<float> local_vapour;         ///< this rank's slab, [z][y - slab_begin][x]
  long first_step = 0, steps_done = 0;     ///< step resumed from (0 for a fresh run), and reached
  double seconds = 0;
};

struct WaterMpiOptions {
  long iterations = 0;            ///< run until the model has done this many steps
  long checkpoint_every = 0;      ///< write out_dir/checkpoint.bin every N steps (0: never)
  std::filesystem::path resume;   ///< checkpoint to continue from (empty: fresh run)
  std::filesystem::path out_dir;  ///< where checkpoints go
};

/// Runs the water model on this rank's slab (a fresh run on `grid`, or resumed from a
/// checkpoint written with any process count) and gathers the fields on rank 0. Checkpoints
/// are gathered on rank 0 and written as one file, the format of a single-process run. Throws
/// NumericError on every rank if any rank finds a NaN or out-of-range density, after writing
/// out_dir/checkpoint_failed.bin.
WaterResult run_water_mpi(const lbm::Grid3& grid, const lbm::WaterModelParams& params, std::uint64_t seed,
                          const WaterMpiOptions& options);

/// Nagel-Raschke percolation of this rank's slab (refined rows of its lattice rows), two halo
/// rows of activation exchanged with the neighbouring ranks before every step; `after_step`
/// (optional) gets the step and the whole grid's active sites after it.
struct PercolationMpiResult {
  int steps = 0;
  std::vector<float> local_density;  ///< cloud fraction of this rank's slab, [z][y - slab_begin][x]
};
PercolationMpiResult run_percolation_mpi(const lbm::Grid3& grid, const std::vector<float>& local_vapour,
                                         const lbm::PercolationParams& params, std::uint64_t seed,
                                         const std::function<void(int, std::size_t)>& after_step = {});

/// Lattice-Boltzmann lighting of this rank's slab to the steady state of the whole grid: the
/// photons that cross a cut are exchanged after every step, and the photon balance is summed
/// over the ranks' row planes in y order, so every rank stops at the same step. `after_step`
/// (optional) sees the solver after each step, with the whole grid's balance.
struct LightingMpiResult {
  int steps = 0;
  double residual = 0;
  std::vector<float> local_light;  ///< this rank's slab, [z][y - slab_begin][x]
};
LightingMpiResult run_lighting_mpi(const lbm::Grid3& grid, const std::vector<float>& local_density,
                                   const lbm::LightingParams& params,
                                   const std::function<void(const lbm::LightingSolver&)>& after_step = {});

}  // namespace nephos::app
