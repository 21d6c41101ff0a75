#include "lbm_mpi.hpp"

#include <mpi.h>

#include <fmt/format.h>
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdlib>
#include <exception>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/progress.hpp"

namespace nephos::app {

double step_water_model(lbm::WaterModel& model, long iterations, long checkpoint_every,
                        const std::filesystem::path& out_dir, const std::function<void()>& check,
                        const std::function<void(const std::filesystem::path&)>& save) {
  const auto t0 = std::chrono::steady_clock::now();
  {
    Progress progress("water model", static_cast<std::size_t>(std::max(0L, iterations - model.steps_done())));
    while (model.steps_done() < iterations) {
      model.step();
      progress.advance();
      if (model.steps_done() % 10 == 0) check();
      if (checkpoint_every > 0 && model.steps_done() % checkpoint_every == 0) save(out_dir / "checkpoint.bin");
    }
  }
  check();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

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

template <class T>
MPI_Datatype mpi_type();
template <>
MPI_Datatype mpi_type<float>() {
  return MPI_FLOAT;
}
template <>
MPI_Datatype mpi_type<std::uint64_t>() {
  return MPI_UINT64_T;
}
// The halo swap of slabs on a ring of ranks: sends `to_above` to rank + 1 and `to_below` to
// rank - 1 (wrapping around), and returns what arrives from below and from above. Both
// directions carry the same number of values.
template <class T>
std::pair<std::vector<T>, std::vector<T>> swap_with_neighbours(const std::vector<T>& to_above,
                                                               const std::vector<T>& to_below) {
  const int rank = mpi_rank(), size = mpi_size();
  const int up = (rank + 1) % size, down = (rank + size - 1) % size;
  std::vector<T> from_below(to_above.size()), from_above(to_below.size());
  const int n = static_cast<int>(to_above.size());
  MPI_Sendrecv(to_above.data(), n, mpi_type<T>(), up, 1, from_below.data(), n, mpi_type<T>(), down, 1, MPI_COMM_WORLD,
               MPI_STATUS_IGNORE);
  MPI_Sendrecv(to_below.data(), n, mpi_type<T>(), down, 2, from_above.data(), n, mpi_type<T>(), up, 2, MPI_COMM_WORLD,
               MPI_STATUS_IGNORE);
  return {std::move(from_below), std::move(from_above)};
}

}  // namespace

int slab_begin(int ny, int r, int size) { return static_cast<int>(static_cast<long>(ny) * r / size); }

std::vector<float> gather_slabs(const lbm::Grid3& grid, const std::vector<float>& local) {
  // Gather the owned blocks ([z][y_own][x] per rank) on rank 0 and put them in place.
  const int rank = mpi_rank(), size = mpi_size();
  auto begin = [&](int r) { return slab_begin(grid.ny, r, size); };
  std::vector<int> counts(static_cast<std::size_t>(size)), displs(static_cast<std::size_t>(size));
  for (int r = 0; r < size; ++r) {
    counts[static_cast<std::size_t>(r)] = (begin(r + 1) - begin(r)) * grid.nx * grid.nz;
    displs[static_cast<std::size_t>(r)] =
        r == 0 ? 0 : displs[static_cast<std::size_t>(r - 1)] + counts[static_cast<std::size_t>(r - 1)];
  }
  std::vector<float> all(rank == 0 ? grid.cells() : 0);
  MPI_Gatherv(local.data(), static_cast<int>(local.size()), MPI_FLOAT, all.data(), counts.data(), displs.data(),
              MPI_FLOAT, 0, MPI_COMM_WORLD);
  if (rank != 0) return {};
  std::vector<float> dest(grid.cells());
  for (int r = 0; r < size; ++r) {
    const int own = begin(r + 1) - begin(r);
    const float* block = all.data() + displs[static_cast<std::size_t>(r)];
    for (int z = 0; z < grid.nz; ++z)
      for (int y = 0; y < own; ++y)
        for (int x = 0; x < grid.nx; ++x)
          dest[grid.index(x, begin(r) + y, z)] = block[(static_cast<std::size_t>(z) * own + y) * grid.nx + x];
  }
  return dest;
}

WaterResult run_water_mpi(const lbm::Grid3& fresh_grid, const lbm::WaterModelParams& params, std::uint64_t seed,
                          const WaterMpiOptions& o) {
  const int rank = mpi_rank(), size = mpi_size();
  const lbm::Grid3 grid =
      on_all_ranks([&] { return o.resume.empty() ? fresh_grid : lbm::WaterModel::checkpoint_grid(o.resume); });
  auto begin = [&](int r) { return slab_begin(grid.ny, r, size); };
  const int y0 = begin(rank), y1 = begin(rank + 1);
  if (grid.ny / size < 2)
    throw ValueError(fmt::format("{} ranks need at least {} rows in y", size, 2 * size), {.key = "--grid"});
  lbm::WaterModel model = on_all_ranks([&] {
    if (!o.resume.empty()) return lbm::WaterModel::load_slab(o.resume, y0, y1);
    lbm::WaterModel m(grid, params, y0, y1);
    m.initialise(lbm::make_silos(grid, params, seed), seed);
    return m;
  });
  model.set_exchange([&](lbm::WaterModel& m, lbm::WaterModel::Exchange kind) {
    const auto [from_below, from_above] =
        swap_with_neighbours(m.pack_row(kind, m.owned_end() - 1), m.pack_row(kind, m.owned_begin()));
    m.unpack_row(kind, 0, from_below);
    m.unpack_row(kind, m.local_ny() - 1, from_above);
  });
  // Checkpoints: one file whatever the process count, written in place by every rank (its own
  // rows) into the temporary that rank 0 created at full size, which rank 0 then renames: no
  // rank holds the whole lattice. Each on_all_ranks is also a barrier.
  auto checkpoint = [&](const std::filesystem::path& path) {
    std::optional<AtomicFile> file;  // rank 0's: removes the temporary unless committed
    std::string temp;
    on_all_ranks([&] {
      if (rank != 0) return;
      file.emplace(path);
      lbm::WaterModel::create_checkpoint(file->temp_path(), grid, params, model.steps_done());
      temp = file->temp_path().string();
    });
    int length = static_cast<int>(temp.size());
    MPI_Bcast(&length, 1, MPI_INT, 0, MPI_COMM_WORLD);
    temp.resize(static_cast<std::size_t>(length));
    MPI_Bcast(temp.data(), length, MPI_CHAR, 0, MPI_COMM_WORLD);
    on_all_ranks([&] { model.write_owned(temp); });
    on_all_ranks([&] {
      if (rank == 0) file->commit();
    });
  };
  // The first rank that finds a bad density describes it (global cell coordinates); every
  // rank writes its part of the failure checkpoint and throws the same message.
  auto check = [&] {
    const auto bad = model.bad_density();
    const auto first = first_failure(bad.has_value(), bad.value_or(""));
    if (!first) return;
    const auto ck = o.out_dir / "checkpoint_failed.bin";
    checkpoint(ck);
    throw NumericError(fmt::format("{}; state saved to {}", first->message, ck.string()));
  };
  const long first = model.steps_done();
  const double seconds = step_water_model(model, o.iterations, o.checkpoint_every, o.out_dir, check, checkpoint);
  WaterResult result;
  result.grid = grid;
  result.first_step = first;
  result.steps_done = model.steps_done();
  result.seconds = seconds;
  result.local_vapour = model.vapour();
  result.vapour = gather_slabs(grid, result.local_vapour);
  result.temperature = gather_slabs(grid, model.temperature());
  return result;
}

PercolationMpiResult run_percolation_mpi(const lbm::Grid3& grid, const std::vector<float>& local_vapour,
                                         const lbm::PercolationParams& params, std::uint64_t seed,
                                         const std::function<void(int, std::size_t)>& after_step) {
  const int rank = mpi_rank(), size = mpi_size();
  const int y0 = slab_begin(grid.ny, rank, size), y1 = slab_begin(grid.ny, rank + 1, size);
  lbm::Percolation perc = on_all_ranks([&] { return lbm::Percolation(grid, local_vapour, params, seed, y0, y1); });
  PercolationMpiResult result;
  lbm::Percolation::RunHooks hooks;
  hooks.exchange = [](lbm::Percolation& p) {  // periodic in y: the ring wraps
    using Side = lbm::Percolation::Side;
    const auto [from_below, from_above] = swap_with_neighbours(p.edge_rows(Side::above), p.edge_rows(Side::below));
    p.set_halo(Side::below, from_below);
    p.set_halo(Side::above, from_above);
  };
  hooks.total = [](std::size_t n) {
    unsigned long long mine = n, total = 0;  // an integer sum: exact in any order
    MPI_Allreduce(&mine, &total, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    return static_cast<std::size_t>(total);
  };
  hooks.after_step = after_step;
  result.steps = perc.run(hooks);
  result.local_density = perc.coarse_density();
  return result;
}

LightingMpiResult run_lighting_mpi(const lbm::Grid3& grid, const std::vector<float>& local_density,
                                   const lbm::LightingParams& params,
                                   const std::function<void(const lbm::LightingSolver&)>& after_step) {
  const int rank = mpi_rank(), size = mpi_size();
  const int y0 = slab_begin(grid.ny, rank, size), y1 = slab_begin(grid.ny, rank + 1, size);
  lbm::LightingSolver solver = on_all_ranks([&] { return lbm::LightingSolver(grid, local_density, params, y0, y1); });
  // Every rank's row planes, gathered in rank (= y) order for the whole grid's balance.
  std::vector<int> counts(static_cast<std::size_t>(size)), displs(static_cast<std::size_t>(size));
  for (int r = 0; r < size; ++r) {
    counts[static_cast<std::size_t>(r)] = 3 * (slab_begin(grid.ny, r + 1, size) - slab_begin(grid.ny, r, size));
    displs[static_cast<std::size_t>(r)] = 3 * slab_begin(grid.ny, r, size);
  }
  std::vector<std::array<double, 3>> planes(static_cast<std::size_t>(grid.ny));
  LightingMpiResult result;
  result.steps = solver.solve([&](lbm::LightingSolver& s) {
    using Side = lbm::LightingSolver::Side;
    const auto [from_below, from_above] = swap_with_neighbours(s.leaving(Side::above), s.leaving(Side::below));
    s.set_arrivals(Side::below, from_below);
    s.set_arrivals(Side::above, from_above);
    MPI_Allgatherv(s.plane_balance().data()->data(), 3 * static_cast<int>(s.plane_balance().size()), MPI_DOUBLE,
                   planes.data()->data(), counts.data(), displs.data(), MPI_DOUBLE, MPI_COMM_WORLD);
    s.set_balance(lbm::LightingSolver::balance_of_planes(planes));
    if (after_step) after_step(s);
  });
  result.residual = solver.residual();
  result.local_light = solver.light();
  return result;
}

}  // namespace nephos::app
