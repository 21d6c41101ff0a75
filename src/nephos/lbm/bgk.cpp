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
  const int nx = g_.nx;
  const float omega = static_cast<float>(1.0 / xi_), d = static_cast<float>(d_);
  const float shift = static_cast<float>(xi_);  // u_eq = u + xi F / rho (eq. 10, tau = 1)
  const float sfx = shift * static_cast<float>(force_[0]), sfy = shift * static_cast<float>(force_[1]),
              sfz = shift * static_cast<float>(force_[2]);
#pragma omp parallel
  {
    // Per-thread row buffers: populations (19 x nx) and the row's moments.
    std::vector<float> f(static_cast<std::size_t>(d3q19::q) * static_cast<std::size_t>(nx));
    std::vector<float> post(f.size());  // the row's post-collision populations, streamed out
    std::vector<float> drho_v(static_cast<std::size_t>(nx)), ux_v(drho_v.size()), uy_v(drho_v.size()),
        uz_v(drho_v.size()), rho_v(drho_v.size());
#pragma omp for collapse(2) schedule(static)
    for (int z = 0; z < g_.nz; ++z)
      for (int y = 0; y < g_.ny; ++y) {
        gather_row(row_sources(g_, a_.data(), y, z, zb_), f.data(), static_cast<std::size_t>(nx));
        float* drho = drho_v.data();
        float* ux = ux_v.data();
        float* uy = uy_v.data();
        float* uz = uz_v.data();
        float* rho = rho_v.data();
        auto F = [&](int i) { return f.data() + static_cast<std::size_t>(i) * static_cast<std::size_t>(nx); };
        for (int x = 0; x < nx; ++x) drho[x] = ux[x] = uy[x] = uz[x] = 0;
#pragma GCC unroll 19
        for (int i = 0; i < d3q19::q; ++i) {
          const float* fi = F(i);
          const float cx = static_cast<float>(d3q19::cx[static_cast<std::size_t>(i)]);
          const float cy = static_cast<float>(d3q19::cy[static_cast<std::size_t>(i)]);
          const float cz = static_cast<float>(d3q19::cz[static_cast<std::size_t>(i)]);
          for (int x = 0; x < nx; ++x) {
            drho[x] += fi[x];
            ux[x] += cx * fi[x];
            uy[x] += cy * fi[x];
            uz[x] += cz * fi[x];
          }
        }
        for (int x = 0; x < nx; ++x) {  // populations are shifted by w_i (rho_ref = 1)
          rho[x] = 1.0f + drho[x];
          const float inv = 1.0f / rho[x];
          ux[x] = (ux[x] + sfx) * inv;
          uy[x] = (uy[x] + sfy) * inv;
          uz[x] = (uz[x] + sfz) * inv;
        }
        float* out = b_.data() + g_.index(0, y, z);
#pragma GCC unroll 19
        for (int i = 0; i < d3q19::q; ++i) {
          const float* fi = F(i);
          float* o = post.data() + static_cast<std::size_t>(i) * static_cast<std::size_t>(nx);
          const float cx = static_cast<float>(d3q19::cx[static_cast<std::size_t>(i)]);
          const float cy = static_cast<float>(d3q19::cy[static_cast<std::size_t>(i)]);
          const float cz = static_cast<float>(d3q19::cz[static_cast<std::size_t>(i)]);
          // Shifted equilibrium (d3q19::equilibrium_shifted), vectorised over the row.
          const auto e = d3q19::equilibrium_coefficients<float>(i, d);
          for (int x = 0; x < nx; ++x) {
            const float cu = cx * ux[x] + cy * uy[x] + cz * uz[x];
            const float u2 = ux[x] * ux[x] + uy[x] * uy[x] + uz[x] * uz[x];
            const float feq = e.w * drho[x] + rho[x] * (e.k1 * cu + e.k2 * cu * cu - e.k3 * u2);
            o[x] = fi[x] - omega * (fi[x] - feq);
          }
          store_streaming(out + static_cast<std::size_t>(i) * n, o, static_cast<std::size_t>(nx));
        }
      }
    stream_fence();
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
