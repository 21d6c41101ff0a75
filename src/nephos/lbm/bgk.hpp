#pragma once
// Single-component D3Q19 BGK (the LBGK operator of eq. 6 with one component) with a uniform
// body force by the velocity shift of eq. (10), and optional no-slip walls at the z ends. Used
// to validate the lattice against analytic flows and to measure the streaming kernel.
// Lattice units: spacing 1, time step 1; kinematic viscosity nu = (xi - 1/2) / 3.
#include <array>
#include <vector>

#include "nephos/core/huge_page_allocator.hpp"
#include "nephos/lbm/lattice.hpp"

namespace nephos::lbm {

class BgkSolver {
 public:
  BgkSolver(Grid3 grid, double relaxation_time, ZBoundary zb, std::array<double, 3> body_force = {0, 0, 0},
            double rest_fraction = 1.0 / 3.0);
  const Grid3& grid() const { return g_; }
  /// Sets every cell to equilibrium at density rho and velocity 0.
  void initialise(double rho);
  /// One fused stream + collide update of every cell.
  void step();
  double density(std::size_t cell) const;
  /// Physical velocity u = (sum_i f_i c_i + F/2) / rho (eq. 11).
  std::array<double, 3> velocity(std::size_t cell) const;
  double total_mass() const;
  double viscosity() const { return (xi_ - 0.5) / 3.0; }

 private:
  Grid3 g_;
  double xi_;
  ZBoundary zb_;
  std::array<double, 3> force_;
  double d_;
  // a_: post-collision populations (current state). Huge pages: 2 MiB-aligned rows for
  // streaming stores, and 38 concurrent streams that would otherwise thrash the TLB.
  std::vector<float, HugePageAllocator<float>> a_, b_;
};

}  // namespace nephos::lbm
