#pragma once
// The Nagel-Raschke cloud automaton (Nagel & Raschke 1992, in the formulation of Dobashi et
// al. 2000) used by the lattice-Boltzmann cloud seed (section 4.2) to add fine detail.
// Three boolean states per cell of a grid refined K times per axis: humidity (hum),
// activation (act), cloud (cld). One synchronous step:
//   hum' = hum AND NOT act
//   cld' = cld OR act
//   act' = NOT act AND hum AND f_act,
//   f_act = act at x+-1, x+-2, y+-1, y+-2 (horizontal) or z-1, z-2 (below)
// so activation spreads sideways and upwards but never downwards (the asymmetric upward rule).
// Without the optional extinction rule (cld' = cld AND NOT ext, ext with probability p_ext)
// a cloud site never switches off. States are bit-packed along x (64 cells per word).
#include <cstdint>
#include <functional>
#include <vector>

#include "nephos/lbm/lattice.hpp"

namespace nephos::lbm {

struct PercolationParams {
  int refinement = 5;              ///< K
  double epsilon_below = 0.00025;  ///< eps1: no humidity where vapour < rho10 - eps1
  double epsilon_above = 0.0002;   ///< eps2: all humid where vapour > rho10 + eps2
  double rho10 = 1.0;
  double initial_activation = 0.01;  ///< probability that a humid site starts active
  double extinction = 0.0;           ///< probability per step that a cloud site vanishes
  int max_steps = 2000;
};

class Percolation {
 public:
  /// Seeds the refined grid from the vapour density on `coarse` (section 4.2).
  Percolation(const Grid3& coarse, const std::vector<float>& vapour, const PercolationParams& params,
              std::uint64_t seed);
  /// A slab of the refined grid, for domain decomposition across processes: the sites of the
  /// coarse rows y_begin <= y < y_end (`vapour` holds those rows only, [z][y - y_begin][x], as
  /// a water-model slab's vapour()), plus two halo rows of activation on each side, which
  /// set_halo() fills from the neighbouring slabs' edge_rows() before every step (periodic in
  /// y: the last slab's neighbour above is the first). Seeding and extinction hash global site
  /// indices, so the slabs together step exactly as the whole grid does.
  Percolation(const Grid3& coarse, const std::vector<float>& vapour, const PercolationParams& params,
              std::uint64_t seed, int y_begin, int y_end);
  /// Makes fine site (x, y, z) active (and humid): explicit seeding, e.g. for tests. y is the
  /// global fine row, which must lie in this slab.
  void set_active(int x, int y, int z);
  /// One synchronous update; returns the number of active sites after it (in this slab).
  std::size_t step();
  /// What run() calls besides stepping. A slab needs `exchange`, which fills its halo rows
  /// (set_halo) before each step, and `total`, the sum of a count over all slabs (every slab
  /// calls both in the same order); `after_step` (optional) gets the step number (from 1) and
  /// the active sites of the whole grid after it, e.g. for progress.
  struct RunHooks {
    std::function<void(Percolation&)> exchange;
    std::function<std::size_t(std::size_t)> total;
    std::function<void(int, std::size_t)> after_step;
  };
  /// Steps until no site is active (or max_steps); returns the number of steps taken.
  int run(const RunHooks& hooks = {});
  /// Cloud fraction per coarse cell: the mean of cld over each K^3 block (a slab: its coarse
  /// rows, [z][y - y_begin][x]).
  std::vector<float> coarse_density() const;
  /// Counts of sites in each state (a slab: its own sites).
  std::size_t count_humid() const { return popcount(hum_); }
  std::size_t count_active() const { return popcount(act_); }
  std::size_t count_cloud() const { return popcount(cld_); }
  /// The cloud field projected along z (OR over the column), fine resolution, row-major y, x
  /// (a slab: its own rows).
  std::vector<std::uint8_t> projected_cloud() const;
  const Grid3& fine() const { return fine_; }
  /// Site (x, y, z) is cloud; y is the global fine row, which must lie in this slab.
  bool cloud(int x, int y, int z) const { return bit(cld_, x, y, z); }

  /// Halo exchange of a slab. edge_rows(side): the activation of the two rows of this slab
  /// nearest `side`, every z ([z][row][word]); set_halo(side, rows): the neighbour's on that
  /// side (its edge_rows of the opposite side) into this slab's halo rows there.
  enum class Side { below, above };
  std::vector<std::uint64_t> edge_rows(Side side) const;
  void set_halo(Side side, const std::vector<std::uint64_t>& rows);
  bool is_slab() const { return halo_ > 0; }

 private:
  // The whole grid is the slab of every row without halo rows (halo 0: y wraps instead).
  Percolation(const Grid3& coarse, const std::vector<float>& vapour, const PercolationParams& params,
              std::uint64_t seed, int y_begin, int y_end, int halo);
  void seed_sites(const std::vector<float>& vapour);
  std::size_t popcount(const std::vector<std::uint64_t>& v) const;
  bool bit(const std::vector<std::uint64_t>& v, int x, int y, int z) const;  // y: global fine row
  bool bit_local(const std::vector<std::uint64_t>& v, int x, int yl, int z) const {
    return (v[row(yl, z) + static_cast<std::size_t>(x >> 6)] >> (x & 63)) & 1ULL;
  }
  // Word offset of local row yl (halo rows first in a slab) of plane z.
  std::size_t row(int yl, int z) const { return (static_cast<std::size_t>(z) * local_ny_ + yl) * words_; }
  int local_row(int y_global) const;
  Grid3 coarse_, fine_;  // the whole grid, coarse and refined
  PercolationParams p_;
  std::uint64_t seed_;
  int words_;                              // 64-bit words per fine row
  int y_begin_ = 0, y_end_ = 0;            // coarse rows of this slab (the whole grid: 0, ny)
  int halo_ = 0, own_ = 0, local_ny_ = 0;  // fine halo rows per side (0: whole grid), own rows, stored rows
  long step_ = 0;
  std::vector<std::uint64_t> hum_, act_, cld_, next_act_, next_hum_;
};

/// Site count (area) and perimeter-site count (clear sites with at least one 4-neighbour in
/// the cluster, each counted once) of one cluster of a 2D binary field.
struct ClusterSize {
  long area, perimeter;
};
/// The 4-connected clusters of a periodic nx x ny field (row-major y, x), in order of their
/// first site.
std::vector<ClusterSize> cluster_sizes(const std::vector<std::uint8_t>& field, int nx, int ny);

/// Perimeter-area fractal dimension of the clusters of a 2D binary field (4-connectivity,
/// periodic): least-squares slope of log P against log A over clusters with A >= min_area,
/// D = 2 * slope (P ~ A^(D/2); Lovejoy 1982). A is the cluster's site count and P its
/// perimeter-site count, the clear sites with at least one neighbour in the cluster: the
/// lattice definition of Nagel & Raschke (1992) and Schneider & Woehlke (1992), whose D the
/// tests compare with. Returns NaN with fewer than 10 clusters.
double perimeter_area_dimension(const std::vector<std::uint8_t>& field, int nx, int ny, int min_area = 4);

}  // namespace nephos::lbm
