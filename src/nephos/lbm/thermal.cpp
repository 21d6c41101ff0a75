#include "nephos/lbm/thermal.hpp"

#include <cmath>

#include "nephos/core/error.hpp"

namespace nephos::lbm {
namespace {
// D3Q7: rest + 6 axis directions (same order as D3Q19's first seven), c_s^2 = 1/4.
constexpr int q7 = 7;
constexpr double w7[q7] = {0.25, 0.125, 0.125, 0.125, 0.125, 0.125, 0.125};
constexpr double t_hot = 0.5, t_cold = -0.5;  // wall temperatures (dT = 1), mean 0
}  // namespace

RayleighBenard::RayleighBenard(int nx, int ny, int nz, double rayleigh, double nu, double kappa)
    : g_{nx, ny, nz}, nu_(nu), kappa_(kappa) {
  if (nx < 2 || ny < 1 || nz < 4) throw ValueError("Rayleigh-Benard box too small");
  xi_f_ = 3 * nu + 0.5;
  xi_t_ = 4 * kappa + 0.5;
  g_beta_ = rayleigh * nu * kappa / std::pow(static_cast<double>(nz), 3);  // dT = 1
  const std::size_t n = g_.cells();
  f_.assign(d3q19::q * n, 0.0f);
  f2_ = f_;
  t_.assign(q7 * n, 0.0f);
  t2_ = t_;
  temp_.assign(n, 0.0f);
}

void RayleighBenard::initialise(double amplitude) {
  const std::size_t n = g_.cells();
  std::fill(f_.begin(), f_.end(), 0.0f);  // rest at rho = 1 (shifted populations are 0)
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < g_.ny; ++y)
      for (int x = 0; x < g_.nx; ++x) {
        const double zz = z + 0.5;
        const double tc = t_hot + (t_cold - t_hot) * zz / g_.nz +
                          amplitude * std::cos(2 * M_PI * (x + 0.5) / g_.nx) * std::sin(M_PI * zz / g_.nz);
        const std::size_t c = g_.index(x, y, z);
        temp_[c] = static_cast<float>(tc);
        for (int i = 0; i < q7; ++i) t_[static_cast<std::size_t>(i) * n + c] = static_cast<float>(w7[i] * tc);
      }
}

void RayleighBenard::step() {
  const std::size_t n = g_.cells();
  const int nx = g_.nx, ny = g_.ny, nz = g_.nz;
  const double omega_f = 1.0 / xi_f_, omega_t = 1.0 / xi_t_;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x) {
        const std::size_t c = g_.index(x, y, z);
        // Fluid: pull with halfway bounce-back at the plates.
        double f[d3q19::q], drho = 0, j[3] = {0, 0, 0};
        for (int i = 0; i < d3q19::q; ++i) {
          const auto iu = static_cast<std::size_t>(i);
          const int sz = z - d3q19::cz[iu];
          if (sz < 0 || sz >= nz) {
            f[i] = f_[static_cast<std::size_t>(d3q19::opposite[iu]) * n + c];
          } else {
            const int sx = (x - d3q19::cx[iu] + nx) % nx, sy = (y - d3q19::cy[iu] + ny) % ny;
            f[i] = f_[iu * n + g_.index(sx, sy, sz)];
          }
          drho += f[i];
          j[0] += f[i] * d3q19::cx[iu];
          j[1] += f[i] * d3q19::cy[iu];
          j[2] += f[i] * d3q19::cz[iu];
        }
        // Temperature: pull with anti-bounce-back (Dirichlet) at the plates.
        double tt[q7], temp = 0;
        for (int i = 0; i < q7; ++i) {
          const auto iu = static_cast<std::size_t>(i);
          const int sz = z - d3q19::cz[iu];
          if (sz < 0 || sz >= nz) {
            const double tw = sz < 0 ? t_hot : t_cold;
            tt[i] = -t_[static_cast<std::size_t>(d3q19::opposite[iu]) * n + c] + 2 * w7[i] * tw;
          } else {
            const int sx = (x - d3q19::cx[iu] + nx) % nx, sy = (y - d3q19::cy[iu] + ny) % ny;
            tt[i] = t_[iu * n + g_.index(sx, sy, sz)];
          }
          temp += tt[i];
        }
        temp_[c] = static_cast<float>(temp);
        const double rho = 1 + drho;
        const double force_z = rho * g_beta_ * temp;  // Boussinesq, reference temperature 0
        const double ux = j[0] / rho, uy = j[1] / rho, uz_eq = (j[2] + xi_f_ * force_z) / rho;
        const double uz = (j[2] + 0.5 * force_z) / rho;  // physical velocity (eq. 11)
        double feq[d3q19::q];
        d3q19::equilibrium_shifted<double>(drho, rho, ux, uy, uz_eq, 1.0 / 3.0, feq);
        for (int i = 0; i < d3q19::q; ++i)
          f2_[static_cast<std::size_t>(i) * n + c] = static_cast<float>(f[i] - omega_f * (f[i] - feq[i]));
        const double u[3] = {ux, uy, uz};
        for (int i = 0; i < q7; ++i) {
          const auto iu = static_cast<std::size_t>(i);
          const double cu = d3q19::cx[iu] * u[0] + d3q19::cy[iu] * u[1] + d3q19::cz[iu] * u[2];
          const double teq = w7[i] * temp * (1 + 4 * cu);
          t2_[iu * n + c] = static_cast<float>(tt[i] - omega_t * (tt[i] - teq));
        }
      }
  f_.swap(f2_);
  t_.swap(t2_);
}

double RayleighBenard::convective_amplitude() const {
  const std::size_t n = g_.cells();
  double a = 0;
  for (int y = 0; y < g_.ny; ++y)
    for (int x = 0; x < g_.nx; ++x) {
      double uz = 0, rho = 1;
      for (int z : {g_.nz / 2 - 1, g_.nz / 2}) {  // average the two middle layers
        const std::size_t c = g_.index(x, y, z);
        double drho = 0, jz = 0;
        for (int i = 0; i < d3q19::q; ++i) {
          const auto iu = static_cast<std::size_t>(i);
          drho += f_[iu * n + c];
          jz += static_cast<double>(f_[iu * n + c]) * d3q19::cz[iu];
        }
        rho = 1 + drho;
        uz += 0.5 * jz / rho;
      }
      a += uz * std::cos(2 * M_PI * (x + 0.5) / g_.nx);
    }
  return a;
}

double RayleighBenard::kinetic_energy() const {
  const std::size_t n = g_.cells();
  double e = 0;
  for (std::size_t c = 0; c < n; ++c) {
    double drho = 0, j[3] = {0, 0, 0};
    for (int i = 0; i < d3q19::q; ++i) {
      const auto iu = static_cast<std::size_t>(i);
      const double f = f_[iu * n + c];
      drho += f;
      j[0] += f * d3q19::cx[iu];
      j[1] += f * d3q19::cy[iu];
      j[2] += f * d3q19::cz[iu];
    }
    e += 0.5 * (j[0] * j[0] + j[1] * j[1] + j[2] * j[2]) / (1 + drho);
  }
  return e;
}

}  // namespace nephos::lbm
