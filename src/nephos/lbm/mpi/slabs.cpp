#include "nephos/lbm/mpi/slabs.hpp"

#include <mpi.h>

#include <fmt/format.h>

#include <array>
#include <cstdlib>
#include <exception>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"

namespace nephos::lbm::mpi {

bool launched() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"})
    if (const char* s = std::getenv(v)) return std::atoi(s) > 1;
  return false;
}

Session::Session(int& argc, char**& argv) : active_(launched()) {
  if (active_) MPI_Init(&argc, &argv);
}
Session::~Session() {
  if (active_) MPI_Finalize();
}

namespace {
int rank_of_world() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}
int size_of_world() {
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}
}  // namespace

int Session::rank() const { return active_ ? rank_of_world() : 0; }
int Session::size() const { return active_ ? size_of_world() : 1; }

namespace {

struct RankFailure {
  int rank;
  std::string message;
};
// Collective: the lowest rank that reports `failed` and its `message`, on every rank; nothing
// when no rank failed.
std::optional<RankFailure> first_failure(bool failed, const std::string& message) {
  const int rank = rank_of_world(), size = size_of_world();
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
  const int rank = rank_of_world(), size = size_of_world();
  const int up = (rank + 1) % size, down = (rank + size - 1) % size;
  std::vector<T> from_below(to_above.size()), from_above(to_below.size());
  const int n = static_cast<int>(to_above.size());
  MPI_Sendrecv(to_above.data(), n, mpi_type<T>(), up, 1, from_below.data(), n, mpi_type<T>(), down, 1, MPI_COMM_WORLD,
               MPI_STATUS_IGNORE);
  MPI_Sendrecv(to_below.data(), n, mpi_type<T>(), down, 2, from_above.data(), n, mpi_type<T>(), up, 2, MPI_COMM_WORLD,
               MPI_STATUS_IGNORE);
  return {std::move(from_below), std::move(from_above)};
}

// The slab decomposition: this process owns rows [y0, y1) of every lattice.
class Slabs final : public Decomposition {
 public:
  Slabs() : rank_(rank_of_world()), size_(size_of_world()) {}
  int process() const override { return rank_; }
  int processes() const override { return size_; }
  void on_every_process(const std::function<void()>& f) override { on_all_ranks(f); }

  Grid3 lattice(const Grid3& grid, const std::filesystem::path& resume) override {
    const Grid3 g = on_all_ranks([&] { return resume.empty() ? grid : WaterModel::checkpoint_grid(resume); });
    if (g.ny / size_ < 2)
      throw ValueError(fmt::format("{} processes need at least {} rows in y", size_, 2 * size_), {.key = "grid"});
    return g;
  }

  WaterModel water_model(const Grid3& grid, const WaterModelParams& params, std::uint64_t seed,
                         const std::filesystem::path& resume) override {
    const int y0 = begin(grid.ny, rank_), y1 = begin(grid.ny, rank_ + 1);
    WaterModel model = on_all_ranks([&] {
      if (!resume.empty()) return WaterModel::load_slab(resume, y0, y1);
      WaterModel m(grid, params, y0, y1);
      m.initialise(make_silos(grid, params, seed), seed);
      return m;
    });
    model.set_exchange([](WaterModel& m, WaterModel::Exchange kind) {
      const auto [from_below, from_above] =
          swap_with_neighbours(m.pack_row(kind, m.owned_end() - 1), m.pack_row(kind, m.owned_begin()));
      m.unpack_row(kind, 0, from_below);
      m.unpack_row(kind, m.local_ny() - 1, from_above);
    });
    return model;
  }

  // One file whatever the process count, written in place by every process (its own rows)
  // into the temporary that process 0 created at full size, which process 0 then renames: no
  // process holds the whole lattice. Each on_all_ranks is also a barrier.
  void save_checkpoint(const WaterModel& model, const std::filesystem::path& path) override {
    std::optional<AtomicFile> file;  // process 0's: removes the temporary unless committed
    std::string temp;
    on_all_ranks([&] {
      if (rank_ != 0) return;
      file.emplace(path);
      WaterModel::create_checkpoint(file->temp_path(), model.global_grid(), model.params(), model.steps_done());
      temp = file->temp_path().string();
    });
    int length = static_cast<int>(temp.size());
    MPI_Bcast(&length, 1, MPI_INT, 0, MPI_COMM_WORLD);
    temp.resize(static_cast<std::size_t>(length));
    MPI_Bcast(temp.data(), length, MPI_CHAR, 0, MPI_COMM_WORLD);
    on_all_ranks([&] { model.write_owned(temp); });
    on_all_ranks([&] {
      if (rank_ == 0) file->commit();
    });
  }

  std::optional<std::string> bad_density(const WaterModel& model) override {
    const auto bad = model.bad_density();
    const auto first = first_failure(bad.has_value(), bad.value_or(""));
    if (!first) return std::nullopt;
    return first->message;
  }

  PercolationRun percolate(const Grid3& grid, const std::vector<float>& vapour, const PercolationParams& params,
                           std::uint64_t seed, const std::function<void(int, std::size_t)>& after_step) override {
    const int y0 = begin(grid.ny, rank_), y1 = begin(grid.ny, rank_ + 1);
    Percolation perc = on_all_ranks([&] { return Percolation(grid, vapour, params, seed, y0, y1); });
    Percolation::RunHooks hooks;
    hooks.exchange = [](Percolation& p) {  // periodic in y: the ring wraps
      using Side = Percolation::Side;
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
    PercolationRun run;
    run.steps = perc.run(hooks);
    run.density = perc.coarse_density();
    return run;
  }

  LightingRun light(const Grid3& grid, const std::vector<float>& density, const LightingParams& params,
                    const std::function<void(const LightingSolver&)>& after_step) override {
    const int y0 = begin(grid.ny, rank_), y1 = begin(grid.ny, rank_ + 1);
    LightingSolver solver = on_all_ranks([&] { return LightingSolver(grid, density, params, y0, y1); });
    // Every process's row planes, gathered in process (= y) order for the whole grid's balance.
    std::vector<int> counts(static_cast<std::size_t>(size_)), displs(static_cast<std::size_t>(size_));
    for (int r = 0; r < size_; ++r) {
      counts[static_cast<std::size_t>(r)] = 3 * (begin(grid.ny, r + 1) - begin(grid.ny, r));
      displs[static_cast<std::size_t>(r)] = 3 * begin(grid.ny, r);
    }
    std::vector<std::array<double, 3>> planes(static_cast<std::size_t>(grid.ny));
    LightingRun run;
    run.steps = solver.solve([&](LightingSolver& s) {
      using Side = LightingSolver::Side;
      const auto [from_below, from_above] = swap_with_neighbours(s.leaving(Side::above), s.leaving(Side::below));
      s.set_arrivals(Side::below, from_below);
      s.set_arrivals(Side::above, from_above);
      MPI_Allgatherv(s.plane_balance().data()->data(), 3 * static_cast<int>(s.plane_balance().size()), MPI_DOUBLE,
                     planes.data()->data(), counts.data(), displs.data(), MPI_DOUBLE, MPI_COMM_WORLD);
      s.set_balance(LightingSolver::balance_of_planes(planes));
      if (after_step) after_step(s);
    });
    run.residual = solver.residual();
    run.light = solver.light();
    return run;
  }

  std::vector<float> gather(const Grid3& grid, const std::vector<float>& local) override {
    // Gather the owned blocks ([z][y_own][x] per process) on process 0 and put them in place.
    std::vector<int> counts(static_cast<std::size_t>(size_)), displs(static_cast<std::size_t>(size_));
    for (int r = 0; r < size_; ++r) {
      counts[static_cast<std::size_t>(r)] = (begin(grid.ny, r + 1) - begin(grid.ny, r)) * grid.nx * grid.nz;
      displs[static_cast<std::size_t>(r)] =
          r == 0 ? 0 : displs[static_cast<std::size_t>(r - 1)] + counts[static_cast<std::size_t>(r - 1)];
    }
    std::vector<float> all(rank_ == 0 ? grid.cells() : 0);
    MPI_Gatherv(local.data(), static_cast<int>(local.size()), MPI_FLOAT, all.data(), counts.data(), displs.data(),
                MPI_FLOAT, 0, MPI_COMM_WORLD);
    if (rank_ != 0) return {};
    std::vector<float> dest(grid.cells());
    for (int r = 0; r < size_; ++r) {
      const int own = begin(grid.ny, r + 1) - begin(grid.ny, r);
      const float* block = all.data() + displs[static_cast<std::size_t>(r)];
      for (int z = 0; z < grid.nz; ++z)
        for (int y = 0; y < own; ++y)
          for (int x = 0; x < grid.nx; ++x)
            dest[grid.index(x, begin(grid.ny, r) + y, z)] =
                block[(static_cast<std::size_t>(z) * own + y) * grid.nx + x];
    }
    return dest;
  }

 private:
  int begin(int ny, int r) const { return slab_begin(ny, r, size_); }
  int rank_, size_;
};

}  // namespace

std::unique_ptr<Decomposition> slabs() { return std::make_unique<Slabs>(); }

}  // namespace nephos::lbm::mpi
