#pragma once
// A field over directions (the unit sphere) stored on the six faces of a cube, n x n texels
// each. Lookup needs one division and no trigonometry, which is why the hot ray-marching loop
// samples weather masks and displacement maps through cube maps rather than lat-lon grids.
// Face f has major axis a = f/2 with sign (f%2 ? -1 : +1); the texel coordinates are the other
// two components divided by the major one, in fixed axis order.
#include <algorithm>
#include <cmath>
#include <vector>

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
  std::vector<T>& data() { return data_; }
  const std::vector<T>& data() const { return data_; }

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

  /// Bilinear value in direction d (any length > 0).
  T sample(const earth::Vec3& d) const {
    const double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
    int a;
    double m;
    if (ax >= ay && ax >= az)
      a = 0, m = d.x;
    else if (ay >= az)
      a = 1, m = d.y;
    else
      a = 2, m = d.z;
    const int face = 2 * a + (m < 0 ? 1 : 0);
    const double inv = 1.0 / std::abs(m);
    const double u = d[(a + 1) % 3] * inv, v = d[(a + 2) % 3] * inv;
    // Within half a texel of a face edge the outermost two texels are extrapolated linearly
    // (weights slightly outside [0, 1]), so smooth fields stay smooth across the seams.
    const double x = (u + 1.0) * 0.5 * n_ - 0.5, y = (v + 1.0) * 0.5 * n_ - 0.5;
    const int i0 = std::clamp(static_cast<int>(std::floor(x)), 0, n_ - 2);
    const int j0 = std::clamp(static_cast<int>(std::floor(y)), 0, n_ - 2);
    const float tx = static_cast<float>(x - i0), ty = static_cast<float>(y - j0);
    const T& a00 = texel(face, i0, j0);
    const T& a10 = texel(face, i0 + 1, j0);
    const T& a01 = texel(face, i0, j0 + 1);
    const T& a11 = texel(face, i0 + 1, j0 + 1);
    return (a00 * (1.0f - tx) + a10 * tx) * (1.0f - ty) + (a01 * (1.0f - tx) + a11 * tx) * ty;
  }

 private:
  std::size_t index(int face, int i, int j) const {
    return (static_cast<std::size_t>(face) * n_ + static_cast<std::size_t>(j)) * n_ + static_cast<std::size_t>(i);
  }
  int n_ = 0;
  std::vector<T> data_;
};

}  // namespace nephos::clouds
