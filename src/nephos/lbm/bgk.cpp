#include "nephos/lbm/bgk.hpp"

#include "nephos/core/error.hpp"

namespace nephos::lbm {

BgkSolver::BgkSolver(Grid3 grid, double relaxation_time, ZBoundary zb, std::array<double, 3> body_force,
                     double rest_fraction)
    : g_(grid), xi_(relaxation_time), zb_(zb), force_(body_force), d_(rest_fraction) {
  if (!(xi_ > 0.5)) throw ValueError("relaxation time must exceed 1/2 for stability", {.key = "xi"});
  a_.resize(d3q19::q * g_.cells());
  b_.resize(a_.size());
}

void BgkSolver::initialise(double rho) {
  float feq[d3q19::q];
  d3q19::equilibrium_shifted<float>(static_cast<float>(rho - 1.0), static_cast<float>(rho), 0, 0, 0,
                                    static_cast<float>(d_), feq);
  const std::size_t n = g_.cells();
  for (int i = 0; i < d3q19::q; ++i)
    std::fill(a_.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(i) * n),
              a_.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(i + 1) * n), feq[i]);
}

void BgkSolver::step() {
  const std::size_t n = g_.cells();
  const float omega = static_cast<float>(1.0 / xi_), d = static_cast<float>(d_);
  const float fx = static_cast<float>(force_[0]), fy = static_cast<float>(force_[1]), fz = static_cast<float>(force_[2]);
  const float shift = static_cast<float>(xi_);  // u_eq = u + xi F / rho (eq. 10, tau = 1)
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < g_.ny; ++y) {
      const RowSources src = row_sources(g_, a_.data(), y, z, zb_);
      float* out = b_.data() + g_.index(0, y, z);
      for (int x = 0; x < g_.nx; ++x) {
        float f[d3q19::q];
        float drho = 0, jx = 0, jy = 0, jz = 0;  // populations are shifted by w_i (rho_ref = 1)
        for (int i = 0; i < d3q19::q; ++i) {
          f[i] = *src.at(i, x);
          drho += f[i];
          jx += f[i] * static_cast<float>(d3q19::cx[static_cast<std::size_t>(i)]);
          jy += f[i] * static_cast<float>(d3q19::cy[static_cast<std::size_t>(i)]);
          jz += f[i] * static_cast<float>(d3q19::cz[static_cast<std::size_t>(i)]);
        }
        const float rho = 1.0f + drho, inv = 1.0f / rho;
        float feq[d3q19::q];
        d3q19::equilibrium_shifted<float>(drho, rho, (jx + shift * fx) * inv, (jy + shift * fy) * inv,
                                          (jz + shift * fz) * inv, d, feq);
        for (int i = 0; i < d3q19::q; ++i)
          out[static_cast<std::size_t>(i) * n + static_cast<std::size_t>(x)] = f[i] - omega * (f[i] - feq[i]);
      }
    }
  a_.swap(b_);
}

double BgkSolver::density(std::size_t cell) const {
  double rho = 1.0;  // rho_ref
  for (int i = 0; i < d3q19::q; ++i) rho += a_[static_cast<std::size_t>(i) * g_.cells() + cell];
  return rho;
}

std::array<double, 3> BgkSolver::velocity(std::size_t cell) const {
  // a_ holds post-collision populations; the momentum of the post-collision state already
  // includes the full force impulse, so the cross-collision average (eq. 11) is j - F/2.
  double j[3] = {0, 0, 0};
  for (int i = 0; i < d3q19::q; ++i) {
    const double f = a_[static_cast<std::size_t>(i) * g_.cells() + cell];
    j[0] += f * d3q19::cx[static_cast<std::size_t>(i)];
    j[1] += f * d3q19::cy[static_cast<std::size_t>(i)];
    j[2] += f * d3q19::cz[static_cast<std::size_t>(i)];
  }
  const double rho = density(cell);
  return {(j[0] - 0.5 * force_[0]) / rho, (j[1] - 0.5 * force_[1]) / rho, (j[2] - 0.5 * force_[2]) / rho};
}

double BgkSolver::total_mass() const {
  double m = static_cast<double>(g_.cells());  // rho_ref per cell
  for (float v : a_) m += v;
  return m;
}

}  // namespace nephos::lbm
