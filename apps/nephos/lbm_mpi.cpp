#include "lbm_mpi.hpp"

#include <mpi.h>

#include <fmt/format.h>
#include <chrono>
#include <cstdlib>
#include <exception>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>

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

namespace {

struct RankFailure {
  int rank;
  std::string message;
};
// Collective: the lowest rank that reports `failed` and its `message`, on every rank; nothing
// when no rank failed.
std::optional<RankFailure> first_failure(bool failed, const std::string& message) {
  const int rank = mpi_rank(), size = mpi_size();
  const int mine = failed ? rank : size;
  int first = size;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (first == size) return std::nullopt;
  int length = static_cast<int>(message.size());
  MPI_Bcast(&length, 1, MPI_INT, first, MPI_COMM_WORLD);
  std::string text = rank == first ? message : std::string(static_cast<std::size_t>(length), '\0');
  MPI_Bcast(text.data(), length, MPI_CHAR, first, MPI_COMM_WORLD);
  return RankFailure{first, std::move(text)};
}

// Runs `f` on every rank; if it throws on any rank, every rank throws: the failing rank its own
// exception, the others an Error carrying the lowest failing rank's message. A rank must never
// go on into a collective call while another has stopped (it would wait forever).
template <class F>
auto on_all_ranks(F&& f) {
  std::exception_ptr failure;
  std::string message;
  using R = decltype(f());
  std::optional<std::conditional_t<std::is_void_v<R>, int, R>> result;
  try {
    if constexpr (std::is_void_v<R>) {
      f();
      result.emplace(0);
    } else {
      result.emplace(f());
    }
  } catch (const std::exception& e) {
    failure = std::current_exception();
    message = e.what();
  }
  if (const auto first = first_failure(failure != nullptr, message)) {
    if (failure) std::rethrow_exception(failure);
    throw Error(fmt::format("rank {} failed: {}", first->rank, first->message));
  }
  if constexpr (!std::is_void_v<R>) return std::move(*result);
}

}  // namespace

WaterResult run_water_mpi(const lbm::Grid3& fresh_grid, const lbm::WaterModelParams& params, std::uint64_t seed,
                          const WaterMpiOptions& o) {
  const int rank = mpi_rank(), size = mpi_size();
  const lbm::Grid3 grid =
      on_all_ranks([&] { return o.resume.empty() ? fresh_grid : lbm::WaterModel::checkpoint_grid(o.resume); });
  auto begin = [&](int r) { return static_cast<int>(static_cast<long>(grid.ny) * r / size); };
  const int y0 = begin(rank), y1 = begin(rank + 1);
  if (grid.ny / size < 2)
    throw ValueError(fmt::format("{} ranks need at least {} rows in y", size, 2 * size), {.key = "--grid"});
  lbm::WaterModel model = on_all_ranks([&] {
    if (!o.resume.empty()) return lbm::WaterModel::load_slab(o.resume, y0, y1);
    lbm::WaterModel m(grid, params, y0, y1);
    m.initialise(lbm::make_silos(grid, params, seed), seed);
    return m;
  });
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
  // Checkpoints: every rank's owned populations gathered on rank 0, written as one file.
  const long row_values = 2L * 19 * grid.nz * grid.nx;
  if (row_values * grid.ny > std::numeric_limits<int>::max())
    throw ValueError(fmt::format("lattice {} too large for gathered MPI checkpoints", grid.describe()),
                     {.key = "--checkpoint-every"});
  auto checkpoint = [&](const std::filesystem::path& path) {
    const std::vector<float> mine = model.pack_owned();
    std::vector<int> counts(static_cast<std::size_t>(size)), displs(static_cast<std::size_t>(size));
    for (int r = 0; r < size; ++r) {
      counts[static_cast<std::size_t>(r)] = static_cast<int>((begin(r + 1) - begin(r)) * row_values);
      displs[static_cast<std::size_t>(r)] = static_cast<int>(begin(r) * row_values);
    }
    std::vector<float> rows(rank == 0 ? static_cast<std::size_t>(row_values * grid.ny) : 0);
    MPI_Gatherv(mine.data(), static_cast<int>(mine.size()), MPI_FLOAT, rows.data(), counts.data(), displs.data(),
                MPI_FLOAT, 0, MPI_COMM_WORLD);
    on_all_ranks([&] {
      if (rank == 0) lbm::WaterModel::save_gathered(path, grid, params, model.steps_done(), rows);
    });
  };
  // The first rank that finds a bad density describes it (global cell coordinates); every
  // rank writes its part of the failure checkpoint and throws the same message.
  auto check = [&] {
    std::string what, message;
    std::size_t cell = 0;
    const bool bad = !model.check(what, cell);
    if (bad) {
      const std::size_t nx = static_cast<std::size_t>(grid.nx), own = static_cast<std::size_t>(y1 - y0);
      message = fmt::format("step {}: {} at cell (x={}, y={}, z={})", model.steps_done(), what, cell % nx,
                            y0 + static_cast<long>(cell / nx % own), cell / (nx * own));
    }
    const auto first = first_failure(bad, message);
    if (!first) return;
    const auto ck = o.out_dir / "checkpoint_failed.bin";
    checkpoint(ck);
    throw NumericError(fmt::format("{}; state saved to {}", first->message, ck.string()));
  };
  const auto t0 = std::chrono::steady_clock::now();
  const long first = model.steps_done();
  while (model.steps_done() < o.iterations) {
    model.step();
    if (model.steps_done() % 10 == 0) check();
    if (o.checkpoint_every > 0 && model.steps_done() % o.checkpoint_every == 0)
      checkpoint(o.out_dir / "checkpoint.bin");
  }
  check();
  WaterResult result;
  result.grid = grid;
  result.first_step = first;
  result.steps_done = model.steps_done();
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
