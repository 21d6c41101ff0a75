#pragma once
// Tileable 3D fractal textures (seed 000, section 2.1): Perlin gradient-noise fractals and an
// inverted Worley (cellular) fractal, baked once per seed into an N^3 grid of 16-bit values in
// [0, 1] and sampled with periodic trilinear interpolation. 16-bit storage halves the memory
// traffic of float at a quantisation error of at most 0.5/65535 = 7.6e-6 (tested).
#include <cmath>
#include <cstdint>
#include <vector>

namespace nephos::noise {

enum class FractalKind { perlin, worley };

struct FractalSpec {
  FractalKind kind = FractalKind::perlin;
  int base_cells = 4;        ///< lattice cells across the tile at the first octave (tileable: integer)
  int octaves = 4;           ///< each octave doubles the cell count
  double persistence = 0.5;  ///< amplitude factor from one octave to the next
  bool invert = false;       ///< 1 - value (Worley: bright cell centres, dark borders)
};

/// A periodic N x N x N texture of values in [0, 1], stored as uint16.
class Texture3D {
 public:
  Texture3D() = default;
  explicit Texture3D(int n) : n_(n), data_(static_cast<std::size_t>(n) * n * n) {}
  int size() const { return n_; }
  std::size_t bytes() const { return data_.size() * sizeof(std::uint16_t); }

  /// Trilinear value at texture coordinates (u, v, w) in tile units: 1.0 = one tile; any real
  /// value wraps periodically.
  float sample(float u, float v, float w) const {
    const float fn = static_cast<float>(n_);
    float x = u * fn, y = v * fn, z = w * fn;
    const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
    const float tx = x - fx, ty = y - fy, tz = z - fz;
    const unsigned mask = static_cast<unsigned>(n_ - 1);  // n is a power of two
    const unsigned x0 = static_cast<unsigned>(static_cast<int>(fx)) & mask, x1 = (x0 + 1) & mask;
    const unsigned y0 = static_cast<unsigned>(static_cast<int>(fy)) & mask, y1 = (y0 + 1) & mask;
    const unsigned z0 = static_cast<unsigned>(static_cast<int>(fz)) & mask, z1 = (z0 + 1) & mask;
    const unsigned sn = static_cast<unsigned>(n_);
    auto at = [&](unsigned i, unsigned j, unsigned k) { return static_cast<float>(data_[(k * sn + j) * sn + i]); };
    const float c00 = at(x0, y0, z0) + tx * (at(x1, y0, z0) - at(x0, y0, z0));
    const float c10 = at(x0, y1, z0) + tx * (at(x1, y1, z0) - at(x0, y1, z0));
    const float c01 = at(x0, y0, z1) + tx * (at(x1, y0, z1) - at(x0, y0, z1));
    const float c11 = at(x0, y1, z1) + tx * (at(x1, y1, z1) - at(x0, y1, z1));
    const float c0 = c00 + ty * (c10 - c00), c1 = c01 + ty * (c11 - c01);
    return (c0 + tz * (c1 - c0)) * (1.0f / 65535.0f);
  }
  /// Value of voxel (i, j, k) in [0, 1].
  float voxel(int i, int j, int k) const {
    return data_[(static_cast<std::size_t>(k) * n_ + j) * n_ + i] * (1.0f / 65535.0f);
  }
  std::uint16_t* data() { return data_.data(); }
  const std::uint16_t* data() const { return data_.data(); }

 private:
  int n_ = 0;
  std::vector<std::uint16_t> data_;
};

/// Unquantised fractal value at a point of the unit tile (x, y, z in [0, 1)), before the
/// texture-wide normalisation; periodic with period 1 in each axis.
double fractal_value(const FractalSpec& spec, std::uint64_t seed, double x, double y, double z);

/// Bakes `spec` into an n^3 texture (n a power of two, >= 8), normalised so that its minimum
/// maps to 0 and maximum to 1. Deterministic from `seed` for any thread count.
Texture3D bake(const FractalSpec& spec, std::uint64_t seed, int n);

}  // namespace nephos::noise
