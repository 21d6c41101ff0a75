#pragma once
// Running the lattice-Boltzmann water model across MPI processes: the lattice is cut into
// slabs along y, one per rank, which exchange one halo row of populations before streaming and
// one of densities before the force computation. Results are bit-identical to one process.
#include <cstdint>
#include <filesystem>
#include <vector>

#include "nephos/lbm/water_model.hpp"

namespace nephos::app {

/// True when this process was started by mpirun/mpiexec with more than one rank.
bool mpi_launched();
void mpi_init(int& argc, char**& argv);
void mpi_finalize();
int mpi_rank();
int mpi_size();

struct WaterResult {
  lbm::Grid3 grid;                         ///< the whole lattice
  std::vector<float> vapour, temperature;  ///< whole lattice, on rank 0 only
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

}  // namespace nephos::app
