#include "nephos/lbm/water_model.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"

namespace nephos::lbm {

WaterModelParams WaterModelParams::from(const ParamDict& dict) {
  WaterModelParams p;
  const ParamDict m = dict.table("water");
  p.rho10 = m.get("rho10", p.rho10);
  p.rho20 = m.get("rho20", p.rho20);
  p.rest_fraction = m.get("rest_fraction", p.rest_fraction);
  p.xi_vapour = m.get("xi_vapour", p.xi_vapour);
  p.xi_temperature = m.get("xi_temperature", p.xi_temperature);
  p.g12 = m.get("g12", p.g12);
  p.g22 = m.get("g22", p.g22);
  p.buoyancy = m.get("buoyancy", p.buoyancy);
  p.buoyancy_reference = m.get("buoyancy_reference", p.buoyancy_reference);
  p.temperature_bottom = m.get("temperature_bottom", p.temperature_bottom);
  p.temperature_top = m.get("temperature_top", p.temperature_top);
  p.silos = m.get("silos", p.silos);
  p.silo_radius_min = m.get("silo_radius_min", p.silo_radius_min);
  p.silo_radius_max = m.get("silo_radius_max", p.silo_radius_max);
  p.silo_height_min = m.get("silo_height_min", p.silo_height_min);
  p.silo_height_max = m.get("silo_height_max", p.silo_height_max);
  p.vapour_background = m.get("vapour_background", p.vapour_background);
  if (!(p.xi_vapour > 0.5) || !(p.xi_temperature > 0.5))
    throw ConfigError("relaxation times must exceed 1/2", {.file = dict.source(), .key = "water.xi_*"});
  if (p.rest_fraction < 0 || p.rest_fraction > 1)
    throw ConfigError("must be in [0, 1]", {.file = dict.source(), .key = "water.rest_fraction"});
  return p;
}

std::vector<Silo> make_silos(const Grid3& g, const WaterModelParams& p, std::uint64_t seed) {
  std::vector<Silo> s;
  const double size = std::min(g.nx, g.ny);
  for (int k = 0; k < p.silos; ++k) {
    const auto u = [&](std::uint64_t c) { return uniform01(seed, 0x5110, static_cast<std::uint64_t>(k), c); };
    s.push_back({u(0) * g.nx, u(1) * g.ny, (p.silo_radius_min + u(2) * (p.silo_radius_max - p.silo_radius_min)) * size,
                 (p.silo_height_min + u(3) * (p.silo_height_max - p.silo_height_min)) * g.nz});
  }
  return s;
}

namespace {
// Reference densities of the shifted populations: vapour rho10, temperature 0.5.
double reference(const WaterModelParams& p, int c) { return c == 0 ? p.rho10 : 0.5; }
}  // namespace

WaterModel::WaterModel(Grid3 global, WaterModelParams params, int y_begin, int y_end)
    : WaterModel(Grid3{global.nx, y_end - y_begin + 2, global.nz}, params) {
  if (y_begin < 0 || y_end > global.ny || y_end - y_begin < 2)
    throw ValueError("a slab needs at least 2 rows inside the lattice", {.key = "mpi"});
  global_ = global;
  y_begin_ = y_begin;
  halo_ = 1;
}

WaterModel::WaterModel(Grid3 grid, WaterModelParams params) : g_(grid), global_(grid), p_(params) {
  const std::size_t n = g_.cells();
  for (int c = 0; c < 2; ++c) {
    f_[c].assign(d3q19::q * n, 0.0f);
    rho_[c].assign(n, 0.0f);
  }
  psi1_.assign(n, 0.0f);
}

void WaterModel::initialise(const std::vector<Silo>& silos, std::uint64_t seed) {
  const std::size_t n = g_.cells();
  const float d = static_cast<float>(p_.rest_fraction);
#pragma omp parallel for schedule(static)
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < g_.ny; ++y)
      for (int x = 0; x < g_.nx; ++x) {
        const std::size_t cell = g_.index(x, y, z);
        const int gy = global_y(y);
        const std::uint64_t gcell = global_.index(x, gy, z);  // hashes use global indices
        double vapour = p_.vapour_background * p_.rho10;
        for (const Silo& s : silos) {
          // Minimum-image horizontal distance on the torus.
          double dx = std::abs(x + 0.5 - s.x), dy = std::abs(gy + 0.5 - s.y);
          dx = std::min(dx, g_.nx - dx);
          dy = std::min(dy, global_.ny - dy);
          const double zc = z + 0.5;
          const double dist =
              zc <= s.height ? std::hypot(dx, dy) : std::sqrt(dx * dx + dy * dy + (zc - s.height) * (zc - s.height));
          double v;
          if (dist <= s.radius) {
            v = p_.rho10 * (0.99 + 0.02 * uniform01(seed, 0x7a90, gcell));
          } else {
            const double t = std::min(1.0, (dist - s.radius) / s.radius);
            v = p_.rho10 + t * (p_.vapour_background * p_.rho10 - p_.rho10);
          }
          vapour = std::max(vapour, v);
        }
        const double temp = p_.temperature_bottom + (p_.temperature_top - p_.temperature_bottom) *
                                                        (g_.nz > 1 ? static_cast<double>(z) / (g_.nz - 1) : 0.0);
        float feq[d3q19::q];
        d3q19::equilibrium_shifted<float>(static_cast<float>(vapour - reference(p_, 0)), static_cast<float>(vapour), 0,
                                          0, 0, d, feq);
        for (int i = 0; i < d3q19::q; ++i) f_[0][static_cast<std::size_t>(i) * n + cell] = feq[i];
        d3q19::equilibrium_shifted<float>(static_cast<float>(temp - reference(p_, 1)), static_cast<float>(temp), 0, 0,
                                          0, d, feq);
        for (int i = 0; i < d3q19::q; ++i) f_[1][static_cast<std::size_t>(i) * n + cell] = feq[i];
      }
  step_ = 0;
}

void WaterModel::initialise_uniform(double vapour, double temperature, double perturbation, std::uint64_t seed) {
  const std::size_t n = g_.cells();
  const float d = static_cast<float>(p_.rest_fraction);
  for (std::size_t cell = 0; cell < n; ++cell) {
    const double v = vapour + perturbation * (2 * uniform01(seed, 0x9e7, cell) - 1);
    float feq[d3q19::q];
    d3q19::equilibrium_shifted<float>(static_cast<float>(v - reference(p_, 0)), static_cast<float>(v), 0, 0, 0, d, feq);
    for (int i = 0; i < d3q19::q; ++i) f_[0][static_cast<std::size_t>(i) * n + cell] = feq[i];
    d3q19::equilibrium_shifted<float>(static_cast<float>(temperature - reference(p_, 1)),
                                      static_cast<float>(temperature), 0, 0, 0, d, feq);
    for (int i = 0; i < d3q19::q; ++i) f_[1][static_cast<std::size_t>(i) * n + cell] = feq[i];
  }
  step_ = 0;
}

void WaterModel::step() {
  if (exchange_ || halo_ != 0 || p_.periodic_z) {  // slabs exchange halos between the passes; see fused_step()
    if (exchange_) exchange_(*this, Exchange::populations);
    step_stage(Stage::stream);
    if (exchange_) exchange_(*this, Exchange::densities);
    step_stage(Stage::collide);
    return;
  }
  fused_step();
}

void WaterModel::stream_row(int y, int z, float* const tmp[2], std::size_t stride, std::size_t tbase) {
  // Pass 1 of row (y, z): stream both components into tmp (population i of cell x at
  // tmp[c][i * stride + tbase + x]); densities and Psi_1.
  const int nx = g_.nx;
  const ZBoundary zb = p_.periodic_z ? ZBoundary::periodic : ZBoundary::walls;
  const float rho10 = static_cast<float>(p_.rho10);
  const std::size_t base = g_.index(0, y, z);
  for (int c = 0; c < 2; ++c) {
    gather_row(row_sources(g_, f_[c].data(), y, z, zb), tmp[c] + tbase, stride);
    float* rho = rho_[c].data() + base;
    const float ref = static_cast<float>(reference(p_, c));
#pragma omp simd
    for (int x = 0; x < nx; ++x) rho[x] = 0;
    for (int i = 0; i < d3q19::q; ++i) {
      const float* t = tmp[c] + static_cast<std::size_t>(i) * stride + tbase;
#pragma omp simd
      for (int x = 0; x < nx; ++x) rho[x] += t[x];
    }
#pragma omp simd
    for (int x = 0; x < nx; ++x) rho[x] += ref;
  }
  float* psi = psi1_.data() + base;
  const float* r1 = rho_[0].data() + base;
#pragma omp simd
  for (int x = 0; x < nx; ++x) psi[x] = rho10 * (1.0f - std::exp(-r1[x] / rho10));
}

struct WaterModel::RowScratch {
  explicit RowScratch(int nx)
      : buf(static_cast<std::size_t>(21) * static_cast<std::size_t>(nx)),
        nb1(static_cast<std::size_t>(nx)),
        nb2(static_cast<std::size_t>(nx)) {}
  std::vector<float> buf, nb1, nb2;
};

void WaterModel::collide_row(int y, int z, const float* const tmp[2], std::size_t stride, std::size_t tbase,
                             RowScratch& scratch) {
  // Pass 2 of row (y, z), with unit-stride loops over x: gradients, forces, equilibrium
  // velocities, collision, all in FP32 (the populations are shifted by their rest values, so
  // FP32 rounds the deviations, not the densities), 16 cells per AVX-512 instruction.
  const std::size_t n = g_.cells();
  const int nx = g_.nx;
  const auto nxs = static_cast<std::size_t>(nx);
  const float xi[2] = {static_cast<float>(p_.xi_vapour), static_cast<float>(p_.xi_temperature)};
  const float d = static_cast<float>(p_.rest_fraction);
  const float g11_scale = static_cast<float>(-((1 - p_.rest_fraction) / p_.rho10));  // eq. (31) with v = 1
  const float rho20 = static_cast<float>(p_.rho20), g12 = static_cast<float>(p_.g12), g22 = static_cast<float>(p_.g22),
              buoyancy = static_cast<float>(p_.buoyancy),
              buoyancy_reference = static_cast<float>(p_.buoyancy_reference);
  auto B = [&](int k) { return scratch.buf.data() + static_cast<std::size_t>(k) * nxs; };
  float *g1x = B(0), *g1y = B(1), *g1z = B(2), *g2x = B(3), *g2y = B(4), *g2z = B(5);
  float *ux = B(6), *uy = B(7), *uz = B(8), *drho = B(9);
  float *j1x = B(10), *j1y = B(11), *j1z = B(12), *j2x = B(13), *j2y = B(14), *j2z = B(15);
  float *f1x = B(16), *f1y = B(17), *f1z = B(18), *tmpd = B(19), *feq_sum = B(20);
  std::vector<float>& nb1 = scratch.nb1;
  std::vector<float>& nb2 = scratch.nb2;
  const std::size_t base = g_.index(0, y, z);
  // Isotropic gradients of Psi_1 and Psi_2 = rho_2 (walls: the row beyond is the row itself).
  for (int k = 0; k < 6; ++k)
    for (int x = 0; x < nx; ++x) B(k)[x] = 0;
  for (int i = 1; i < d3q19::q; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    const int sy = (y + d3q19::cy[iu] + g_.ny) % g_.ny;
    int sz = z + d3q19::cz[iu];
    sz = p_.periodic_z ? (sz + g_.nz) % g_.nz : std::clamp(sz, 0, g_.nz - 1);
    const float* p1 = psi1_.data() + g_.index(0, sy, sz);
    const float* p2 = rho_[1].data() + g_.index(0, sy, sz);
    const int cx = d3q19::cx[iu];
    // Neighbour values at x + cx (periodic in x): shifted copies, not per-element gathers.
    auto shifted = [&](const float* src, std::vector<float>& dst) {
      float* o = dst.data();
      if (cx == 0) {
        std::copy_n(src, nx, o);
      } else if (cx == 1) {
        std::copy_n(src + 1, nx - 1, o);
        o[nx - 1] = src[0];
      } else {
        o[0] = src[nx - 1];
        std::copy_n(src, nx - 1, o + 1);
      }
    };
    shifted(p1, nb1);
    shifted(p2, nb2);
    const float w = static_cast<float>(d3q19::gradient_weight(i));
    const float wx = w * static_cast<float>(cx), wy = w * static_cast<float>(d3q19::cy[iu]),
                wz = w * static_cast<float>(d3q19::cz[iu]);
#pragma omp simd
    for (int x = 0; x < nx; ++x) {
      const float a = nb1[static_cast<std::size_t>(x)], b = nb2[static_cast<std::size_t>(x)];
      g1x[x] += wx * a;
      g1y[x] += wy * a;
      g1z[x] += wz * a;
      g2x[x] += wx * b;
      g2y[x] += wy * b;
      g2z[x] += wz * b;
    }
  }
  // Momenta of both components.
  for (int k = 10; k < 16; ++k)
    for (int x = 0; x < nx; ++x) B(k)[x] = 0;
  for (int c = 0; c < 2; ++c) {
    float* jx = c == 0 ? j1x : j2x;
    float* jy = c == 0 ? j1y : j2y;
    float* jz = c == 0 ? j1z : j2z;
    for (int i = 1; i < d3q19::q; ++i) {
      const auto iu = static_cast<std::size_t>(i);
      const float* t = tmp[c] + iu * stride + tbase;
      const float cx = static_cast<float>(d3q19::cx[iu]), cy = static_cast<float>(d3q19::cy[iu]),
                  cz = static_cast<float>(d3q19::cz[iu]);
#pragma omp simd
      for (int x = 0; x < nx; ++x) {
        jx[x] += cx * t[x];
        jy[x] += cy * t[x];
        jz[x] += cz * t[x];
      }
    }
  }
  const float* r1 = rho_[0].data() + base;
  const float* r2 = rho_[1].data() + base;
  const float* ps = psi1_.data() + base;
// Forces (eq. 25) into f1*, the temperature force into g2* (no longer needed), and the
// common equilibrium velocity (eq. 9).
#pragma omp simd
  for (int x = 0; x < nx; ++x) {
    const float psi1 = ps[x], rr1 = r1[x], rr2 = r2[x];
    const float g11 = g11_scale * (1 + rho20 - rr2);
    const float h1x = g1x[x], h1y = g1y[x], h1z = g1z[x];
    // Self-interaction with the factor 2 that makes the pressure G11 Psi_1^2 of eq. (29),
    // whose window dp/drho_1 < 0 (eq. 30) eq. (31) normalises; see docs/lbm.md.
    f1x[x] = -psi1 * (2 * g11 * h1x + g12 * g2x[x]);
    f1y[x] = -psi1 * (2 * g11 * h1y + g12 * g2y[x]);
    f1z[x] = -psi1 * (2 * g11 * h1z + g12 * g2z[x]) + rr1 * buoyancy * (rr2 - buoyancy_reference);
    const float f2x = -rr2 * (g12 * h1x + g22 * g2x[x]);
    const float f2y = -rr2 * (g12 * h1y + g22 * g2y[x]);
    const float f2z = -rr2 * (g12 * h1z + g22 * g2z[x]);
    g2x[x] = f2x;
    g2y[x] = f2y;
    g2z[x] = f2z;
    const float denom = rr1 / xi[0] + rr2 / xi[1];
    ux[x] = (j1x[x] / xi[0] + j2x[x] / xi[1]) / denom;
    uy[x] = (j1y[x] / xi[0] + j2y[x] / xi[1]) / denom;
    uz[x] = (j1z[x] / xi[0] + j2z[x] / xi[1]) / denom;
  }
  for (int c = 0; c < 2; ++c) {
    const float* rho = c == 0 ? r1 : r2;
    const float* fx = c == 0 ? f1x : g2x;
    const float* fy = c == 0 ? f1y : g2y;
    const float* fz = c == 0 ? f1z : g2z;
    const float omega = 1.0f / xi[c];
    // Per-cell equilibrium velocity of this component (eq. 10) into j* (reused), and
    // rho - rho_ref from the shifted populations (no cancellation against rho_ref).
    float* vx = c == 0 ? j1x : j2x;
    float* vy = c == 0 ? j1y : j2y;
    float* vz = c == 0 ? j1z : j2z;
#pragma omp simd
    for (int x = 0; x < nx; ++x) {
      const float s = xi[c] / rho[x];
      vx[x] = ux[x] + s * fx[x];
      vy[x] = uy[x] + s * fy[x];
      vz[x] = uz[x] + s * fz[x];
      drho[x] = 0;
    }
    for (int i = 0; i < d3q19::q; ++i) {
      const float* t = tmp[c] + static_cast<std::size_t>(i) * stride + tbase;
#pragma omp simd
      for (int x = 0; x < nx; ++x) drho[x] += t[x];
    }
// The moving directions first; the rest population's equilibrium is what makes the
// equilibria sum to drho. Computing it from its own weight instead would conserve
// mass only up to the FP32 rounding of the weights (sum w_i = 1 + O(1e-7)), a
// systematic drift of ~4e-6 per 100 steps.
#pragma omp simd
    for (int x = 0; x < nx; ++x) feq_sum[x] = 0;
    for (int i = 1; i <= d3q19::q; ++i) {
      const int k = i % d3q19::q;  // 1, 2, ..., 18, then 0
      const auto iu = static_cast<std::size_t>(k);
      const float* t = tmp[c] + iu * stride + tbase;
      float* o = f_[c].data() + iu * n + base;
      if (k == 0) {
#pragma omp simd
        for (int x = 0; x < nx; ++x) tmpd[x] = t[x] - omega * (t[x] - (drho[x] - feq_sum[x]));
      } else {
        const float cx = static_cast<float>(d3q19::cx[iu]), cy = static_cast<float>(d3q19::cy[iu]),
                    cz = static_cast<float>(d3q19::cz[iu]);
        const auto e = d3q19::equilibrium_coefficients<float>(k, d);
#pragma omp simd
        for (int x = 0; x < nx; ++x) {
          const float cu = cx * vx[x] + cy * vy[x] + cz * vz[x];
          const float u2 = vx[x] * vx[x] + vy[x] * vy[x] + vz[x] * vz[x];
          const float feq = e.w * drho[x] + rho[x] * (e.k1 * cu + e.k2 * cu * cu - e.k3 * u2);
          feq_sum[x] += feq;
          tmpd[x] = t[x] - omega * (t[x] - feq);
        }
      }
      store_streaming(o, tmpd, nxs);
    }
  }
}

void WaterModel::step_stage(Stage stage) {
  const std::size_t n = g_.cells();
  if (tmp_[0].size() != d3q19::q * n)  // allocated on first use: fused_step() needs no lattice-sized copy
    for (auto& t : tmp_) t.assign(d3q19::q * n, 0.0f);
  float* const tmp[2] = {tmp_[0].data(), tmp_[1].data()};
  if (stage == Stage::stream) {
#pragma omp parallel for collapse(2) schedule(static)
    for (int z = 0; z < g_.nz; ++z)
      for (int y = 0; y < g_.ny; ++y) stream_row(y, z, tmp, n, g_.index(0, y, z));
    return;
  }
  const int y0 = owned_begin(), y1 = owned_end();
#pragma omp parallel
  {
    RowScratch scratch(g_.nx);
#pragma omp for collapse(2) schedule(static)
    for (int z = 0; z < g_.nz; ++z)
      for (int y = y0; y < y1; ++y) collide_row(y, z, tmp, n, g_.index(0, y, z), scratch);
    stream_fence();
  }
  finish_step();
}

void WaterModel::fused_step() {
  // The two passes as a wavefront over z: stage s streams plane s (pass 1) and then collides
  // plane s - 1 (pass 2), which needs Psi of planes s - 2 .. s, all done. Pass 1 of plane s
  // reads the populations of planes s - 1 .. s + 1 before pass 2 of plane s - 1 overwrites
  // them (a barrier between the two), so every row sees exactly the inputs of the two-pass
  // order and the result is bit-identical. The streamed populations live in a ring of two
  // planes (2.5 MiB at 128^2 per plane) that stays in cache instead of a lattice-sized array
  // that goes to memory and back: a step moves about half the bytes. Walls in z only (a
  // periodic z would need plane 0's old populations after it is overwritten).
  const std::size_t plane = static_cast<std::size_t>(g_.nx) * static_cast<std::size_t>(g_.ny);
  const std::size_t stride = 2 * plane;  // ring: population i of slot k at i * stride + k * plane
  if (ring_[0].size() != d3q19::q * stride)
    for (auto& r : ring_) r.assign(d3q19::q * stride, 0.0f);
  float* const ring[2] = {ring_[0].data(), ring_[1].data()};
  const int nz = g_.nz, ny = g_.ny, nx = g_.nx;
#pragma omp parallel
  {
    RowScratch scratch(nx);
    for (int s = 0; s <= nz; ++s) {
      if (s < nz) {
#pragma omp for schedule(static)
        for (int y = 0; y < ny; ++y)
          stream_row(y, s, ring, stride, static_cast<std::size_t>(s % 2) * plane + static_cast<std::size_t>(y) * nx);
      }
      if (s >= 1) {
#pragma omp for schedule(static)
        for (int y = 0; y < ny; ++y)
          collide_row(y, s - 1, ring, stride,
                      static_cast<std::size_t>((s - 1) % 2) * plane + static_cast<std::size_t>(y) * nx, scratch);
      }
    }
    stream_fence();
  }
  finish_step();
}

void WaterModel::finish_step() {
  const std::size_t n = g_.cells();
  const double d = p_.rest_fraction;
  // Fixed-temperature, zero-velocity bottom and top layers.
  if (!p_.periodic_z) {
    for (int z : {0, g_.nz - 1}) {
      const float temp = static_cast<float>(z == 0 ? p_.temperature_bottom : p_.temperature_top);
      const float df = static_cast<float>(d);
#pragma omp parallel for schedule(static)
      for (int y = 0; y < g_.ny; ++y)
        for (int x = 0; x < g_.nx; ++x) {
          const std::size_t cell = g_.index(x, y, z);
          float feq[d3q19::q];
          d3q19::equilibrium_shifted<float>(rho_[0][cell] - static_cast<float>(reference(p_, 0)), rho_[0][cell], 0, 0,
                                            0, df, feq);
          for (int i = 0; i < d3q19::q; ++i) f_[0][static_cast<std::size_t>(i) * n + cell] = feq[i];
          d3q19::equilibrium_shifted<float>(temp - static_cast<float>(reference(p_, 1)), temp, 0, 0, 0, df, feq);
          for (int i = 0; i < d3q19::q; ++i) f_[1][static_cast<std::size_t>(i) * n + cell] = feq[i];
        }
    }
  }
  ++step_;
}

std::vector<float> WaterModel::density(int c) const {
  const std::size_t n = g_.cells();
  const int own = owned_end() - owned_begin();
  std::vector<float> out(static_cast<std::size_t>(g_.nx) * static_cast<std::size_t>(own) *
                         static_cast<std::size_t>(g_.nz));
  const float ref = static_cast<float>(reference(p_, c));
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < own; ++y)
      for (int x = 0; x < g_.nx; ++x) {
        const std::size_t cell = g_.index(x, y + owned_begin(), z);
        float s = ref;
        for (int i = 0; i < d3q19::q; ++i) s += f_[c][static_cast<std::size_t>(i) * n + cell];
        out[(static_cast<std::size_t>(z) * own + static_cast<std::size_t>(y)) * g_.nx + x] = s;
      }
  return out;
}

double WaterModel::total(int c) const {
  double s = 0;
  for (float v : density(c)) s += v;
  return s;
}

std::vector<float> WaterModel::pack_row(Exchange kind, int y) const {
  std::vector<float> out;
  const std::size_t n = g_.cells();
  if (kind == Exchange::populations) {
    for (int c = 0; c < 2; ++c)
      for (int i = 0; i < d3q19::q; ++i)
        for (int z = 0; z < g_.nz; ++z) {
          const float* r = f_[c].data() + static_cast<std::size_t>(i) * n + g_.index(0, y, z);
          out.insert(out.end(), r, r + g_.nx);
        }
  } else {
    for (const std::vector<float>* f : {&rho_[0], &rho_[1], &psi1_})
      for (int z = 0; z < g_.nz; ++z) {
        const float* r = f->data() + g_.index(0, y, z);
        out.insert(out.end(), r, r + g_.nx);
      }
  }
  return out;
}

void WaterModel::unpack_row(Exchange kind, int y, const std::vector<float>& data) {
  const std::size_t n = g_.cells();
  std::size_t k = 0;
  if (kind == Exchange::populations) {
    for (int c = 0; c < 2; ++c)
      for (int i = 0; i < d3q19::q; ++i)
        for (int z = 0; z < g_.nz; ++z, k += static_cast<std::size_t>(g_.nx))
          std::copy_n(data.data() + k, g_.nx, f_[c].data() + static_cast<std::size_t>(i) * n + g_.index(0, y, z));
  } else {
    for (std::vector<float>* f : {&rho_[0], &rho_[1], &psi1_})
      for (int z = 0; z < g_.nz; ++z, k += static_cast<std::size_t>(g_.nx))
        std::copy_n(data.data() + k, g_.nx, f->data() + g_.index(0, y, z));
  }
}

bool WaterModel::check(std::string& what, std::size_t& cell) const {
  const auto v = vapour(), t = temperature();
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!(v[k] >= 0 && v[k] <= 100 * p_.rho10)) {
      what = fmt::format("vapour density {}", v[k]);
      cell = k;
      return false;
    }
    if (!(t[k] >= 0 && t[k] <= 10)) {
      what = fmt::format("temperature {}", t[k]);
      cell = k;
      return false;
    }
  }
  return true;
}

namespace {
// CK2: parameters stored field by field (CK1 wrote the struct's bytes, padding included, so
// equal states could give different files).
constexpr char magic[16] = "NEPHOS-LBM-CK2";
constexpr int param_count = 18;

std::array<double, param_count> params_to_array(const WaterModelParams& p) {
  return {p.rho10,
          p.rho20,
          p.rest_fraction,
          p.xi_vapour,
          p.xi_temperature,
          p.g12,
          p.g22,
          p.buoyancy,
          p.buoyancy_reference,
          p.temperature_bottom,
          p.temperature_top,
          static_cast<double>(p.silos),
          p.silo_radius_min,
          p.silo_radius_max,
          p.silo_height_min,
          p.silo_height_max,
          p.vapour_background,
          p.periodic_z ? 1.0 : 0.0};
}

WaterModelParams params_from_array(const std::array<double, param_count>& a) {
  WaterModelParams p;
  p.rho10 = a[0], p.rho20 = a[1], p.rest_fraction = a[2], p.xi_vapour = a[3], p.xi_temperature = a[4];
  p.g12 = a[5], p.g22 = a[6], p.buoyancy = a[7], p.buoyancy_reference = a[8];
  p.temperature_bottom = a[9], p.temperature_top = a[10], p.silos = static_cast<int>(a[11]);
  p.silo_radius_min = a[12], p.silo_radius_max = a[13], p.silo_height_min = a[14], p.silo_height_max = a[15];
  p.vapour_background = a[16], p.periodic_z = a[17] != 0;
  return p;
}

// The checkpoint file: magic, (nx, ny, nz, step), the parameters, then both components'
// populations of the whole lattice, direction-major (f[i * cells + cell]).
struct CheckpointHeader {
  Grid3 grid;
  long step;
  WaterModelParams params;
};

void write_checkpoint(const std::filesystem::path& path, const CheckpointHeader& h, const float* f0, const float* f1) {
  AtomicFile out(path);
  {
    std::ofstream os(out.temp_path(), std::ios::binary);
    if (!os) throw IoError("cannot open checkpoint for writing", {.file = path.string()});
    os.write(magic, sizeof magic);
    const std::int64_t hdr[4] = {h.grid.nx, h.grid.ny, h.grid.nz, h.step};
    os.write(reinterpret_cast<const char*>(hdr), sizeof hdr);
    const auto params = params_to_array(h.params);
    os.write(reinterpret_cast<const char*>(params.data()), sizeof params);
    const auto bytes = static_cast<std::streamsize>(d3q19::q * h.grid.cells() * sizeof(float));
    os.write(reinterpret_cast<const char*>(f0), bytes);
    os.write(reinterpret_cast<const char*>(f1), bytes);
    if (!os.flush()) throw IoError("checkpoint write failed (disk full?)", {.file = path.string()});
  }
  out.commit();
}

// Reads the header and leaves `is` at the populations.
CheckpointHeader read_checkpoint_header(std::ifstream& is, const std::filesystem::path& path) {
  if (!is) throw IoError("cannot open checkpoint", {.file = path.string()});
  char m[16] = {};
  is.read(m, sizeof m);
  if (std::memcmp(m, "NEPHOS-LBM-CK1", 15) == 0)
    throw FormatError("checkpoint from an older nephos (format CK1): rerun the simulation", {.file = path.string()});
  if (std::memcmp(m, magic, sizeof magic) != 0)
    throw FormatError("not a nephos lbm checkpoint", {.file = path.string()});
  std::int64_t hdr[4];
  is.read(reinterpret_cast<char*>(hdr), sizeof hdr);
  std::array<double, param_count> params{};
  is.read(reinterpret_cast<char*>(params.data()), sizeof params);
  const WaterModelParams p = params_from_array(params);
  if (!is || hdr[0] < 4 || hdr[1] < 4 || hdr[2] < 4 || hdr[0] > 4096 || hdr[1] > 4096 || hdr[2] > 4096 || hdr[3] < 0)
    throw FormatError("corrupt checkpoint header", {.file = path.string()});
  return {Grid3{static_cast<int>(hdr[0]), static_cast<int>(hdr[1]), static_cast<int>(hdr[2])}, hdr[3], p};
}

}  // namespace

void WaterModel::save(const std::filesystem::path& path) const {
  if (halo_ != 0)
    throw ValueError("a slab cannot save itself: gather pack_owned() of every slab and call save_gathered()");
  write_checkpoint(path, {g_, step_, p_}, f_[0].data(), f_[1].data());
}

WaterModel WaterModel::load(const std::filesystem::path& path) {
  std::ifstream is(path, std::ios::binary);
  const CheckpointHeader h = read_checkpoint_header(is, path);
  WaterModel w(h.grid, h.params);
  w.step_ = h.step;
  for (int c = 0; c < 2; ++c)
    is.read(reinterpret_cast<char*>(w.f_[c].data()), static_cast<std::streamsize>(w.f_[c].size() * sizeof(float)));
  if (!is) throw FormatError("truncated checkpoint", {.file = path.string()});
  return w;
}

Grid3 WaterModel::checkpoint_grid(const std::filesystem::path& path) {
  std::ifstream is(path, std::ios::binary);
  return read_checkpoint_header(is, path).grid;
}

WaterModel WaterModel::load_slab(const std::filesystem::path& path, int y_begin, int y_end) {
  std::ifstream is(path, std::ios::binary);
  const CheckpointHeader h = read_checkpoint_header(is, path);
  WaterModel w(h.grid, h.params, y_begin, y_end);
  w.step_ = h.step;
  // Read one direction of one component at a time (a whole-lattice plane of populations) and
  // keep the slab's rows: memory stays at one plane beyond the slab.
  const std::size_t N = h.grid.cells(), n = w.g_.cells();
  std::vector<float> plane(N);
  for (int c = 0; c < 2; ++c)
    for (int i = 0; i < d3q19::q; ++i) {
      is.read(reinterpret_cast<char*>(plane.data()), static_cast<std::streamsize>(N * sizeof(float)));
      if (!is) throw FormatError("truncated checkpoint", {.file = path.string()});
      for (int z = 0; z < h.grid.nz; ++z)
        for (int y = w.owned_begin(); y < w.owned_end(); ++y)
          std::copy_n(plane.data() + h.grid.index(0, w.global_y(y), z), h.grid.nx,
                      w.f_[c].data() + static_cast<std::size_t>(i) * n + w.g_.index(0, y, z));
    }
  return w;
}

std::vector<float> WaterModel::pack_owned() const {
  std::vector<float> out;
  for (int y = owned_begin(); y < owned_end(); ++y) {
    const std::vector<float> r = pack_row(Exchange::populations, y);
    out.insert(out.end(), r.begin(), r.end());
  }
  return out;
}

void WaterModel::save_gathered(const std::filesystem::path& path, const Grid3& global, const WaterModelParams& params,
                               long step, const std::vector<float>& rows) {
  // rows: pack_row(populations) of every global row in y order: per row, c, i, z, then x.
  const std::size_t N = global.cells(), row = 2 * d3q19::q * static_cast<std::size_t>(global.nz) * global.nx;
  if (rows.size() != row * static_cast<std::size_t>(global.ny))
    throw ValueError(fmt::format("gathered checkpoint has {} values, expected {}", rows.size(), row * global.ny));
  std::vector<float> f[2] = {std::vector<float>(d3q19::q * N), std::vector<float>(d3q19::q * N)};
  for (int y = 0; y < global.ny; ++y) {
    const float* r = rows.data() + static_cast<std::size_t>(y) * row;
    for (int c = 0; c < 2; ++c)
      for (int i = 0; i < d3q19::q; ++i)
        for (int z = 0; z < global.nz; ++z, r += global.nx)
          std::copy_n(r, global.nx, f[c].data() + static_cast<std::size_t>(i) * N + global.index(0, y, z));
  }
  write_checkpoint(path, {global, step, params}, f[0].data(), f[1].data());
}

}  // namespace nephos::lbm
