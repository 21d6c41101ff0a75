#pragma once
// The D3Q19 lattice: the rest vector, the 6 axis directions and the 12 face diagonals of the
// unit cube {-1,0,1}^3 (no corners), in the order of the lattice-Boltzmann cloud seed:
// c_0 = 0, c_1..c_6 the axes, c_7..c_18 the diagonals. Opposite pairs are adjacent (1,2), (3,4)...
#include <array>
#include <cstddef>
#include <utility>

namespace nephos::lbm::d3q19 {

inline constexpr int q = 19;
inline constexpr std::array<int, q> cx{0, 1, -1, 0, 0, 0, 0, 1, -1, 1, -1, 1, -1, 1, -1, 0, 0, 0, 0};
inline constexpr std::array<int, q> cy{0, 0, 0, 1, -1, 0, 0, 1, -1, -1, 1, 0, 0, 0, 0, 1, -1, 1, -1};
inline constexpr std::array<int, q> cz{0, 0, 0, 0, 0, 1, -1, 0, 0, 0, 0, 1, -1, -1, 1, 1, -1, -1, 1};
inline constexpr std::array<int, q> opposite{0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9, 12, 11, 14, 13, 16, 15, 18, 17};

/// Isotropic gradient weights w_i / c_s^2 with the standard weights (1/18 axis, 1/36 diagonal)
/// and c_s^2 = 1/3: grad(phi) ~ sum_i g_i phi(x + c_i) c_i.
inline constexpr double gradient_weight(int i) { return i == 0 ? 0.0 : i <= 6 ? 3.0 / 18.0 : 3.0 / 36.0; }

/// c_i . (x, y, z) with the zero components of c_i left out and the unit ones as additions and
/// subtractions. Called with a constant i (inside a fully unrolled loop) only the non-zero
/// terms remain; written as c_x x + c_y y + c_z z, IEEE rules keep every 0 * x (it could be a
/// NaN or -0), a third of the arithmetic of a D3Q19 collision. Exact: the same value as the
/// product form wherever that one has no signed-zero or NaN subtlety. Always inlined (as
/// add_c): they only shrink to those few terms once inlined with a constant i, and GCC's
/// inlining budget can otherwise drop add_c from the water model's collision.
template <class T>
[[gnu::always_inline]] inline T dot_c(int i, T x, T y, T z) {
  const auto iu = static_cast<std::size_t>(i);
  T r = T(0);
  bool any = false;
  for (const auto& [c, v] : {std::pair{cx[iu], x}, std::pair{cy[iu], y}, std::pair{cz[iu], z}}) {
    if (c == 0) continue;
    r = any ? (c > 0 ? r + v : r - v) : (c > 0 ? v : -v);
    any = true;
  }
  return r;
}

/// (sx, sy, sz) += c_i v with the zero components of c_i left out (see dot_c).
template <class T>
[[gnu::always_inline]] inline void add_c(int i, T v, T& sx, T& sy, T& sz) {
  const auto iu = static_cast<std::size_t>(i);
  if (cx[iu] != 0) sx = cx[iu] > 0 ? sx + v : sx - v;
  if (cy[iu] != 0) sy = cy[iu] > 0 ? sy + v : sy - v;
  if (cz[iu] != 0) sz = cz[iu] > 0 ? sz + v : sz - v;
}

/// The equilibrium of the seed (section 3, after eq. 6) with rest fraction d and unit lattice
/// speed v = lambda / tau = 1:
///   f_0 = rho (d - u^2/2)
///   f_i = rho ((1-d)/12 + c.u/6 + (c.u)^2/4 - u^2/12)   axis
///   f_i = rho ((1-d)/24 + c.u/12 + (c.u)^2/8 - u^2/24)  diagonal
/// d = 1/3 gives the standard D3Q19 weights; the pressure is p = rho (1 - d)/2 (eq. 19).
template <class T>
inline void equilibrium(T rho, T ux, T uy, T uz, T d, T* feq) {
  const T u2 = ux * ux + uy * uy + uz * uz;
  const T a = (T(1) - d) / T(12), b = (T(1) - d) / T(24);
  feq[0] = rho * (d - T(0.5) * u2);
  for (int i = 1; i < q; ++i) {
    const T cu = T(cx[static_cast<std::size_t>(i)]) * ux + T(cy[static_cast<std::size_t>(i)]) * uy +
                 T(cz[static_cast<std::size_t>(i)]) * uz;
    feq[i] = i <= 6 ? rho * (a + cu / T(6) + cu * cu / T(4) - u2 / T(12))
                    : rho * (b + cu / T(12) + cu * cu / T(8) - u2 / T(24));
  }
}

/// Coefficients of the equilibrium per direction: f_i = w_i rho + rho (k1 c.u + k2 (c.u)^2 - k3 u^2).
template <class T>
struct EquilibriumCoefficients {
  T w, k1, k2, k3;
};
template <class T>
constexpr EquilibriumCoefficients<T> equilibrium_coefficients(int i, T d) {
  if (i == 0) return {d, T(0), T(0), T(0.5)};
  if (i <= 6) return {(T(1) - d) / T(12), T(1) / T(6), T(0.25), T(1) / T(12)};
  return {(T(1) - d) / T(24), T(1) / T(12), T(0.125), T(1) / T(24)};
}

/// The equilibrium minus w_i * rho_ref ("DDF shifting", as in FluidX3D): populations are
/// stored as deviations from the rest state of density rho_ref, which keeps FP32 rounding
/// relative to the deviation, not to the density. drho = rho - rho_ref.
template <class T>
inline void equilibrium_shifted(T drho, T rho, T ux, T uy, T uz, T d, T* out) {
  const T u2 = ux * ux + uy * uy + uz * uz;
  for (int i = 0; i < q; ++i) {
    const auto e = equilibrium_coefficients<T>(i, d);
    const T cu = T(cx[static_cast<std::size_t>(i)]) * ux + T(cy[static_cast<std::size_t>(i)]) * uy +
                 T(cz[static_cast<std::size_t>(i)]) * uz;
    out[i] = e.w * drho + rho * (e.k1 * cu + e.k2 * cu * cu - e.k3 * u2);
  }
}

}  // namespace nephos::lbm::d3q19
