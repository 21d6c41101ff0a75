#pragma once
// Lattice-Boltzmann photon transport (Geist et al. 2004, "Lattice-Boltzmann lighting"; seed
// section 4.3). Photon densities I_i travel along the 18 moving D3Q19 directions. Each step:
//   collision  I_i' = (1 - sigma_t) I_i + sigma_s sum_j P_ij I_j      (sigma_t = sigma_a + sigma_s)
//   streaming  I_i(x + c_i) = I_i'(x)
// with sigma_a, sigma_s [per lattice step] following the cloud density of each voxel and a
// discrete phase function P whose columns sum to 1 (scattering conserves photons). Sunlight
// enters through the boundary along the lattice directions nearest the sun direction;
// photons leaving the box are lost. Iterated to a steady state.
//
// Diffusion limit (derived in docs/lbm.md): for isotropic P (P_i = w_i / sum w: 1/12 axis,
// 1/24 diagonal) and no absorption, a photon keeps its direction with probability 1 - sigma_s
// per step, so the walk is a persistent random walk with <|c|^2> = 3/2 and
//   D = (<|c|^2> / 6) (2 - sigma_s) / sigma_s = (2 / sigma_s - 1) / 4,
// Geist et al.'s D = (2/sigma_t - 1) / (4 (1 + sigma_a)) at sigma_a = 0 (tested).
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "nephos/core/huge_page_allocator.hpp"
#include "nephos/lbm/lattice.hpp"

namespace nephos::lbm {

inline constexpr int light_dirs = 18;  ///< D3Q19 directions 1..18

/// Discrete phase function: P[i][j] = probability that a photon scattered while travelling in
/// direction j leaves in direction i (indices 0..17 for D3Q19 directions 1..18).
using PhaseMatrix = std::array<std::array<double, light_dirs>, light_dirs>;
/// Henyey-Greenstein weighted by the lattice weights, columns normalised; the discrete
/// asymmetry parameter is solved for so that the mean scattering cosine equals `g` exactly
/// (g = 0: isotropic).
PhaseMatrix phase_matrix(double g);
/// Mean cosine of scattering of column j of P.
double mean_cosine(const PhaseMatrix& p, int j);

struct LightingParams {
  double sigma_s_per_density = 0.5;                      ///< scattering per lattice step at cloud density 1
  double sigma_a_per_density = 0.005;                    ///< absorption per lattice step at cloud density 1
  double asymmetry = 0.0;                                ///< g of the Henyey-Greenstein phase function
  double sun_azimuth_deg = 135, sun_elevation_deg = 45;  ///< azimuth from +x towards +y
  double tolerance = 1e-5;                               ///< steady state: relative change of total photons per step
  int max_iterations = 5000;
  bool periodic = false;  ///< tests: a periodic box without sun

  /// Sets the sun: a finite azimuth and an elevation in (0, 90] deg (a sun on or below the
  /// horizon lights nothing); ValueError naming `key` otherwise.
  void set_sun(double azimuth_deg, double elevation_deg, const std::string& key);
};

struct PhotonBalance {
  double inflow = 0, outflow = 0, absorbed = 0;  ///< photons per step
};

class LightingSolver {
 public:
  /// `density` in [0, 1] per cell (e.g. the percolated cloud fraction).
  LightingSolver(Grid3 grid, std::vector<float> density, LightingParams params);
  /// A slab of `grid` for domain decomposition across processes: rows y_begin <= y < y_end
  /// (`density` holds those rows only, [z][y - y_begin][x]) plus one halo row on each side,
  /// into which the photons leaving the slab in y are streamed. After every step, the
  /// neighbours swap them: set_arrivals(side, its leaving(opposite side)). The sunlight enters
  /// only through the whole grid's faces, so the slabs step exactly as the whole grid does.
  LightingSolver(Grid3 grid, std::vector<float> density, LightingParams params, int y_begin, int y_end);
  /// One collision + streaming step; returns the relative change of the total photon count. A
  /// slab's residual and balance are its own until set_balance() gives the whole grid's.
  double step();
  /// Steps until the change falls below the tolerance; returns the steps taken. A slab passes
  /// `after_step`, which exchanges the photons that crossed into the halo rows and sets the
  /// whole grid's balance (set_balance); every slab calls it in the same order.
  int solve(const std::function<void(LightingSolver&)>& after_step = {});
  double residual() const { return residual_; }
  const PhotonBalance& balance() const { return balance_; }
  /// The photon balance of the last step per own row plane y (summed over z in order): what
  /// the whole grid's balance sums in y order (balance_of_planes), so that slabs reproduce it
  /// to the bit.
  const std::vector<std::array<double, 3>>& plane_balance() const { return plane_balance_; }
  /// Sums plane balances (absorbed, inflow, outflow) in order.
  static PhotonBalance balance_of_planes(const std::vector<std::array<double, 3>>& planes);
  /// Sets the balance (and from it the residual) of the last step: a slab's driver, with the
  /// whole grid's.
  void set_balance(const PhotonBalance& b);
  /// Total photon density per cell (sum over directions): the light field (a slab: its rows,
  /// [z][y - y_begin][x]).
  std::vector<float> light() const;
  double total() const;
  /// Puts photons `amount` at cell, spread over directions by the lattice weights (tests).
  void add_pulse(std::size_t cell, double amount);
  /// Puts photons `amount` at cell travelling in D3Q19 direction `dir` (1..18) (tests).
  void add_beam(std::size_t cell, int dir, double amount);
  /// Photons of D3Q19 direction `dir` (1..18) summed over the grid.
  double total_in_direction(int dir) const;
  const Grid3& grid() const { return global_; }
  /// The lattice directions the sun enters along and their weights (sum 1).
  const std::vector<std::pair<int, double>>& sun_directions() const { return sun_; }

  /// Halo exchange of a slab: leaving(side) holds the photons this step streamed out of the
  /// slab on that side (its halo row there, the directions that point that way; [z][dir][x]);
  /// set_arrivals(side, photons) puts the neighbour's on that side into this slab's edge row.
  /// At a face of the whole grid that is not periodic, arrivals are ignored (sunlight enters).
  enum class Side { below, above };
  std::vector<float> leaving(Side side) const;
  void set_arrivals(Side side, const std::vector<float>& photons);
  bool is_slab() const { return halo_ > 0; }

 private:
  LightingSolver(Grid3 grid, std::vector<float> density, LightingParams params, int y_begin, int y_end, int halo);
  std::size_t local_cell(std::size_t global_cell) const;
  struct RowScratch;
  /// Row `base`'s photons (nx cells from cell `base`) after the collision, a direction row each,
  /// into w.post; returns the photons the row absorbed.
  double collide_row(std::size_t base, RowScratch& w) const;
  /// Row (y, z)'s post-collision rows (global row yg) pushed to their destination rows
  /// (y + c_y, z + c_z), shifted by c_x: photons leaving the grid add to `outflow`, the
  /// sunlight `inject` entering at a row's x edge to `inflow`.
  void push_row(int y, int yg, int z, const std::array<float, light_dirs>& inject, RowScratch& w, double& inflow,
                double& outflow);
  Grid3 global_, g_;  // the whole grid; the stored grid (a slab: its rows and halo rows)
  int y_begin_ = 0, halo_ = 0;
  LightingParams p_;
  std::vector<float> sigma_s_, sigma_a_;
  // [dir][cell], photons arriving at each cell (before its collision); huge pages: 2 MiB-aligned
  // rows for streaming stores.
  std::vector<float, HugePageAllocator<float>> i_, next_;
  PhaseMatrix phase_;
  bool isotropic_;
  std::vector<std::pair<int, double>> sun_;
  double residual_ = 1;
  PhotonBalance balance_;
  std::vector<std::array<double, 3>> plane_balance_;
};

}  // namespace nephos::lbm
