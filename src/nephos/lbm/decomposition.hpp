#pragma once
// How the lattice-Boltzmann stages are spread over processes. The pipeline (lbm/job.hpp) asks
// its Decomposition for each stage's solver and for the fields; one process (SingleProcess)
// runs the whole lattice, the MPI decomposition (lbm/mpi, its own optional library) cuts it
// into slabs along y, one per process, whose halos it exchanges. Results are bit-identical
// for any process count.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "nephos/lbm/lighting.hpp"
#include "nephos/lbm/percolation.hpp"
#include "nephos/lbm/water_model.hpp"

namespace nephos::lbm {

/// A stage's result on one process: its slab of a field ([z][y - slab begin][x]; the whole
/// field with one process) and how the iteration ended.
struct PercolationRun {
  int steps = 0;
  std::vector<float> density;  ///< cloud fraction per lattice cell
};
struct LightingRun {
  int steps = 0;
  double residual = 0;
  std::vector<float> light;  ///< photon density per cell
};

class Decomposition {
 public:
  virtual ~Decomposition() = default;
  /// This process, 0 .. processes() - 1; process 0 gathers the fields and writes the outputs.
  virtual int process() const = 0;
  virtual int processes() const = 0;
  /// Runs `f` on every process; if it throws on any, every process throws: that one its own
  /// error, the others an Error naming the first failing process. (A process must never go on
  /// into a collective step while another has stopped.)
  virtual void on_every_process(const std::function<void()>& f) = 0;

  /// The lattice a run works on: `grid`, or the checkpoint's when resuming.
  virtual Grid3 lattice(const Grid3& grid, const std::filesystem::path& resume) = 0;
  /// This process's water model: fresh (silos from `seed`) or resumed from a checkpoint
  /// written with any process count.
  virtual WaterModel water_model(const Grid3& grid, const WaterModelParams& params, std::uint64_t seed,
                                 const std::filesystem::path& resume) = 0;
  /// The whole lattice's checkpoint, one file whatever the process count (atomic).
  virtual void save_checkpoint(const WaterModel& model, const std::filesystem::path& path) = 0;
  /// The first process's description of a NaN or out-of-range density, on every process;
  /// nothing when every density is fine.
  virtual std::optional<std::string> bad_density(const WaterModel& model) = 0;
  /// Percolation of this process's slab of `vapour` (or of the whole lattice).
  virtual PercolationRun percolate(const Grid3& grid, const std::vector<float>& vapour, const PercolationParams& params,
                                   std::uint64_t seed,
                                   const std::function<void(int step, std::size_t active)>& after_step) = 0;
  /// Lighting of this process's slab of `density` to the whole lattice's steady state.
  virtual LightingRun light(const Grid3& grid, const std::vector<float>& density, const LightingParams& params,
                            const std::function<void(const LightingSolver&)>& after_step) = 0;
  /// The whole field on process 0 (empty on the others) from every process's slab.
  virtual std::vector<float> gather(const Grid3& grid, const std::vector<float>& local) = 0;
};

/// The whole lattice in this process.
class SingleProcess final : public Decomposition {
 public:
  int process() const override { return 0; }
  int processes() const override { return 1; }
  void on_every_process(const std::function<void()>& f) override { f(); }
  Grid3 lattice(const Grid3& grid, const std::filesystem::path& resume) override;
  WaterModel water_model(const Grid3& grid, const WaterModelParams& params, std::uint64_t seed,
                         const std::filesystem::path& resume) override;
  void save_checkpoint(const WaterModel& model, const std::filesystem::path& path) override { model.save(path); }
  std::optional<std::string> bad_density(const WaterModel& model) override { return model.bad_density(); }
  PercolationRun percolate(const Grid3& grid, const std::vector<float>& vapour, const PercolationParams& params,
                           std::uint64_t seed,
                           const std::function<void(int step, std::size_t active)>& after_step) override;
  LightingRun light(const Grid3& grid, const std::vector<float>& density, const LightingParams& params,
                    const std::function<void(const LightingSolver&)>& after_step) override;
  std::vector<float> gather(const Grid3&, const std::vector<float>& local) override { return local; }
};

/// The first row of slab r of a lattice `ny` rows long cut into `slabs` (r = slabs: ny).
inline int slab_begin(int ny, int r, int slabs) { return static_cast<int>(static_cast<long>(ny) * r / slabs); }

}  // namespace nephos::lbm
