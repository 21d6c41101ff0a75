#pragma once
// A field over directions (the unit sphere) stored on the six faces of a cube, n x n texels
// each. Lookup needs one division and no trigonometry, which is why the hot ray-marching loop
// samples weather masks and displacement maps through cube maps rather than lat-lon grids.
// Face f has major axis a = f/2 with sign (f%2 ? -1 : +1); the texel coordinates are the other
// two components divided by the major one, in fixed axis order.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "nephos/core/huge_page_allocator.hpp"
#include "nephos/earth/geometry.hpp"

namespace nephos::clouds {

template <class T>
class CubeMap {
 public:
  CubeMap() = default;
  explicit CubeMap(int n) : n_(n), data_(static_cast<std::size_t>(6) * n * n) {}
  int size() const { return n_; }
  std::size_t texel_count() const { return data_.size(); }
  T& texel(int face, int i, int j) { return data_[index(face, i, j)]; }
  const T& texel(int face, int i, int j) const { return data_[index(face, i, j)]; }
  using Storage = std::vector<T, TableAllocator<T>>;  // sampled at random: huge pages
  Storage& data() { return data_; }
  const Storage& data() const { return data_; }

  /// The point (u, v) in [-1, 1]^2 of `face` on the cube's surface (not normalised): the
  /// inverse of the face selection in sample().
  static earth::Vec3 face_point(int face, double u, double v) {
    earth::Vec3 d{0, 0, 0};
    const int a = face / 2;
    d[a] = face % 2 ? -1.0 : 1.0;
    d[(a + 1) % 3] = u;
    d[(a + 2) % 3] = v;
    return d;
  }
  /// The unit direction through the centre of texel (i, j) of `face`.
  earth::Vec3 texel_direction(int face, int i, int j) const {
    return glm::normalize(face_point(face, (i + 0.5) * 2.0 / n_ - 1.0, (j + 0.5) * 2.0 / n_ - 1.0));
  }

  /// Sets every texel to value(direction through its centre), in parallel (OpenMP).
  template <class F>
  void fill(F&& value) {
#pragma omp parallel for collapse(2) schedule(static)
    for (int f = 0; f < 6; ++f)
      for (int j = 0; j < n_; ++j)
        for (int i = 0; i < n_; ++i) texel(f, i, j) = value(texel_direction(f, i, j));
  }

  /// Where sample() reads for direction (x, y, z): the flat index of texel (i0, j0), whose
  /// neighbours (i0 + 1, j0), (i0, j0 + 1), (i0 + 1, j0 + 1) are at +1, +n, +n + 1, and the
  /// bilinear weights. Branch-free so that loops over many directions vectorise (`omp simd`).
  struct Location {
    std::uint32_t index;
    float tx, ty;
  };
  static Location locate(int n, double x, double y, double z) {
    const double ax = std::abs(x), ay = std::abs(y), az = std::abs(z);
    const bool on_x = (ax >= ay) & (ax >= az), on_y = !on_x & (ay >= az);  // the major axis
    const double m = on_x ? x : on_y ? y : z;
    const double a1 = on_x ? y : on_y ? z : x, a2 = on_x ? z : on_y ? x : y;  // axes (a+1)%3, (a+2)%3
    const int face = 2 * (on_x ? 0 : on_y ? 1 : 2) + (m < 0 ? 1 : 0);
    const double inv = 1.0 / std::abs(m);
    const double u = a1 * inv, v = a2 * inv;
    // Within half a texel of a face edge the outermost two texels are extrapolated linearly
    // (weights slightly outside [0, 1]), so smooth fields stay smooth across the seams.
    const double fx = (u + 1.0) * 0.5 * n - 0.5, fy = (v + 1.0) * 0.5 * n - 0.5;
    const int i0 = std::min(std::max(static_cast<int>(std::floor(fx)), 0), n - 2);
    const int j0 = std::min(std::max(static_cast<int>(std::floor(fy)), 0), n - 2);
    return {static_cast<std::uint32_t>((face * n + j0) * n + i0), static_cast<float>(fx - i0),
            static_cast<float>(fy - j0)};
  }
  /// locate() of m directions (x[i], y[i], z[i]) into arrays (index[i], tx[i], ty[i]), in a loop
  /// that vectorises. Lookups of many directions locate here and load the texels in a scalar
  /// loop: vectorised, GCC 12 gathers the texels, which on the AMD cores we measure on is
  /// slower than scalar loads from cached lines (docs/PERFORMANCE.md, design choices).
  static void locate_many(int n, const double* x, const double* y, const double* z, std::size_t m, std::uint32_t* index,
                          float* tx, float* ty) {
#pragma omp simd
    for (std::size_t i = 0; i < m; ++i) {
      const Location l = locate(n, x[i], y[i], z[i]);
      index[i] = l.index, tx[i] = l.tx, ty[i] = l.ty;
    }
  }
  /// The bilinear blend sample() applies to the texels at `l`.
  static T blend(const Location& l, const T& a00, const T& a10, const T& a01, const T& a11) {
    return (a00 * (1.0f - l.tx) + a10 * l.tx) * (1.0f - l.ty) + (a01 * (1.0f - l.tx) + a11 * l.tx) * l.ty;
  }
  /// blend() of the texels at `l` read from a flat array: texel (i0, j0) at t[first], its
  /// neighbour in i `step` further, in j `row` further (a cube map's data(): first = l.index,
  /// step 1, row n; one component of a vec3 map seen as floats: step 3, row 3 n). Always
  /// inlined: GCC 12 otherwise leaves the call in, and the batched lookups unvectorised.
  [[gnu::always_inline]] static T blend_at(const Location& l, const T* t, std::size_t first, std::size_t step,
                                           std::size_t row) {
    return blend(l, t[first], t[first + step], t[first + row], t[first + row + step]);
  }

  /// Bilinear value in direction d (any length > 0).
  T sample(const earth::Vec3& d) const {
    const Location l = locate(n_, d.x, d.y, d.z);
    const std::size_t n = static_cast<std::size_t>(n_);
    return blend_at(l, data_.data(), l.index, 1, n);
  }

 private:
  std::size_t index(int face, int i, int j) const {
    return (static_cast<std::size_t>(face) * n_ + static_cast<std::size_t>(j)) * n_ + static_cast<std::size_t>(i);
  }
  int n_ = 0;
  Storage data_;
};

}  // namespace nephos::clouds
