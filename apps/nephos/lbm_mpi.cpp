#include "lbm_mpi.hpp"

#include <mpi.h>

#include <fmt/format.h>
#include <chrono>
#include <cstdlib>

#include "nephos/core/error.hpp"

namespace nephos::app {

bool mpi_launched() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"})
    if (const char* s = std::getenv(v)) return std::atoi(s) > 1;
  return false;
}
void mpi_init(int& argc, char**& argv) { MPI_Init(&argc, &argv); }
void mpi_finalize() { MPI_Finalize(); }
int mpi_rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}
int mpi_size() {
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

WaterResult run_water_mpi(const lbm::Grid3& grid, const lbm::WaterModelParams& params, std::uint64_t seed,
                          long iterations) {
  const int rank = mpi_rank(), size = mpi_size();
  auto begin = [&](int r) { return static_cast<int>(static_cast<long>(grid.ny) * r / size); };
  const int y0 = begin(rank), y1 = begin(rank + 1);
  if (grid.ny / size < 2)
    throw ValueError(fmt::format("{} ranks need at least {} rows in y", size, 2 * size), {.key = "--grid"});
  lbm::WaterModel model(grid, params, y0, y1);
  model.initialise(lbm::make_silos(grid, params, seed), seed);
  const int up = (rank + 1) % size, down = (rank + size - 1) % size;
  model.set_exchange([&](lbm::WaterModel& m, lbm::WaterModel::Exchange kind) {
    const auto low = m.pack_row(kind, m.owned_begin()), high = m.pack_row(kind, m.owned_end() - 1);
    std::vector<float> from_below(high.size()), from_above(low.size());
    const int n = static_cast<int>(low.size());
    MPI_Sendrecv(high.data(), n, MPI_FLOAT, up, 1, from_below.data(), n, MPI_FLOAT, down, 1, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
    MPI_Sendrecv(low.data(), n, MPI_FLOAT, down, 2, from_above.data(), n, MPI_FLOAT, up, 2, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
    m.unpack_row(kind, 0, from_below);
    m.unpack_row(kind, m.local_ny() - 1, from_above);
  });
  const auto t0 = std::chrono::steady_clock::now();
  for (long t = 0; t < iterations; ++t) {
    model.step();
    if (model.steps_done() % 10 == 0 || t + 1 == iterations) {
      std::string what;
      std::size_t cell = 0;
      const int ok = model.check(what, cell) ? 1 : 0;
      int all = 0;
      MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
      if (!all)
        throw NumericError(fmt::format("step {}: a density left its bounds{} (rank {}, rows {}..{})",
                                       model.steps_done(), ok ? " on another rank" : ": " + what, rank, y0, y1 - 1));
    }
  }
  WaterResult result;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Gather the owned blocks ([z][y_own][x] per rank) on rank 0 and put them in place.
  for (int c = 0; c < 2; ++c) {
    const auto local = c == 0 ? model.vapour() : model.temperature();
    std::vector<int> counts(static_cast<std::size_t>(size)), displs(static_cast<std::size_t>(size));
    for (int r = 0; r < size; ++r) {
      counts[static_cast<std::size_t>(r)] = (begin(r + 1) - begin(r)) * grid.nx * grid.nz;
      displs[static_cast<std::size_t>(r)] =
          r == 0 ? 0 : displs[static_cast<std::size_t>(r - 1)] + counts[static_cast<std::size_t>(r - 1)];
    }
    std::vector<float> all(rank == 0 ? grid.cells() : 0);
    MPI_Gatherv(local.data(), static_cast<int>(local.size()), MPI_FLOAT, all.data(), counts.data(), displs.data(),
                MPI_FLOAT, 0, MPI_COMM_WORLD);
    if (rank != 0) continue;
    std::vector<float>& dest = c == 0 ? result.vapour : result.temperature;
    dest.resize(grid.cells());
    for (int r = 0; r < size; ++r) {
      const int own = begin(r + 1) - begin(r);
      const float* block = all.data() + displs[static_cast<std::size_t>(r)];
      for (int z = 0; z < grid.nz; ++z)
        for (int y = 0; y < own; ++y)
          for (int x = 0; x < grid.nx; ++x)
            dest[grid.index(x, begin(r) + y, z)] = block[(static_cast<std::size_t>(z) * own + y) * grid.nx + x];
    }
  }
  return result;
}

}  // namespace nephos::app
