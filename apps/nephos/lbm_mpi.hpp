#pragma once
// Running the lattice-Boltzmann water model across MPI processes: the lattice is cut into
// slabs along y, one per rank, which exchange one halo row of populations before streaming and
// one of densities before the force computation. Results are bit-identical to one process.
#include <cstdint>
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
  std::vector<float> vapour, temperature;  ///< whole lattice, on rank 0 only
  double seconds = 0;
};

/// Runs `iterations` steps on this rank's slab and gathers the fields on rank 0. Throws
/// NumericError (on every rank) if any rank finds a NaN or out-of-range density.
WaterResult run_water_mpi(const lbm::Grid3& grid, const lbm::WaterModelParams& params, std::uint64_t seed,
                          long iterations);

}  // namespace nephos::app
