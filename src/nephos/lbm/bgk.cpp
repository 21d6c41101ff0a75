#include "nephos/lbm/bgk.hpp"

#include <algorithm>

#include "nephos/core/error.hpp"

namespace nephos::lbm {

BgkSolver::BgkSolver(Grid3 grid, double relaxation_time, ZBoundary zb, std::array<double, 3> body_force,
                     double rest_fraction)
    : g_(grid), xi_(relaxation_time), zb_(zb), force_(body_force), d_(rest_fraction) {
  if (!(xi_ > 0.5)) throw ValueError("relaxation time must exceed 1/2 for stability", {.key = "xi"});
  a_.resize(g_.population_size(d3q19::q));
  b_.resize(a_.size());
}

void BgkSolver::initialise(double rho) {
  float feq[d3q19::q];
  d3q19::equilibrium_shifted<float>(static_cast<float>(rho - 1.0), static_cast<float>(rho), 0, 0, 0,
                                    static_cast<float>(d_), feq);
  const std::size_t stride = g_.direction_stride();
  for (int i = 0; i < d3q19::q; ++i)
    std::fill_n(a_.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(i) * stride),
                static_cast<std::ptrdiff_t>(g_.cells()), feq[i]);
}

namespace {

constexpr int chunk = chunk_cells;

struct BgkConstants {
  float omega, d, sfx, sfy, sfz;  // 1/xi, rest fraction, xi * force (the eq. 10 velocity shift)
};

// Collides `count` (<= chunk) cells whose pulled populations are src[i][l], l < count, into
// post[i * chunk + l]. The body is written per cell; `omp simd` vectorises it across the chunk.
inline void collide_chunk(const float* const* src, float* post, int count, const BgkConstants& k) {
  using namespace d3q19;
#pragma omp simd
  for (int l = 0; l < count; ++l) {
    float f[q];
#pragma GCC unroll 19
    for (int i = 0; i < q; ++i) f[i] = src[i][l];
    float drho = 0, jx = 0, jy = 0, jz = 0;
#pragma GCC unroll 19
    for (int i = 0; i < q; ++i) {
      drho += f[i];
      add_c(i, f[i], jx, jy, jz);
    }
    const float rho = 1.0f + drho;  // populations are shifted by w_i (rho_ref = 1)
    const float inv = 1.0f / rho;
    const float ux = (jx + k.sfx) * inv, uy = (jy + k.sfy) * inv, uz = (jz + k.sfz) * inv;
    const float u2 = ux * ux + uy * uy + uz * uz;
    {
      const auto e = equilibrium_coefficients<float>(0, k.d);
      const float feq = e.w * drho + rho * (-e.k3 * u2);
      post[l] = f[0] - k.omega * (f[0] - feq);
    }
    // Opposite directions (i, i + 1) in pairs: their equilibria share the even part,
    // f_eq(+-) = sym +- anti (as the water model's collision), half the arithmetic.
#pragma GCC unroll 9
    for (int i = 1; i < q; i += 2) {
      const auto e = equilibrium_coefficients<float>(i, k.d);
      const float cu = dot_c(i, ux, uy, uz);
      const float sym = e.w * drho + rho * (e.k2 * cu * cu - e.k3 * u2), anti = rho * e.k1 * cu;
      post[i * chunk + l] = f[i] - k.omega * (f[i] - (sym + anti));
      post[(i + 1) * chunk + l] = f[i + 1] - k.omega * (f[i + 1] - (sym - anti));
    }
  }
}

}  // namespace

void BgkSolver::step() {
  const std::size_t stride = g_.direction_stride();
  const int nx = g_.nx;
  const float shift = static_cast<float>(xi_);  // u_eq = u + xi F / rho (eq. 10, tau = 1)
  const BgkConstants k{static_cast<float>(1.0 / xi_), static_cast<float>(d_), shift * static_cast<float>(force_[0]),
                       shift * static_cast<float>(force_[1]), shift * static_cast<float>(force_[2])};
#pragma omp parallel
  {
    alignas(64) float post[d3q19::q * chunk];
    alignas(64) float edge[d3q19::q * chunk];  // pulled populations of chunks that wrap around x
#pragma omp for collapse(2) schedule(static)
    for (int z = 0; z < g_.nz; ++z)
      for (int y = 0; y < g_.ny; ++y) {
        const RowSources rs = row_sources(g_, a_.data(), y, z, zb_);
        float* out = b_.data() + g_.index(0, y, z);
        for (int x0 = 0; x0 < nx; x0 += chunk) {
          const int count = std::min(chunk, nx - x0);
          const float* src[d3q19::q];
          for (int i = 0; i < d3q19::q; ++i) {
            // The same direction two rows ahead (rows of a direction follow each other in
            // memory): more streams than the hardware prefetchers follow.
            __builtin_prefetch(rs.row[static_cast<std::size_t>(i)] + x0 + 2 * nx);
            src[i] = periodic_span(rs.row[static_cast<std::size_t>(i)], nx, x0, -rs.shift[static_cast<std::size_t>(i)],
                                   count, edge + i * chunk);
          }
          collide_chunk(src, post, count, k);
          for (int i = 0; i < d3q19::q; ++i)
            store_streaming(out + static_cast<std::size_t>(i) * stride + x0, post + i * chunk,
                            static_cast<std::size_t>(count));
        }
      }
    stream_fence();
  }
  a_.swap(b_);
}

double BgkSolver::density(std::size_t cell) const {
  double rho = 1.0;  // rho_ref
  for (int i = 0; i < d3q19::q; ++i) rho += a_[static_cast<std::size_t>(i) * g_.direction_stride() + cell];
  return rho;
}

std::array<double, 3> BgkSolver::velocity(std::size_t cell) const {
  // a_ holds post-collision populations; the momentum of the post-collision state already
  // includes the full force impulse, so the cross-collision average (eq. 11) is j - F/2.
  double j[3] = {0, 0, 0};
  for (int i = 0; i < d3q19::q; ++i) {
    const double f = a_[static_cast<std::size_t>(i) * g_.direction_stride() + cell];
    j[0] += f * d3q19::cx[static_cast<std::size_t>(i)];
    j[1] += f * d3q19::cy[static_cast<std::size_t>(i)];
    j[2] += f * d3q19::cz[static_cast<std::size_t>(i)];
  }
  const double rho = density(cell);
  return {(j[0] - 0.5 * force_[0]) / rho, (j[1] - 0.5 * force_[1]) / rho, (j[2] - 0.5 * force_[2]) / rho};
}

double BgkSolver::total_mass() const {
  double m = static_cast<double>(g_.cells());  // rho_ref per cell
  for (float v : a_) m += v;                   // the padding between directions stays zero
  return m;
}

}  // namespace nephos::lbm
