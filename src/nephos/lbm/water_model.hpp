#pragma once
// The two-component lattice-Boltzmann water model of the convective-cloud seed (section 3,
// after Shan & Doolen 1995 and Shan 1997): component 1 is water-vapour density, component 2
// is temperature (a component of negligible molecular mass, advected and diffused, eq. 28).
//
// Per step: stream (pull); densities rho_s and momenta; interaction forces (eq. 25)
//   F_1 = -Psi_1 (2 G11 grad Psi_1 + G12 grad Psi_2) + rho_1 g_1(rho_2) z_hat
//     (the factor 2 on the self-interaction gives the pressure of eq. 29, see docs/lbm.md)
//   F_2 = -Psi_2 (G21 grad Psi_1 + G22 grad Psi_2)
// with Psi_1 = rho10 (1 - exp(-rho_1/rho10)), Psi_2 = rho_2, G11 from eq. (31)
// (G11 = -v^2 ((1-d)/rho10) (1 + rho20 - rho_2), evaluated with the local temperature),
// G12 = G21 = 0.5, G22 = 0, buoyancy g_1 = 0.01 (rho_2 - 0.5); the common equilibrium
// velocity (eq. 9) shifted per component by xi_s F_s / rho_s (eq. 10); LBGK collision (eq. 6).
// Gradients use the isotropic D3Q19 stencil. Boundaries: periodic in x and y; at the bottom
// and top layers the temperature is held at its initial value and both components are reset
// to rest equilibrium ("equalising directional densities"), with walls beyond.
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "nephos/core/config.hpp"
#include "nephos/lbm/lattice.hpp"
#include "nephos/lbm/populations.hpp"

namespace nephos::lbm {

/// The most initial silos a run may ask for.
inline constexpr int max_silos = 10000;

struct WaterModelParams {
  double rho10 = 1.0;                              ///< maximum effective vapour density (bound of Psi_1)
  double rho20 = 0.505;                            ///< maximum temperature of a phase transition
  double rest_fraction = 0.1;                      ///< d
  double xi_vapour = 1.01, xi_temperature = 2.00;  ///< relaxation times
  double g12 = 0.5, g22 = 0.0;
  double buoyancy = 0.01, buoyancy_reference = 0.5;  ///< g_1 = buoyancy (rho_2 - reference)
  double temperature_bottom = 0.505, temperature_top = 0.495;
  // Initial silos (cylinders with hemispherical caps on the floor).
  int silos = 4;
  double silo_radius_min = 0.08, silo_radius_max = 0.16;  ///< fraction of the horizontal size
  double silo_height_min = 0.2, silo_height_max = 0.4;    ///< cylinder height, fraction of nz
  double vapour_background = 0.5;                         ///< vapour density far from silos, fraction of rho10
  bool periodic_z = false;                                ///< tests: a fully periodic box (no top/bottom layers)
  /// Population storage: FP32, or FP16 (half the memory traffic; arithmetic stays FP32; see
  /// populations.hpp and docs/lbm.md for the error).
  Storage storage = Storage::fp32;

  static WaterModelParams from(const ParamDict& dict);
  /// Sets `silos` (0..max_silos); ValueError naming `key` otherwise.
  void set_silos(int n, const std::string& key);
  /// What the model holds per cell [B] (docs/lbm.md): both components' populations, two copies,
  /// and the density fields: 316 B in FP32 storage, 180 B in FP16.
  double bytes_per_cell() const { return storage == Storage::fp16 ? 180 : 316; }
};

struct Silo {
  double x, y, radius, height;  ///< lattice units; the cap's centre is at z = height
};

/// `count` silos with positions, radii and heights drawn from the counter-based hash of seed.
std::vector<Silo> make_silos(const Grid3& g, const WaterModelParams& p, std::uint64_t seed);

class WaterModel {
 public:
  WaterModel(Grid3 grid, WaterModelParams params);
  /// A slab of the global lattice for domain decomposition: rows y_begin <= y < y_end, plus one
  /// halo row on each side that `set_exchange`'s callback fills from the neighbouring slabs.
  WaterModel(Grid3 global, WaterModelParams params, int y_begin, int y_end);

  /// What a halo exchange moves: the post-collision populations before streaming, or the
  /// densities and Psi_1 before the force computation.
  enum class Exchange { populations, densities };
  /// Called twice per step in slab mode (populations, then densities).
  void set_exchange(std::function<void(WaterModel&, Exchange)> exchange) { exchange_ = std::move(exchange); }
  /// Packs / unpacks one local row (y_local) of the fields an exchange moves.
  std::vector<float> pack_row(Exchange kind, int y_local) const;
  void unpack_row(Exchange kind, int y_local, const std::vector<float>& data);
  /// Local rows: halo at 0 and local_ny() - 1 in slab mode; owned rows [owned_begin, owned_end).
  int local_ny() const { return g_.ny; }
  int owned_begin() const { return halo_; }
  int owned_end() const { return g_.ny - halo_; }
  const Grid3& global_grid() const { return global_; }
  int y_begin() const { return y_begin_; }
  /// Initial conditions: silo vapour (uniform in [0.99, 1.01] rho10 inside, linear fall-off
  /// outside over one radius to the background), linear temperature from bottom to top.
  void initialise(const std::vector<Silo>& silos, std::uint64_t seed);
  /// Uniform vapour and temperature at rest, vapour perturbed by +-`perturbation` (hashed).
  void initialise_uniform(double vapour, double temperature, double perturbation, std::uint64_t seed);
  /// Both components at rest equilibrium with the given densities, each a whole-lattice field
  /// in the layout of vapour() (x fastest, then y, then z; a slab takes its own and its halo
  /// rows). ValueError naming `vapour` or `temperature` if a field has the wrong size.
  void initialise_fields(const std::vector<float>& vapour, const std::vector<float>& temperature);
  void step();
  /// The two halves of step() for drivers that exchange halos themselves: stream (pass 1: the
  /// densities after streaming and Psi_1) then collide (pass 2: streaming, forces, collision,
  /// boundary layers).
  enum class Stage { stream, collide };
  void step_stage(Stage stage);
  long steps_done() const { return step_; }

  const Grid3& grid() const { return g_; }
  const WaterModelParams& params() const { return p_; }
  /// Densities of the owned cells (vapour = component 1, temperature = component 2), x fastest,
  /// then owned y, then z.
  std::vector<float> vapour() const { return density(0); }
  std::vector<float> temperature() const { return density(1); }
  /// Sum of a component's populations over the grid (double accumulation).
  double total(int component) const;
  /// The velocity moments of one cell's stored (post-collision) populations: density
  /// sum_i f_i, momentum sum_i f_i c_i and the second moment sum_i f_i c_i c_i (xx, yy, zz,
  /// xy, xz, yz), in double. (x, y, z) as in vapour(): y counts the owned rows.
  struct Moments {
    double density;
    std::array<double, 3> momentum;
    std::array<double, 6> second;
  };
  Moments moments(int component, int x, int y, int z) const;

  /// Finds the first NaN or out-of-range density (vapour outside [0, 100 rho10], temperature
  /// outside [0, 10]); returns false and describes it in `what` / `cell`.
  bool check(std::string& what, std::size_t& cell) const;
  /// check() as the message a run stops with: "step N: <what> at cell (x=, y=, z=)", the cell
  /// in the whole lattice's coordinates (also for a slab); nothing when every density is fine.
  std::optional<std::string> bad_density() const;

  /// Checkpoint: the full state, bit-exact (atomic write), except that every NaN is stored as
  /// the quiet NaN 0x7FC00000 (a NaN's sign and payload depend on the order of operations).
  /// Resuming gives results identical to an uninterrupted run. One file format whatever the
  /// process count: a run may resume on a different number of MPI processes.
  void save(const std::filesystem::path& path) const;
  static WaterModel load(const std::filesystem::path& path);
  /// The lattice size a checkpoint holds (reads its header only).
  static Grid3 checkpoint_grid(const std::filesystem::path& path);
  /// Whether `path` starts like a checkpoint (any format version); false if it cannot be read.
  static bool is_checkpoint(const std::filesystem::path& path);
  /// `nephos info` of a checkpoint: format, lattice, step, storage, the [water] parameters (as
  /// TOML keys) and whether the file holds all its populations. Throws like load().
  static std::string describe_checkpoint(const std::filesystem::path& path);
  /// The slab rows y_begin <= y < y_end of a checkpoint (see the slab constructor).
  static WaterModel load_slab(const std::filesystem::path& path, int y_begin, int y_end);
  /// The populations of the owned rows, pack_row(populations) of each in y order.
  std::vector<float> pack_owned() const;
  /// Checkpoints written by the slabs themselves, so that no process holds the whole lattice:
  /// create_checkpoint() writes the header of the whole lattice's checkpoint into `file` and
  /// gives the file its full size (one process); then each slab's write_owned(file) writes its
  /// rows in place (any order, any processes; disjoint byte ranges). The result is the file
  /// save() writes for the whole lattice, byte for byte. IoError naming the file on failure.
  static void create_checkpoint(const std::filesystem::path& file, const Grid3& global, const WaterModelParams& params,
                                long step);
  void write_owned(const std::filesystem::path& file) const;

 private:
  std::vector<float> density(int component) const;
  /// Both components of a cell at rest equilibrium with these densities.
  void set_rest_equilibrium(std::size_t cell, double vapour, double temperature);
  struct RowScratch;
  /// Where pass 1 puts the densities and Psi_1 of a row and pass 2 finds them: the lattice-wide
  /// arrays (y wrapped around the lattice), or a block's ring of three planes (y unwrapped,
  /// relative to the block's first row, with one halo row on each side).
  struct DensityRows {
    float *rho1, *rho2, *psi1;
    int nx, ny, y_offset, rows_per_plane, planes;  ///< planes: 3 for a block's ring, 0 for the lattice
    std::size_t row(int y, int z) const {          // y in [-1, ny], z >= 0
      const int yl = planes == 0 ? (y < 0 ? y + ny : (y >= ny ? y - ny : y)) : y + y_offset;
      const int zl = planes == 0 ? z : z % 3;  // the ring has three planes
      return (static_cast<std::size_t>(zl) * static_cast<std::size_t>(rows_per_plane) + static_cast<std::size_t>(yl)) *
             static_cast<std::size_t>(nx);
    }
  };
  DensityRows lattice_rows();
  template <class T>  // T: the population storage type, float or FP16 bits (std::uint16_t)
  void density_row(int y, int z, const DensityRows& rows, float* pulled_out);
  template <class T>
  void collide_row(int y, int z, RowScratch& scratch, const DensityRows& rows, const float* pulled_row);
  template <class T>
  void step_stage_impl(Stage stage);
  template <class T>
  void fused_step_impl();
  void fused_step();   // both passes as a wavefront over z (whole lattice, walls in z)
  void finish_step();  // boundary layers and the step count
  int global_y(int y_local) const { return ((y_local - halo_ + y_begin_) % global_.ny + global_.ny) % global_.ny; }
  Grid3 g_;  ///< local grid (the whole lattice unless in slab mode)
  Grid3 global_;
  int y_begin_ = 0, halo_ = 0;
  std::function<void(WaterModel&, Exchange)> exchange_;
  WaterModelParams p_;
  long step_ = 0;
  // Post-collision populations (f_) and the next step's (next_, pull streaming from one into
  // the other); huge pages: 2 MiB-aligned rows for streaming stores, and fewer TLB misses over
  // 38 concurrent streams.
  Populations f_[2], next_[2];
  std::vector<float> rho_[2], psi1_;
};

}  // namespace nephos::lbm
