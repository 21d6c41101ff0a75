#pragma once
// Rayleigh-Benard validation of the lattice's thermal coupling: an incompressible D3Q19 BGK
// fluid with a Boussinesq buoyancy force (velocity shift of eq. 10) and a D3Q7 advection-
// diffusion lattice for temperature, between no-slip plates at fixed temperatures (bottom hot).
// Lattice units; z up; periodic in x and y.
//   nu = (xi_f - 1/2)/3, kappa = (xi_t - 1/2)/4, Ra = g beta dT H^3 / (nu kappa).
#include <vector>

#include "nephos/lbm/lattice.hpp"

namespace nephos::lbm {

class RayleighBenard {
 public:
  /// H = nz fluid layers between the walls (halfway bounce-back), width nx, depth ny.
  RayleighBenard(int nx, int ny, int nz, double rayleigh, double nu, double kappa);
  /// Linear conduction profile plus amplitude * cos(2 pi x / nx) sin(pi z / H) in temperature.
  void initialise(double amplitude);
  void step();
  /// Kinetic energy sum rho u^2 / 2 over the box.
  double kinetic_energy() const;
  /// Amplitude of the first convective mode: sum over x of u_z(x, mid-height) cos(2 pi x / nx)
  /// (projects out the x-independent hydrostatic and acoustic adjustment).
  double convective_amplitude() const;
  double buoyancy_per_kelvin() const { return g_beta_; }

 private:
  Grid3 g_;
  double nu_, kappa_, g_beta_;
  double xi_f_, xi_t_;
  std::vector<float> f_, f2_;  // fluid, shifted by w_i (rho_ref = 1)
  std::vector<float> t_, t2_;  // temperature D3Q7
  std::vector<float> temp_;    // temperature field
};

}  // namespace nephos::lbm
