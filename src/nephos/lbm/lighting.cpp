#include "nephos/lbm/lighting.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "nephos/core/error.hpp"

namespace nephos::lbm {
namespace {

struct Dir {
  double c[3];
  double unit[3];
  double weight;  // D3Q19 lattice weight
};

std::array<Dir, light_dirs> dirs() {
  std::array<Dir, light_dirs> d{};
  for (int k = 0; k < light_dirs; ++k) {
    const auto i = static_cast<std::size_t>(k + 1);
    const double c[3] = {static_cast<double>(d3q19::cx[i]), static_cast<double>(d3q19::cy[i]),
                         static_cast<double>(d3q19::cz[i])};
    const double len = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    auto& e = d[static_cast<std::size_t>(k)];
    for (int a = 0; a < 3; ++a) e.c[a] = c[a], e.unit[a] = c[a] / len;
    e.weight = k < 6 ? 1.0 / 18.0 : 1.0 / 36.0;
  }
  return d;
}

double hg(double mu, double g) { return (1 - g * g) / std::pow(1 + g * g - 2 * g * mu, 1.5); }

// Column j of the phase matrix for Henyey-Greenstein parameter g'.
std::array<double, light_dirs> column(int j, double gp) {
  const auto d = dirs();
  std::array<double, light_dirs> col{};
  double sum = 0;
  for (int i = 0; i < light_dirs; ++i) {
    const auto& a = d[static_cast<std::size_t>(i)];
    const auto& b = d[static_cast<std::size_t>(j)];
    const double mu = a.unit[0] * b.unit[0] + a.unit[1] * b.unit[1] + a.unit[2] * b.unit[2];
    col[static_cast<std::size_t>(i)] = a.weight * hg(mu, gp);
    sum += col[static_cast<std::size_t>(i)];
  }
  for (double& v : col) v /= sum;
  return col;
}

double column_mean_cosine(const std::array<double, light_dirs>& col, int j) {
  const auto d = dirs();
  double m = 0;
  for (int i = 0; i < light_dirs; ++i) {
    const auto& a = d[static_cast<std::size_t>(i)];
    const auto& b = d[static_cast<std::size_t>(j)];
    m += col[static_cast<std::size_t>(i)] * (a.unit[0] * b.unit[0] + a.unit[1] * b.unit[1] + a.unit[2] * b.unit[2]);
  }
  return m;
}

}  // namespace

PhaseMatrix phase_matrix(double g) {
  if (!(g > -0.95 && g < 0.95))
    throw ValueError("phase-function asymmetry must be in (-0.95, 0.95)", {.key = "asymmetry"});
  PhaseMatrix p{};
  for (int j = 0; j < light_dirs; ++j) {
    // Solve for the discrete parameter g' whose column has mean cosine g (bisection; the mean
    // cosine increases monotonically with g').
    double lo = -0.999, hi = 0.999;
    for (int it = 0; it < 100; ++it) {
      const double mid = 0.5 * (lo + hi);
      (column_mean_cosine(column(j, mid), j) < g ? lo : hi) = mid;
    }
    const auto col = column(j, 0.5 * (lo + hi));
    for (int i = 0; i < light_dirs; ++i)
      p[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = col[static_cast<std::size_t>(i)];
  }
  return p;
}

double mean_cosine(const PhaseMatrix& p, int j) {
  std::array<double, light_dirs> col{};
  for (int i = 0; i < light_dirs; ++i)
    col[static_cast<std::size_t>(i)] = p[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
  return column_mean_cosine(col, j);
}

LightingSolver::LightingSolver(Grid3 grid, std::vector<float> density, LightingParams params)
    : g_(grid), p_(params), phase_(phase_matrix(params.asymmetry)), isotropic_(params.asymmetry == 0) {
  if (density.size() != g_.cells()) throw ValueError("density field does not match the lighting grid");
  const std::size_t n = g_.cells();
  sigma_s_.resize(n);
  sigma_a_.resize(n);
  for (std::size_t c = 0; c < n; ++c) {
    const double rho = std::clamp(static_cast<double>(density[c]), 0.0, 1.0);
    sigma_s_[c] = static_cast<float>(p_.sigma_s_per_density * rho);
    sigma_a_[c] = static_cast<float>(p_.sigma_a_per_density * rho);
    if (sigma_s_[c] + sigma_a_[c] > 1.0f) throw ValueError("sigma_s + sigma_a must not exceed 1 per lattice step");
  }
  i_.assign(static_cast<std::size_t>(light_dirs) * n, 0.0f);
  next_.assign(i_.size(), 0.0f);
  if (!p_.periodic) {
    // Light travels along -(direction towards the sun); inject along the three lattice
    // directions closest to it, weighted by their cosine to it.
    const double ea = p_.sun_elevation_deg * M_PI / 180, az = p_.sun_azimuth_deg * M_PI / 180;
    const double travel[3] = {-std::cos(ea) * std::cos(az), -std::cos(ea) * std::sin(az), -std::sin(ea)};
    std::vector<std::pair<double, int>> cosines;
    const auto d = dirs();
    for (int k = 0; k < light_dirs; ++k) {
      const auto& u = d[static_cast<std::size_t>(k)].unit;
      cosines.emplace_back(u[0] * travel[0] + u[1] * travel[1] + u[2] * travel[2], k);
    }
    std::sort(cosines.rbegin(), cosines.rend());
    double sum = 0;
    for (int k = 0; k < 3; ++k) sum += std::max(0.0, cosines[static_cast<std::size_t>(k)].first);
    for (int k = 0; k < 3; ++k)
      if (cosines[static_cast<std::size_t>(k)].first > 0)
        sun_.emplace_back(cosines[static_cast<std::size_t>(k)].second,
                          cosines[static_cast<std::size_t>(k)].first / sum);
  }
}

void LightingSolver::add_pulse(std::size_t cell, double amount) {
  const std::size_t n = g_.cells();
  for (int k = 0; k < light_dirs; ++k)
    i_[static_cast<std::size_t>(k) * n + cell] += static_cast<float>(amount * (k < 6 ? 1.0 / 12.0 : 1.0 / 24.0));
}

void LightingSolver::add_beam(std::size_t cell, int dir, double amount) {
  i_[static_cast<std::size_t>(dir - 1) * g_.cells() + cell] += static_cast<float>(amount);
}

double LightingSolver::total_in_direction(int dir) const {
  double s = 0;
  const std::size_t n = g_.cells();
  for (std::size_t c = 0; c < n; ++c) s += i_[static_cast<std::size_t>(dir - 1) * n + c];
  return s;
}

double LightingSolver::total() const {
  double s = 0;
  for (float v : i_) s += v;
  return s;
}

std::vector<float> LightingSolver::light() const {
  const std::size_t n = g_.cells();
  std::vector<float> out(n, 0.0f);
  for (int k = 0; k < light_dirs; ++k)
    for (std::size_t c = 0; c < n; ++c) out[c] += i_[static_cast<std::size_t>(k) * n + c];
  return out;
}

double LightingSolver::step() {
  const std::size_t n = g_.cells();
  double absorbed = 0;
  // Collision into next_, in blocks of cells so that the 18 direction arrays stay in cache and
  // every loop runs over contiguous cells (vectorised).
  constexpr std::size_t block = 512;
  const std::size_t blocks = (n + block - 1) / block;
#pragma omp parallel for reduction(+ : absorbed) schedule(static)
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t c0 = b * block, c1 = std::min(n, c0 + block), m = c1 - c0;
    float sum[block];
    for (std::size_t c = 0; c < m; ++c) sum[c] = 0;
    for (int k = 0; k < light_dirs; ++k) {
      const float* in = i_.data() + static_cast<std::size_t>(k) * n + c0;
      for (std::size_t c = 0; c < m; ++c) sum[c] += in[c];
    }
    const float* ss = sigma_s_.data() + c0;
    const float* sa = sigma_a_.data() + c0;
    for (std::size_t c = 0; c < m; ++c) absorbed += static_cast<double>(sa[c]) * sum[c];
    for (int k = 0; k < light_dirs; ++k) {
      const float* in = i_.data() + static_cast<std::size_t>(k) * n + c0;
      float* out = next_.data() + static_cast<std::size_t>(k) * n + c0;
      if (isotropic_) {
        const float w = k < 6 ? 1.0f / 12.0f : 1.0f / 24.0f;
        for (std::size_t c = 0; c < m; ++c) out[c] = (1 - ss[c] - sa[c]) * in[c] + ss[c] * w * sum[c];
      } else {
        float scat[block];
        for (std::size_t c = 0; c < m; ++c) scat[c] = 0;
        for (int j = 0; j < light_dirs; ++j) {
          const float pkj = static_cast<float>(phase_[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)]);
          const float* ij = i_.data() + static_cast<std::size_t>(j) * n + c0;
          for (std::size_t c = 0; c < m; ++c) scat[c] += pkj * ij[c];
        }
        for (std::size_t c = 0; c < m; ++c) out[c] = (1 - ss[c] - sa[c]) * in[c] + ss[c] * scat[c];
      }
    }
  }
  // Streaming (pull), row by row: open boundaries inject sunlight along the sun directions,
  // periodic ones wrap; count what enters and what leaves.
  std::array<float, light_dirs> inject{};
  for (const auto& [k, w] : sun_) inject[static_cast<std::size_t>(k)] = static_cast<float>(w);
  double inflow = 0, outflow = 0;
  const int nx = g_.nx;
#pragma omp parallel for collapse(2) reduction(+ : inflow, outflow) schedule(static)
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < g_.ny; ++y)
      for (int k = 0; k < light_dirs; ++k) {
        const auto ku = static_cast<std::size_t>(k + 1);
        const int cx = d3q19::cx[ku], cy = d3q19::cy[ku], cz = d3q19::cz[ku];
        const float inj = p_.periodic ? 0.0f : inject[static_cast<std::size_t>(k)];
        float* out = i_.data() + static_cast<std::size_t>(k) * n + g_.index(0, y, z);
        const float* here = next_.data() + static_cast<std::size_t>(k) * n + g_.index(0, y, z);
        int sy = y - cy, sz = z - cz;
        const bool row_outside = sy < 0 || sy >= g_.ny || sz < 0 || sz >= g_.nz;
        if (row_outside && !p_.periodic) {
          for (int x = 0; x < nx; ++x) out[x] = inj;
          inflow += static_cast<double>(inj) * nx;
        } else {
          sy = (sy + g_.ny) % g_.ny, sz = (sz + g_.nz) % g_.nz;
          const float* src = next_.data() + static_cast<std::size_t>(k) * n + g_.index(0, sy, sz);
          if (cx == 0) {
            for (int x = 0; x < nx; ++x) out[x] = src[x];
          } else if (cx == 1) {
            for (int x = 1; x < nx; ++x) out[x] = src[x - 1];
            out[0] = p_.periodic ? src[nx - 1] : inj;
            if (!p_.periodic) inflow += inj;
          } else {
            for (int x = 0; x < nx - 1; ++x) out[x] = src[x + 1];
            out[nx - 1] = p_.periodic ? src[0] : inj;
            if (!p_.periodic) inflow += inj;
          }
        }
        if (p_.periodic) continue;
        // Post-collision photons here whose destination is outside the box leave it.
        const int dy = y + cy, dz = z + cz;
        if (dy < 0 || dy >= g_.ny || dz < 0 || dz >= g_.nz) {
          for (int x = 0; x < nx; ++x) outflow += here[x];
        } else if (cx == 1) {
          outflow += here[nx - 1];
        } else if (cx == -1) {
          outflow += here[0];
        }
      }
  balance_ = {inflow, outflow, absorbed};
  residual_ = inflow > 0 ? std::abs(inflow - outflow - absorbed) / inflow : 0.0;
  return residual_;
}

int LightingSolver::solve() {
  int it = 0, quiet = 0;
  while (it < p_.max_iterations) {
    step();
    ++it;
    // Converged once the photon balance has held for 10 consecutive steps.
    quiet = residual_ < p_.tolerance ? quiet + 1 : 0;
    if (quiet >= 10) break;
  }
  return it;
}

}  // namespace nephos::lbm
