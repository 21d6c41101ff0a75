#include "nephos/lbm/water_model.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/lbm/vector_math.hpp"

namespace nephos::lbm {

WaterModelParams WaterModelParams::from(const ParamDict& dict) {
  WaterModelParams p;
  const ParamDict m = dict.table("water");
  p.rho10 = m.get_in("rho10", p.rho10, 1e-6, 1e6);
  p.rho20 = m.get_in("rho20", p.rho20, -1e6, 1e6);
  p.rest_fraction = m.get_in("rest_fraction", p.rest_fraction, 0.0, 1.0);
  p.xi_vapour = m.get_in("xi_vapour", p.xi_vapour, 0.5, 1e3);
  p.xi_temperature = m.get_in("xi_temperature", p.xi_temperature, 0.5, 1e3);
  p.g12 = m.get("g12", p.g12);
  p.g22 = m.get("g22", p.g22);
  p.buoyancy = m.get("buoyancy", p.buoyancy);
  p.buoyancy_reference = m.get("buoyancy_reference", p.buoyancy_reference);
  p.temperature_bottom = m.get("temperature_bottom", p.temperature_bottom);
  p.temperature_top = m.get("temperature_top", p.temperature_top);
  p.silos = m.get_in("silos", p.silos, 0, max_silos);
  p.silo_radius_min = m.get_in("silo_radius_min", p.silo_radius_min, 0.0, 1.0);
  p.silo_radius_max = m.get_in("silo_radius_max", p.silo_radius_max, 0.0, 1.0);
  p.silo_height_min = m.get_in("silo_height_min", p.silo_height_min, 0.0, 1.0);
  p.silo_height_max = m.get_in("silo_height_max", p.silo_height_max, 0.0, 1.0);
  p.vapour_background = m.get_in("vapour_background", p.vapour_background, 0.0, 2.0);
  p.storage = parse_storage(m.get("storage", std::string(to_string(p.storage))));
  if (!(p.xi_vapour > 0.5) || !(p.xi_temperature > 0.5))
    throw ConfigError("relaxation times must exceed 1/2", {.file = dict.source(), .key = "water.xi_*"});
  if (p.silo_radius_min > p.silo_radius_max || p.silo_height_min > p.silo_height_max)
    throw ConfigError("each *_min must not exceed its *_max", {.file = dict.source(), .key = "water.silo_*"});
  return p;
}

void WaterModelParams::set_silos(int n, const std::string& key) {
  if (n < 0 || n > max_silos) throw ValueError(fmt::format("must be 0..{}, got {}", max_silos, n), {.key = key});
  silos = n;
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
    f_[c] = Populations(p_.storage, d3q19::q, g_.direction_stride());
    next_[c] = Populations(p_.storage, d3q19::q, g_.direction_stride());
    rho_[c].assign(n, 0.0f);
  }
  psi1_.assign(n, 0.0f);
}

void WaterModel::initialise(const std::vector<Silo>& silos, std::uint64_t seed) {
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
        set_rest_equilibrium(cell, vapour, temp);
      }
  step_ = 0;
}

void WaterModel::set_rest_equilibrium(std::size_t cell, double vapour, double temperature) {
  const std::size_t stride = g_.direction_stride();
  const float d = static_cast<float>(p_.rest_fraction);
  float feq[d3q19::q];
  d3q19::equilibrium_shifted<float>(static_cast<float>(vapour - reference(p_, 0)), static_cast<float>(vapour), 0, 0, 0,
                                    d, feq);
  for (int i = 0; i < d3q19::q; ++i) f_[0].set(static_cast<std::size_t>(i) * stride + cell, feq[i]);
  d3q19::equilibrium_shifted<float>(static_cast<float>(temperature - reference(p_, 1)), static_cast<float>(temperature),
                                    0, 0, 0, d, feq);
  for (int i = 0; i < d3q19::q; ++i) f_[1].set(static_cast<std::size_t>(i) * stride + cell, feq[i]);
}

void WaterModel::initialise_fields(const std::vector<float>& vapour, const std::vector<float>& temperature) {
  const std::size_t n = global_.cells();
  for (const auto& [field, key] : {std::pair{&vapour, "vapour"}, std::pair{&temperature, "temperature"}})
    if (field->size() != n)
      throw ValueError(fmt::format("a field of {} cells, expected {} ({})", field->size(), n, global_.describe()),
                       {.key = key});
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < g_.ny; ++y)
      for (int x = 0; x < g_.nx; ++x) {
        const std::size_t from = global_.index(x, global_y(y), z);
        set_rest_equilibrium(g_.index(x, y, z), vapour[from], temperature[from]);
      }
  step_ = 0;
}

void WaterModel::initialise_uniform(double vapour, double temperature, double perturbation, std::uint64_t seed) {
  const std::size_t n = g_.cells();
  for (std::size_t cell = 0; cell < n; ++cell)
    set_rest_equilibrium(cell, vapour + perturbation * (2 * uniform01(seed, 0x9e7, cell) - 1), temperature);
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

WaterModel::DensityRows WaterModel::lattice_rows() {
  return {rho_[0].data(), rho_[1].data(), psi1_.data(), g_.nx, g_.ny, 0, g_.ny, 0};
}

namespace {
// Cells per line: what the kernels pull at a time per direction, 128 bytes of storage (two
// cache lines): 32 cells in FP32, 64 in FP16 (docs/PERFORMANCE.md, design choices).
template <class T>
constexpr int line = 128 / static_cast<int>(sizeof(T));
constexpr int max_line = line<std::uint16_t>;

// Where a row's pulled populations go in the layout pass 1 hands to pass 2: line by line
// (L cells each), within a line component by component, direction by direction, so that the
// collision reads every population of a line at a fixed offset from one pointer. After a
// component's q directions, slot q holds their sum, the density deviation drho (pass 1's sum,
// in direction order): the collision reads it instead of adding 18 values again, a chain of
// dependent additions that held up its every vector (13 % of its samples).
inline constexpr int pulled_slots = d3q19::q + 1;
template <int L>
constexpr std::size_t pulled_index(int x0, int c, int i) {
  return static_cast<std::size_t>(x0 / L) * (2 * pulled_slots * L) +
         static_cast<std::size_t>((c * pulled_slots + i) * L);
}
// Floats of one row in that layout.
template <int L>
std::size_t pulled_row_size(int nx) {
  return pulled_index<L>((nx + L - 1) / L * L, 0, 0);
}

// The `count` (<= line) pulled populations of direction i at cells x0 ... of a row as floats:
// a pointer into FP32 storage (or into `buf`, where the row wraps around x), or the FP16
// values converted into `buf`.
inline const float* pulled(const RowSourcesOf<float>& rs, int i, int x0, int count, float* buf) {
  const auto iu = static_cast<std::size_t>(i);
  return periodic_span(rs.row[iu], rs.nx, x0, -rs.shift[iu], count, buf);
}
inline const float* pulled(const RowSourcesOf<std::uint16_t>& rs, int i, int x0, int count, float* buf) {
  const auto iu = static_cast<std::size_t>(i);
  const std::uint16_t* row = rs.row[iu];
  const int first = x0 - rs.shift[iu];
#if defined(__F16C__) && defined(__AVX2__)
  if (!(first >= 0 && first + count <= rs.nx)) {
    const __m256 scale = _mm256_set1_ps(1.0f / fp16_scale);
    auto load8 = [row, scale](int k) {
      return _mm256_mul_ps(_mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row + k))), scale);
    };
    if (wrap_span_vectors(rs.nx, first, count, buf, load8)) return buf;
  }
#endif
  periodic_pieces(rs.nx, first, count,
                  [&](int src, int dst, int n) { halves_to_floats(row + src, buf + dst, n, 1.0f / fp16_scale); });
  return buf;
}

inline void store_line(float* dst, const float* src, int n) { store_streaming(dst, src, static_cast<std::size_t>(n)); }
// The sources of one line (cells x0 .. x0 + count - 1) of one component, direction by
// direction (pulled()), with a software prefetch of the same lines one row ahead (consecutive
// rows of a direction are consecutive in memory): 19 streams at a time are more than the
// hardware prefetchers follow, and without it a pass that pulls waits on memory. `buf` (q line<T> floats) holds the spans that are not FP32 in place.
// Direction 0 (rest) is FP32 in either storage, in place at rest_row (the row's first cell);
// it does not move, so its line never wraps.
template <class T>
inline void pull_line(const RowSourcesOf<T>& rs, const float* rest_row, int x0, int count, float* buf,
                      const float* src[d3q19::q]) {
  const char* rest_ahead = reinterpret_cast<const char*>(rest_row + x0 + rs.nx);
  for (std::size_t b = 0; b < line<T> * sizeof(float); b += 64) __builtin_prefetch(rest_ahead + b);
  src[0] = rest_row + x0;
  for (int i = 1; i < d3q19::q; ++i) {
    const char* ahead = reinterpret_cast<const char*>(rs.row[static_cast<std::size_t>(i)] + x0 + rs.nx);
    __builtin_prefetch(ahead);
    __builtin_prefetch(ahead + 64);  // a line is two cache lines
    src[i] = pulled(rs, i, x0, count, buf + i * line<T>);
  }
}

// A pulled line kept in the pulled_index layout: direction i's values at out[i L + l] and
// their sum, the density deviation added in direction order, at out[q L + l]. Both ways of
// stepping take the collision's deviation from here, and density_row() adds in the same order
// where it keeps nothing, so the densities and the collision agree to the bit either way.
template <int L>
inline void keep_line(const float* const src[d3q19::q], int count, float* out) {
#pragma omp simd
  for (int l = 0; l < count; ++l) {
    float sum = 0;
#pragma GCC unroll 19
    for (int i = 0; i < d3q19::q; ++i) {
      const float v = src[i][l];
      out[i * L + l] = v;
      sum += v;
    }
    out[d3q19::q * L + l] = sum;
  }
}
}  // namespace

template <class T>
void WaterModel::density_row(int y, int z, const DensityRows& rows, float* pulled_out) {
  // Pass 1 of row (y, z): the densities after streaming, rho_c = rho_ref + sum_i f_i(x - c_i),
  // and Psi_1. With pulled_out, also the pulled populations themselves, as floats in the
  // line-major layout pass 2 reads (pulled_index()): the fused step's pass 2 then reads them
  // from L2 at fixed offsets instead of pulling them again (see fused_step_impl()).
  const int nx = g_.nx;
  const ZBoundary zb = p_.periodic_z ? ZBoundary::periodic : ZBoundary::walls;
  const float rho10 = static_cast<float>(p_.rho10);
  const std::size_t base = rows.row(y, z);
  const int wy = y < 0 ? y + g_.ny : (y >= g_.ny ? y - g_.ny : y);  // y in [-1, ny]
  alignas(64) float buf[d3q19::q * line<T>];  // pulled populations where they are not FP32 in place
  for (int c = 0; c < 2; ++c) {
    const RowSourcesOf<T> rs = row_sources(g_, f_[c].data<T>(), wy, z, zb);
    const float* rest_row = f_[c].rest() + g_.index(0, wy, z);
    const float ref = static_cast<float>(reference(p_, c));
    for (int x0 = 0; x0 < nx; x0 += line<T>) {
      const int count = std::min(line<T>, nx - x0);
      const float* src[d3q19::q];
      pull_line(rs, rest_row, x0, count, buf, src);
      float* rho = (c == 0 ? rows.rho1 : rows.rho2) + base + x0;
      if (pulled_out) {
        float* out = pulled_out + pulled_index<line<T>>(x0, c, 0);
        keep_line<line<T>>(src, count, out);
        const float* sum = out + d3q19::q * line<T>;
#pragma omp simd
        for (int l = 0; l < count; ++l) rho[l] = sum[l] + ref;
      } else {
#pragma omp simd
        for (int l = 0; l < count; ++l) {
          float sum = 0;
#pragma GCC unroll 19
          for (int i = 0; i < d3q19::q; ++i) sum += src[i][l];
          rho[l] = sum + ref;
        }
      }
    }
  }
  float* psi = rows.psi1 + base;
  const float* r1 = rows.rho1 + base;
#pragma omp simd
  for (int x = 0; x < nx; ++x) psi[x] = rho10 * (1.0f - exp_nonpositive(-r1[x] / rho10));
}

struct WaterModel::RowScratch {
  alignas(64) float edge[2][d3q19::q * max_line];         // neighbours' Psi_1 and rho_2 of lines that wrap around x
  alignas(64) float pulled[2 * pulled_slots * max_line];  // one line's pulled populations (pulled_index layout)
  alignas(64) float wrapped[d3q19::q * max_line];         // pulled spans that are not FP32 in place
  alignas(64) float post[2][d3q19::q * max_line];         // one line's post-collision populations (direction-major)
};

namespace {
// What the collision of one line of cells needs, per lane l < count.
struct WaterLine {
  const float* pop;                // streamed populations: component c, direction i at pop[(c pulled_slots + i) L + l]
  const float* psi_nb[d3q19::q];   // Psi_1 at x + c_i
  const float* rho2_nb[d3q19::q];  // Psi_2 = rho_2 at x + c_i
  const float *rho1, *rho2, *psi1;
};
struct WaterConstants {
  float xi[2], omega[2], d, g11_scale, rho20, g12, g22, buoyancy, buoyancy_reference;  // omega = 1 / xi
};

// Gradients, forces (eq. 25), the common equilibrium velocity (eq. 9), each component's
// shifted velocity (eq. 10) and the LBGK collision of `count` cells, written per cell and
// vectorised across the line. All in FP32: the populations are shifted by their rest values,
// so FP32 rounds the deviations, not the densities. Opposite directions go in pairs, which
// halves the gradient's and the equilibria's arithmetic: on an AVX2 machine (8 lanes, where
// the collision rather than memory bounds a thread) a step took 9 % less time.
template <int L>  // lanes per population in `in.pop` (a line)
inline void collide_line(const WaterLine& in, int count, const WaterConstants& k, float* const post[2],
                         std::size_t stride) {
  using namespace d3q19;
  constexpr float w_axis = static_cast<float>(gradient_weight(1)), w_diag = static_cast<float>(gradient_weight(7));
  const auto ea = equilibrium_coefficients<float>(1, k.d), ed = equilibrium_coefficients<float>(7, k.d);
#pragma omp simd
  for (int l = 0; l < count; ++l) {
    // Isotropic gradients of Psi_1 and Psi_2 = rho_2.
    // Opposite directions (i, i + 1) in pairs: w_i c_i (Psi(x + c_i) - Psi(x - c_i)), the axis
    // and diagonal pairs summed apart and weighted once.
    float a1x = 0, a1y = 0, a1z = 0, a2x = 0, a2y = 0, a2z = 0;  // axis pairs
    float d1x = 0, d1y = 0, d1z = 0, d2x = 0, d2y = 0, d2z = 0;  // diagonal pairs
#pragma GCC unroll 9
    for (int i = 1; i < q; i += 2) {
      const float a = in.psi_nb[i][l] - in.psi_nb[i + 1][l], b = in.rho2_nb[i][l] - in.rho2_nb[i + 1][l];
      if (i <= 6) {
        add_c(i, a, a1x, a1y, a1z);
        add_c(i, b, a2x, a2y, a2z);
      } else {
        add_c(i, a, d1x, d1y, d1z);
        add_c(i, b, d2x, d2y, d2z);
      }
    }
    const float g1x = w_axis * a1x + w_diag * d1x, g1y = w_axis * a1y + w_diag * d1y, g1z = w_axis * a1z + w_diag * d1z;
    const float g2x = w_axis * a2x + w_diag * d2x, g2y = w_axis * a2y + w_diag * d2y, g2z = w_axis * a2z + w_diag * d2z;
    // Momenta and density deviations of both components.
    float jx[2], jy[2], jz[2], drho[2];
#pragma GCC unroll 2
    for (int c = 0; c < 2; ++c) {
      const float* pc = in.pop + c * pulled_slots * L;  // fixed offsets: no pointer per direction to load
      float sx = 0, sy = 0, sz = 0;
#pragma GCC unroll 18
      for (int i = 1; i < q; ++i) add_c(i, pc[i * L + l], sx, sy, sz);
      jx[c] = sx, jy[c] = sy, jz[c] = sz, drho[c] = pc[q * L + l];
    }
    const float psi1 = in.psi1[l], rr1 = in.rho1[l], rr2 = in.rho2[l];
    const float g11 = k.g11_scale * (1 + k.rho20 - rr2);
    // Self-interaction with the factor 2 that makes the pressure G11 Psi_1^2 of eq. (29),
    // whose window dp/drho_1 < 0 (eq. 30) eq. (31) normalises; see docs/lbm.md.
    const float fx[2] = {-psi1 * (2 * g11 * g1x + k.g12 * g2x), -rr2 * (k.g12 * g1x + k.g22 * g2x)};
    const float fy[2] = {-psi1 * (2 * g11 * g1y + k.g12 * g2y), -rr2 * (k.g12 * g1y + k.g22 * g2y)};
    const float fz[2] = {-psi1 * (2 * g11 * g1z + k.g12 * g2z) + rr1 * k.buoyancy * (rr2 - k.buoyancy_reference),
                         -rr2 * (k.g12 * g1z + k.g22 * g2z)};
    // Eq. (9) with the relaxation rates omega_c = 1 / xi_c multiplied in: three divisions per
    // cell instead of twelve (a vector division costs several multiplications).
    const float inv_denom = 1.0f / (rr1 * k.omega[0] + rr2 * k.omega[1]);
    const float ux = (jx[0] * k.omega[0] + jx[1] * k.omega[1]) * inv_denom;
    const float uy = (jy[0] * k.omega[0] + jy[1] * k.omega[1]) * inv_denom;
    const float uz = (jz[0] * k.omega[0] + jz[1] * k.omega[1]) * inv_denom;
#pragma GCC unroll 2
    for (int c = 0; c < 2; ++c) {
      const float rho = c == 0 ? rr1 : rr2;
      const float sh = k.xi[c] / rho;
      const float vx = ux + sh * fx[c], vy = uy + sh * fy[c], vz = uz + sh * fz[c];
      const float u2 = vx * vx + vy * vy + vz * vz;
      const float omega = k.omega[c];
      // The moving directions first; the rest population's equilibrium is what makes the
      // equilibria sum to drho. Computing it from its own weight instead would conserve
      // mass only up to the FP32 rounding of the weights (sum w_i = 1 + O(1e-7)), a
      // systematic drift of ~4e-6 per 100 steps.
      // A pair's equilibria share their even part: f_eq(+-) = sym +- anti, sym = w drho +
      // rho (k2 (c.u)^2 - k3 u^2), anti = rho k1 c.u.
      const float base_a = ea.w * drho[c] - rho * ea.k3 * u2, base_d = ed.w * drho[c] - rho * ed.k3 * u2;
      const float k1_a = rho * ea.k1, k2_a = rho * ea.k2, k1_d = rho * ed.k1, k2_d = rho * ed.k2;
      float feq_sum = 0;
#pragma GCC unroll 9
      for (int i = 1; i < q; i += 2) {
        const bool axis = i <= 6;
        const float cu = dot_c(i, vx, vy, vz);
        const float sym = (axis ? base_a : base_d) + (axis ? k2_a : k2_d) * cu * cu;
        const float anti = (axis ? k1_a : k1_d) * cu;
        const float feq_p = sym + anti, feq_m = sym - anti;
        feq_sum += feq_p + feq_m;
        const float fp = in.pop[(c * pulled_slots + i) * L + l], fm = in.pop[(c * pulled_slots + i + 1) * L + l];
        post[c][static_cast<std::size_t>(i) * stride + static_cast<std::size_t>(l)] = fp - omega * (fp - feq_p);
        post[c][static_cast<std::size_t>(i + 1) * stride + static_cast<std::size_t>(l)] = fm - omega * (fm - feq_m);
      }
      const float f0 = in.pop[c * pulled_slots * L + l];
      post[c][l] = f0 - omega * (f0 - (drho[c] - feq_sum));
    }
  }
}
}  // namespace

template <class T>
void WaterModel::collide_row(int y, int z, RowScratch& scratch, const DensityRows& rows, const float* pulled_row) {
  // Pass 2 of row (y, z), one line of cells at a time (collide_line): the populations pass 1
  // pulled (pulled_row), or, without them, pulled again from the current state; collide, and
  // write the next state with streaming stores.
  const std::size_t stride = g_.direction_stride();
  const int nx = g_.nx;
  const WaterConstants k{{static_cast<float>(p_.xi_vapour), static_cast<float>(p_.xi_temperature)},
                         {static_cast<float>(1 / p_.xi_vapour), static_cast<float>(1 / p_.xi_temperature)},
                         static_cast<float>(p_.rest_fraction),
                         static_cast<float>(-((1 - p_.rest_fraction) / p_.rho10)),  // eq. (31) with v = 1
                         static_cast<float>(p_.rho20),
                         static_cast<float>(p_.g12),
                         static_cast<float>(p_.g22),
                         static_cast<float>(p_.buoyancy),
                         static_cast<float>(p_.buoyancy_reference)};
  const std::size_t base = g_.index(0, y, z), dbase = rows.row(y, z);
  const ZBoundary zb = p_.periodic_z ? ZBoundary::periodic : ZBoundary::walls;
  RowSourcesOf<T> rs[2];       // the two-sweep step's sources (no pulled_row)
  const float* rest_row[2]{};  // their rest populations' row
  if (!pulled_row)
    for (int c = 0; c < 2; ++c) rs[c] = row_sources(g_, f_[c].data<T>(), y, z, zb), rest_row[c] = f_[c].rest() + base;
  // Neighbour rows of the gradients (walls: the row beyond is the row itself).
  const float* psi_row[d3q19::q];
  const float* rho2_row[d3q19::q];
  for (int i = 1; i < d3q19::q; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    int sz = z + d3q19::cz[iu];
    sz = p_.periodic_z ? (sz < 0 ? sz + g_.nz : (sz >= g_.nz ? sz - g_.nz : sz)) : std::clamp(sz, 0, g_.nz - 1);
    const std::size_t r = rows.row(y + d3q19::cy[iu], sz);
    psi_row[i] = rows.psi1 + r;
    rho2_row[i] = rows.rho2 + r;
  }
  WaterLine in{};
  for (int x0 = 0; x0 < nx; x0 += line<T>) {
    const int count = std::min(line<T>, nx - x0);
    if (pulled_row) {
      in.pop = pulled_row + pulled_index<line<T>>(x0, 0, 0);
    } else {
      // The two-sweep step: pass 1 ran a whole sweep earlier, so pull the line again, as pass
      // 1 does, with its prefetch (without it these pulls wait on memory).
      for (int c = 0; c < 2; ++c) {
        const float* src[d3q19::q];
        pull_line(rs[c], rest_row[c], x0, count, scratch.wrapped, src);
        keep_line<line<T>>(src, count, scratch.pulled + pulled_index<line<T>>(0, c, 0));
      }
      in.pop = scratch.pulled;
    }
    for (int i = 1; i < d3q19::q; ++i) {
      const int cx = d3q19::cx[static_cast<std::size_t>(i)];
      in.psi_nb[i] = periodic_span(psi_row[i], nx, x0, cx, count, scratch.edge[0] + i * line<T>);
      in.rho2_nb[i] = periodic_span(rho2_row[i], nx, x0, cx, count, scratch.edge[1] + i * line<T>);
    }
    in.rho1 = rows.rho1 + dbase + x0;
    in.rho2 = rows.rho2 + dbase + x0;
    in.psi1 = rows.psi1 + dbase + x0;
    // The whole line at once: the omp simd loop runs over it in vector-register steps.
    float* const post[2] = {scratch.post[0], scratch.post[1]};
    collide_line<line<T>>(in, count, k, post, static_cast<std::size_t>(line<T>));
    // The line's post-collision populations out at once, two whole cache lines per direction
    // (128 bytes): the streaming stores drain while the next line computes. Written a whole
    // row at a time after the row (19 streams of 512-byte rows), they would come in one burst
    // the core waits on.
    for (int c = 0; c < 2; ++c) {
      float* const post_c = scratch.post[c];
      if constexpr (std::is_same_v<T, std::uint16_t>) {
        // Conservative rounding: the rest population, kept in FP32, takes up what rounding the
        // moving ones to FP16 lost, so the cell's mass is what the collision left (to FP32
        // rounding) and the lattice's is conserved as in FP32 storage.
        for (int i = 1; i < d3q19::q; ++i)
          floats_to_halves_streaming_tracked(next_[c].data<T>() + static_cast<std::size_t>(i) * stride + base + x0,
                                             post_c + static_cast<std::size_t>(i) * line<T>, count, fp16_scale, post_c);
        store_streaming(next_[c].rest() + base + x0, post_c, static_cast<std::size_t>(count));
      } else {
        for (int i = 0; i < d3q19::q; ++i)
          store_line(next_[c].data<T>() + static_cast<std::size_t>(i) * stride + base + x0,
                     post_c + static_cast<std::size_t>(i) * line<T>, count);
      }
    }
  }
}

void WaterModel::step_stage(Stage stage) {
  if (p_.storage == Storage::fp16)
    step_stage_impl<std::uint16_t>(stage);
  else
    step_stage_impl<float>(stage);
}

void WaterModel::fused_step() {
  if (p_.storage == Storage::fp16)
    fused_step_impl<std::uint16_t>();
  else
    fused_step_impl<float>();
}

template <class T>
void WaterModel::step_stage_impl(Stage stage) {
  if (stage == Stage::stream) {
#pragma omp parallel for collapse(2) schedule(static)
    for (int z = 0; z < g_.nz; ++z)
      for (int y = 0; y < g_.ny; ++y) density_row<T>(y, z, lattice_rows(), nullptr);
    return;
  }
  const int y0 = owned_begin(), y1 = owned_end();
#pragma omp parallel
  {
    RowScratch scratch;
#pragma omp for collapse(2) schedule(static)
    for (int z = 0; z < g_.nz; ++z)
      for (int y = y0; y < y1; ++y) collide_row<T>(y, z, scratch, lattice_rows(), nullptr);
    stream_fence();
  }
  for (int c = 0; c < 2; ++c) f_[c].swap(next_[c]);
  finish_step();
}

template <class T>
void WaterModel::fused_step_impl() {
  // The two passes as a wavefront over z, in blocks of rows along y that the threads share
  // out without waiting for each other: per block and plane z, row by row, pass 1 (densities)
  // of row y + 1 of plane z + 1, then pass 2 (collision) of row y of plane z, which needs Psi
  // of planes z - 1 .. z + 1 and rows y - 1 .. y + 1 (pass 1 also covers one halo row on each
  // side of the block). The densities live in the block's own ring of three planes, so no two
  // threads write the same place; halo rows are computed by both blocks beside them, from the
  // same inputs, to the same bits. Pass 1 pulls from the current state and keeps what it pulled
  // for the block's own rows in a ring of block + 2 rows (0.66 MiB at 32 x 128 cells in FP32,
  // partly in the core's L2, the rest in L3), where pass 2 of the next plane finds it: pass 2 reads it at fixed offsets
  // instead of pulling 38 rows again through pointers and wrap-around copies. Pass 2 writes the
  // next state, so every row sees exactly the inputs of the two-pass order (bit-identical to
  // step_stage(), whatever the thread count). A step reads the state from memory once and
  // writes it once (608 B per cell for both components in FP32). Walls in z only. Blocks of
  // 32 rows: each block recomputes two halo rows of densities, 6 % of pass 1 (smaller blocks,
  // whose ring fits the L2 whole, pay more in halo rows than the L2 hits save: docs/lbm.md).
  // With more threads than 32-row blocks (128 rows on more than 4
  // cores) the blocks shrink, to no fewer than 4 rows, so that every thread has one; the
  // results do not depend on the blocking.
  const int nz = g_.nz, ny = g_.ny, nx = g_.nx;
  const int block = std::clamp(ny / std::max(thread_count(), 1), 4, 32);
  const int blocks = (ny + block - 1) / block;
  const std::size_t ring = static_cast<std::size_t>(3) * (block + 2) * static_cast<std::size_t>(nx);
  const std::size_t row_floats = pulled_row_size<line<T>>(nx);
#pragma omp parallel
  {
    RowScratch scratch;
    // Per-thread buffers kept from step to step (the threads of OpenMP's pool persist): no
    // allocation, page faults or unmapping per step.
    // 64-byte aligned (the allocator's small-size path), so that no vector access to them
    // straddles two cache lines.
    thread_local std::vector<float, HugePageAllocator<float>> dens, pulled_ring;
    dens.resize(3 * ring);
    pulled_ring.resize(static_cast<std::size_t>(block + 2) * row_floats);
#pragma omp for schedule(static)
    for (int b = 0; b < blocks; ++b) {
      const int yb = b * block, ye = std::min(ny, yb + block), rows_in_block = ye - yb;
      const DensityRows rows{dens.data(), dens.data() + ring, dens.data() + 2 * ring, nx, ny, 1 - yb, block + 2, 3};
      // Row (y, z)'s pulled populations: the rows in wavefront order, (z, y) -> z n + y - yb,
      // modulo n + 2 slots. Pass 1 writes row (y + 1, z + 1) while rows (y, z) .. (y, z + 1),
      // n + 1 places before it in that order, still wait for pass 2: n + 2 distinct slots.
      auto slot = [&](int y, int z) {
        const auto at =
            static_cast<std::size_t>(z) * static_cast<std::size_t>(rows_in_block) + static_cast<std::size_t>(y - yb);
        return pulled_ring.data() + at % static_cast<std::size_t>(rows_in_block + 2) * row_floats;
      };
      auto pass1 = [&](int y, int z) { density_row<T>(y, z, rows, y >= yb && y < ye ? slot(y, z) : nullptr); };
      for (int y = yb - 1; y <= ye; ++y) pass1(y, 0);
      for (int z = 0; z < nz; ++z) {
        const bool ahead = z + 1 < nz;
        if (ahead) pass1(yb - 1, z + 1), pass1(yb, z + 1);
        for (int y = yb; y < ye; ++y) {
          if (ahead) pass1(y + 1, z + 1);
          collide_row<T>(y, z, scratch, rows, slot(y, z));
        }
        if (z == 0 || z == nz - 1)  // finish_step() resets the boundary layers from the vapour density
          for (int y = yb; y < ye; ++y) std::copy_n(rows.rho1 + rows.row(y, z), nx, rho_[0].data() + g_.index(0, y, z));
      }
    }
    stream_fence();
  }
  for (int c = 0; c < 2; ++c) f_[c].swap(next_[c]);
  finish_step();
}

void WaterModel::finish_step() {
  // Fixed-temperature, zero-velocity bottom and top layers: both components at rest
  // equilibrium, the vapour keeping its density, the temperature at its fixed value. Row by
  // row, a direction row at a time; the temperature's equilibrium is the same in every cell of
  // a layer, computed once.
  if (!p_.periodic_z) {
    const std::size_t stride = g_.direction_stride();
    const float df = static_cast<float>(p_.rest_fraction), ref0 = static_cast<float>(reference(p_, 0));
    const int nx = g_.nx;
    for (int z : {0, g_.nz - 1}) {
      const float temp = static_cast<float>(z == 0 ? p_.temperature_bottom : p_.temperature_top);
      float feq_t[d3q19::q];
      d3q19::equilibrium_shifted<float>(temp - static_cast<float>(reference(p_, 1)), temp, 0, 0, 0, df, feq_t);
      // The temperature's direction rows, the same for every row of the layer.
      std::vector<float> temperature(static_cast<std::size_t>(d3q19::q) * static_cast<std::size_t>(nx));
      for (int i = 0; i < d3q19::q; ++i)
        std::fill_n(temperature.begin() + static_cast<std::ptrdiff_t>(i) * nx, nx, feq_t[i]);
#pragma omp parallel
      {
        std::vector<float> vapour(temperature.size());
#pragma omp for schedule(static)
        for (int y = 0; y < g_.ny; ++y) {
          const std::size_t row = g_.index(0, y, z);
          for (int x = 0; x < nx; ++x) {
            const float rho = rho_[0][row + static_cast<std::size_t>(x)];
            float feq[d3q19::q];
            d3q19::equilibrium_shifted<float>(rho - ref0, rho, 0, 0, 0, df, feq);
            for (int i = 0; i < d3q19::q; ++i)
              vapour[static_cast<std::size_t>(i) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(x)] = feq[i];
          }
          for (int i = 0; i < d3q19::q; ++i) {
            const std::size_t at = static_cast<std::size_t>(i) * stride + row;
            const std::size_t k = static_cast<std::size_t>(i) * static_cast<std::size_t>(nx);
            f_[0].write(at, static_cast<std::size_t>(nx), vapour.data() + k);
            f_[1].write(at, static_cast<std::size_t>(nx), temperature.data() + k);
          }
        }
      }
    }
  }
  ++step_;
}

std::vector<float> WaterModel::density(int c) const {
  const std::size_t stride = g_.direction_stride();
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
        for (int i = 0; i < d3q19::q; ++i) s += f_[c].get(static_cast<std::size_t>(i) * stride + cell);
        out[(static_cast<std::size_t>(z) * own + static_cast<std::size_t>(y)) * g_.nx + x] = s;
      }
  return out;
}

WaterModel::Moments WaterModel::moments(int c, int x, int y, int z) const {
  const std::size_t stride = g_.direction_stride(), cell = g_.index(x, y + owned_begin(), z);
  Moments m{reference(p_, c), {0, 0, 0}, {0, 0, 0, 0, 0, 0}};
  for (int i = 0; i < d3q19::q; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    const double f = f_[c].get(iu * stride + cell);
    const double cx = d3q19::cx[iu], cy = d3q19::cy[iu], cz = d3q19::cz[iu];
    m.density += f;
    m.momentum[0] += f * cx, m.momentum[1] += f * cy, m.momentum[2] += f * cz;
    m.second[0] += f * cx * cx, m.second[1] += f * cy * cy, m.second[2] += f * cz * cz;
    m.second[3] += f * cx * cy, m.second[4] += f * cx * cz, m.second[5] += f * cy * cz;
  }
  // The stored populations are shifted by the rest state w_i rho_ref, whose second moment is
  // rho_ref (1 - d) / 2 per axis (eq. 19).
  for (int a = 0; a < 3; ++a) m.second[static_cast<std::size_t>(a)] += reference(p_, c) * (1 - p_.rest_fraction) / 2;
  return m;
}

double WaterModel::total(int c) const {
  double s = 0;
  for (float v : density(c)) s += v;
  return s;
}

std::vector<float> WaterModel::pack_row(Exchange kind, int y) const {
  std::vector<float> out;
  const std::size_t stride = g_.direction_stride();
  if (kind == Exchange::populations) {
    for (int c = 0; c < 2; ++c)
      for (int i = 0; i < d3q19::q; ++i)
        for (int z = 0; z < g_.nz; ++z) {
          const std::size_t at = out.size();
          out.resize(at + static_cast<std::size_t>(g_.nx));
          f_[c].read(static_cast<std::size_t>(i) * stride + g_.index(0, y, z), static_cast<std::size_t>(g_.nx),
                     out.data() + at);
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
  const std::size_t stride = g_.direction_stride();
  std::size_t k = 0;
  if (kind == Exchange::populations) {
    for (int c = 0; c < 2; ++c)
      for (int i = 0; i < d3q19::q; ++i)
        for (int z = 0; z < g_.nz; ++z, k += static_cast<std::size_t>(g_.nx))
          f_[c].write(static_cast<std::size_t>(i) * stride + g_.index(0, y, z), static_cast<std::size_t>(g_.nx),
                      data.data() + k);
  } else {
    for (std::vector<float>* f : {&rho_[0], &rho_[1], &psi1_})
      for (int z = 0; z < g_.nz; ++z, k += static_cast<std::size_t>(g_.nx))
        std::copy_n(data.data() + k, g_.nx, f->data() + g_.index(0, y, z));
  }
}

namespace {
// IEEE 754 leaves the sign and payload of a NaN that an operation makes to the operation and
// the order of its operands, which a slab's loops and the whole lattice's (vectorised or not,
// operands commuted by the compiler) may choose differently: a blown-up run's NaNs then differ
// in their sign bit between process counts. So a NaN is shown as "NaN" and stored in a
// checkpoint as the one quiet NaN, 0x7FC00000 (checkpoint.cpp): the failure message and
// checkpoint are then the same whatever the process count.
std::string value_text(float v) { return std::isnan(v) ? std::string("NaN") : fmt::format("{}", v); }
}  // namespace

bool WaterModel::check(std::string& what, std::size_t& cell) const {
  const auto v = vapour(), t = temperature();
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!(v[k] >= 0 && v[k] <= 100 * p_.rho10)) {
      what = "vapour density " + value_text(v[k]);
      cell = k;
      return false;
    }
    if (!(t[k] >= 0 && t[k] <= 10)) {
      what = "temperature " + value_text(t[k]);
      cell = k;
      return false;
    }
  }
  return true;
}

std::optional<std::string> WaterModel::bad_density() const {
  std::string what;
  std::size_t cell = 0;
  if (check(what, cell)) return std::nullopt;
  // `cell` indexes the owned rows ([z][y - first owned row][x]); name it in the whole lattice.
  const auto nx = static_cast<std::size_t>(g_.nx), own = static_cast<std::size_t>(owned_end() - owned_begin());
  return fmt::format("step {}: {} at cell (x={}, y={}, z={})", steps_done(), what, cell % nx,
                     global_y(owned_begin() + static_cast<int>(cell / nx % own)), cell / (nx * own));
}

}  // namespace nephos::lbm
