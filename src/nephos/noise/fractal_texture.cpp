#include "nephos/noise/fractal_texture.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <limits>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"

namespace nephos::noise {
namespace {

constexpr double texel_scale = 1.0 / Texture3D::texel_max;  // a texel level's value

int wrap(int i, int period) {
  const int r = i % period;
  return r < 0 ? r + period : r;
}

// Perlin's improved fade curve 6t^5 - 15t^4 + 10t^3 (C2-continuous).
double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

// Per-octave lattice tables: unit gradients (Perlin) or feature points (Worley) for each of
// cells^3 lattice cells, drawn from the counter-based hash of (seed, octave, i, j, k).
class Evaluator {
 public:
  Evaluator(const FractalSpec& spec, std::uint64_t seed) : spec_(spec) {
    for (int o = 0; o < spec.octaves; ++o) {
      const int c = spec.base_cells << o;
      std::vector<float> t(static_cast<std::size_t>(c) * c * c * 3);
      for (int k = 0; k < c; ++k)
        for (int j = 0; j < c; ++j)
          for (int i = 0; i < c; ++i) {
            const std::uint64_t h = hash(seed, static_cast<std::uint64_t>(o), static_cast<std::uint64_t>(i),
                                         static_cast<std::uint64_t>(j), static_cast<std::uint64_t>(k));
            float* g = &t[((static_cast<std::size_t>(k) * c + j) * c + i) * 3];
            if (spec.kind == FractalKind::perlin) {  // uniform on the unit sphere
              const double z = 2.0 * to_unit_double(h) - 1.0;
              const double phi = 2.0 * M_PI * to_unit_double(mix64(h));
              const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
              g[0] = static_cast<float>(r * std::cos(phi));
              g[1] = static_cast<float>(r * std::sin(phi));
              g[2] = static_cast<float>(z);
            } else {  // feature point offset within the cell, uniform in [0, 1)^3
              g[0] = static_cast<float>(to_unit_double(h));
              g[1] = static_cast<float>(to_unit_double(mix64(h)));
              g[2] = static_cast<float>(to_unit_double(mix64(mix64(h))));
            }
          }
      tables_.push_back(std::move(t));
    }
  }

  double operator()(double x, double y, double z) const {
    double sum = 0, amp = 1;
    for (int o = 0; o < spec_.octaves; ++o) {
      const int cells = spec_.base_cells << o;
      sum += amp * (spec_.kind == FractalKind::perlin ? perlin(o, cells, x, y, z) : worley(o, cells, x, y, z));
      amp *= spec_.persistence;
    }
    return sum;
  }

  /// operator()(i / n, y, z) for 0 <= i < n into out[i], with the same arithmetic per voxel.
  /// Octave by octave, the row is cut into runs of voxels inside one lattice cell along x; a
  /// run reads its 8 gradients (27 feature points) once, and its voxels are a loop of
  /// arithmetic without table lookups, which the compiler vectorises.
  void row(int n, double y, double z, double* out) const {
    const double inv = 1.0 / n;
    std::fill(out, out + n, 0.0);
    double amp = 1;
    for (int o = 0; o < spec_.octaves; ++o) {
      const int cells = spec_.base_cells << o;
      const double py = y * cells, pz = z * cells;
      const int iy = static_cast<int>(std::floor(py)), iz = static_cast<int>(std::floor(pz));
      for (int i0 = 0; i0 < n;) {
        const int ix = static_cast<int>(std::floor(i0 * inv * cells));
        int i1 = i0 + 1;  // the run: the voxels with the same lattice cell along x
        while (i1 < n && static_cast<int>(std::floor(i1 * inv * cells)) == ix) ++i1;
        if (spec_.kind == FractalKind::perlin)
          perlin_run(o, cells, ix, iy, iz, py, pz, i0, i1, inv, amp, out);
        else
          worley_run(o, cells, ix, iy, iz, py, pz, i0, i1, inv, amp, out);
        i0 = i1;
      }
      amp *= spec_.persistence;
    }
  }

 private:
  const float* entry(int o, int cells, int i, int j, int k) const {
    return &tables_[static_cast<std::size_t>(o)]
                   [((static_cast<std::size_t>(wrap(k, cells)) * cells + wrap(j, cells)) * cells + wrap(i, cells)) * 3];
  }

  // Periodic gradient noise in about [-1, 1] with `cells` lattice cells across the unit tile.
  double perlin(int o, int cells, double x, double y, double z) const {
    const double px = x * cells, py = y * cells, pz = z * cells;
    const int ix = static_cast<int>(std::floor(px)), iy = static_cast<int>(std::floor(py)),
              iz = static_cast<int>(std::floor(pz));
    const double fx = px - ix, fy = py - iy, fz = pz - iz;
    double n[2][2][2];
    for (int c = 0; c < 8; ++c) {
      const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
      const float* g = entry(o, cells, ix + dx, iy + dy, iz + dz);
      n[dz][dy][dx] = g[0] * (fx - dx) + g[1] * (fy - dy) + g[2] * (fz - dz);
    }
    const double u = fade(fx), v = fade(fy), w = fade(fz);
    auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
    return lerp(lerp(lerp(n[0][0][0], n[0][0][1], u), lerp(n[0][1][0], n[0][1][1], u), v),
                lerp(lerp(n[1][0][0], n[1][0][1], u), lerp(n[1][1][0], n[1][1][1], u), v), w);
  }

  // Periodic Worley noise: distance to the nearest feature point (one per cell), in cell units.
  double worley(int o, int cells, double x, double y, double z) const {
    const double px = x * cells, py = y * cells, pz = z * cells;
    const int ix = static_cast<int>(std::floor(px)), iy = static_cast<int>(std::floor(py)),
              iz = static_cast<int>(std::floor(pz));
    double best = std::numeric_limits<double>::max();
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const float* f = entry(o, cells, ix + dx, iy + dy, iz + dz);
          const double ex = (ix + dx) + double{f[0]} - px, ey = (iy + dy) + double{f[1]} - py,
                       ez = (iz + dz) + double{f[2]} - pz;
          best = std::min(best, ex * ex + ey * ey + ez * ez);
        }
    return std::sqrt(best);
  }

  // perlin() over the voxels [i0, i1) of a row, all in lattice cell (ix, iy, iz); adds amp times
  // the value to out[i]. The expressions are perlin()'s, term for term.
  void perlin_run(int o, int cells, int ix, int iy, int iz, double py, double pz, int i0, int i1, double inv,
                  double amp, double* out) const {
    const double fy = py - iy, fz = pz - iz;
    float g[8][3];
    for (int c = 0; c < 8; ++c) {
      const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
      const float* e = entry(o, cells, ix + dx, iy + dy, iz + dz);
      g[c][0] = e[0], g[c][1] = e[1], g[c][2] = e[2];
    }
    const double v = fade(fy), w = fade(fz);
#pragma omp simd
    for (int i = i0; i < i1; ++i) {
      const double px = i * inv * cells;
      const double fx = px - ix;
      double n[2][2][2];
#pragma GCC unroll 8
      for (int c = 0; c < 8; ++c) {
        const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
        n[dz][dy][dx] = g[c][0] * (fx - dx) + g[c][1] * (fy - dy) + g[c][2] * (fz - dz);
      }
      const double u = fade(fx);
      auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
      out[i] += amp * lerp(lerp(lerp(n[0][0][0], n[0][0][1], u), lerp(n[0][1][0], n[0][1][1], u), v),
                           lerp(lerp(n[1][0][0], n[1][0][1], u), lerp(n[1][1][0], n[1][1][1], u), v), w);
    }
  }

  // worley() over the voxels [i0, i1) of a row, all in lattice cell (ix, iy, iz).
  void worley_run(int o, int cells, int ix, int iy, int iz, double py, double pz, int i0, int i1, double inv,
                  double amp, double* out) const {
    double fxs[27], eys[27], ezs[27];  // per neighbour: (ix + dx) + f_x, and the y, z offsets
    int q = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx, ++q) {
          const float* f = entry(o, cells, ix + dx, iy + dy, iz + dz);
          fxs[q] = (ix + dx) + double{f[0]};
          eys[q] = (iy + dy) + double{f[1]} - py;
          ezs[q] = (iz + dz) + double{f[2]} - pz;
        }
#pragma omp simd
    for (int i = i0; i < i1; ++i) {
      const double px = i * inv * cells;
      double best = std::numeric_limits<double>::max();
#pragma GCC unroll 27
      for (int k = 0; k < 27; ++k) {
        const double ex = fxs[k] - px;
        best = std::min(best, ex * ex + eys[k] * eys[k] + ezs[k] * ezs[k]);
      }
      out[i] += amp * std::sqrt(best);
    }
  }

  FractalSpec spec_;
  std::vector<std::vector<float>> tables_;
};

}  // namespace

double fractal_value(const FractalSpec& spec, std::uint64_t seed, double x, double y, double z) {
  return Evaluator(spec, seed)(x, y, z);
}

Texture3D bake(const FractalSpec& spec, std::uint64_t seed, int n) {
  if (n < 8 || (n & (n - 1)) != 0)
    throw ValueError(fmt::format("texture size must be a power of two >= 8, got {}", n), {.key = "texture"});
  if (spec.base_cells < 1 || spec.octaves < 1 || (spec.base_cells << (spec.octaves - 1)) > n)
    throw ValueError(fmt::format("fractal with {} base cells and {} octaves needs a texture of at least {} voxels",
                                 spec.base_cells, spec.octaves, spec.base_cells << (spec.octaves - 1)),
                     {.key = "octaves"});
  const std::size_t count = static_cast<std::size_t>(n) * n * n;
  std::vector<float> raw(count);
  const Evaluator eval(spec, seed);
  const double inv = 1.0 / n;
#pragma omp parallel
  {
    std::vector<double> row(static_cast<std::size_t>(n));
#pragma omp for schedule(static)
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j) {
        eval.row(n, j * inv, k * inv, row.data());
        float* dst = raw.data() + (static_cast<std::size_t>(k) * n + j) * n;
        for (int i = 0; i < n; ++i) dst[i] = static_cast<float>(row[static_cast<std::size_t>(i)]);
      }
  }
  const auto [lo_it, hi_it] = std::minmax_element(raw.begin(), raw.end());
  const float lo = *lo_it, span = std::max(*hi_it - lo, 1e-30f);
  Texture3D t(n);
  Texture3D::Texel* d = t.data();
#pragma omp parallel for schedule(static)
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j) {
      const float* src = raw.data() + (static_cast<std::size_t>(k) * n + j) * n;
      Texture3D::Texel* row = d + t.offset_y(static_cast<unsigned>(j)) + t.offset_z(static_cast<unsigned>(k));
      for (int i = 0; i < n; ++i) {
        float v = (src[i] - lo) / span;
        if (spec.invert) v = 1.0f - v;
        // Round half away from zero (std::lround) of a value in [0, 255]: exact in double, and
        // without a library call per voxel.
        const double q = static_cast<double>(v * Texture3D::texel_max) + 0.5;
        row[t.offset_x(static_cast<unsigned>(i))] = static_cast<Texture3D::Texel>(static_cast<int>(q));
      }
    }
  t.update_bounds();
  return t;
}

TextureStats texture_stats(const Texture3D& t) {
  const int n = t.size();
  double sum = 0, sum2 = 0, diff2 = 0;
  int lo = 255, hi = 0;
  auto at = [&t, n](int i, int j, int k) {
    return static_cast<int>(t.data()[t.index((i + n) % n, (j + n) % n, (k + n) % n)]);
  };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j) {
      const Texture3D::Texel* row =
          t.data() + t.offset_y(static_cast<unsigned>(j)) + t.offset_z(static_cast<unsigned>(k));
      for (int i = 0; i < n; ++i) {
        const int v = row[t.offset_x(static_cast<unsigned>(i))];
        const int dx = at(i + 1, j, k) - v, dy = at(i, j + 1, k) - v, dz = at(i, j, k + 1) - v;
        sum += v, sum2 += static_cast<double>(v) * v, lo = std::min(lo, v), hi = std::max(hi, v);
        diff2 += static_cast<double>(dx * dx + dy * dy + dz * dz);
      }
    }
  const double count = static_cast<double>(n) * n * n, m = texel_scale * sum / count, s2 = texel_scale * texel_scale;
  return {m, std::max(0.0, s2 * sum2 / count - m * m), texel_scale * lo, texel_scale * hi, s2 * diff2 / count};
}

Texture3D half_size(const Texture3D& t) {
  const int h = t.size() / 2;
  Texture3D out(h);
  auto at = [&t](int i, int j, int k) { return static_cast<int>(t.data()[t.index(i, j, k)]); };
#pragma omp parallel for schedule(static)
  for (int k = 0; k < h; ++k)
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < h; ++i) {
        int sum = 0;
        for (int c = 0; c < 8; ++c) sum += at(2 * i + (c & 1), 2 * j + ((c >> 1) & 1), 2 * k + (c >> 2));
        out.data()[out.index(i, j, k)] = static_cast<Texture3D::Texel>((sum + 4) / 8);
      }
  out.update_bounds();
  return out;
}

MipPyramid MipPyramid::of(const Texture3D& t) {
  MipPyramid m;
  m.stats.push_back(texture_stats(t));
  for (const Texture3D* level = &t; level->size() > 4;) {
    m.levels.push_back(half_size(*level));
    level = &m.levels.back();
    m.stats.push_back(texture_stats(*level));
  }
  m.stats.push_back({m.stats[0].mean, 0.0, m.stats[0].mean, m.stats[0].mean});
  return m;
}

void Texture3D::throw_bad_size(int n) {
  throw ValueError(fmt::format("texture size must be a power of two >= 4, got {}", n), {.key = "texture"});
}

void Texture3D::update_bounds() {
  if (n_ < 4 || (n_ & (n_ - 1)) != 0) throw_bad_size(n_);  // a default-constructed texture
  // The aprons: every slot of every brick that is not its voxel's own copy (the brick's fourth
  // plane along an axis, or a voxel past n - 1 wrapped around) takes that copy's value.
  {
    const unsigned n = static_cast<unsigned>(n_), nb = nb_;
#pragma omp parallel for schedule(static)
    for (int bz = 0; bz < static_cast<int>(nb); ++bz)
      for (unsigned by = 0; by < nb; ++by)
        for (unsigned bx = 0; bx < nb; ++bx) {
          Texel* brick = data_.data() + ((static_cast<std::size_t>(bz) * nb + by) * nb + bx) * 64;
          for (unsigned lz = 0; lz < 4; ++lz)
            for (unsigned ly = 0; ly < 4; ++ly)
              for (unsigned lx = 0; lx < 4; ++lx) {
                const unsigned x = (3 * bx + lx) % n, y = (3 * by + ly) % n,
                               z = (3 * static_cast<unsigned>(bz) + lz) % n;
                const std::size_t own = std::size_t{offset_x(x)} + offset_y(y) + offset_z(z);
                Texel& slot = brick[lz * 16 + ly * 4 + lx];
                if (&slot != data_.data() + own) slot = data_[own];  // own copies are only read
              }
        }
  }
  block_shift_ = 0;
  while ((n_ >> block_shift_) > bounds_grid) ++block_shift_;
  const int b = 1 << block_shift_, nb = n_ / b;
  block_bounds_.assign(static_cast<std::size_t>(nb) * nb * nb, {});
  const unsigned mask = static_cast<unsigned>(n_ - 1);
#pragma omp parallel for collapse(2) schedule(static)
  for (int bk = 0; bk < nb; ++bk)
    for (int bj = 0; bj < nb; ++bj)
      for (int bi = 0; bi < nb; ++bi) {
        std::uint32_t lo = 255, hi = 0;
        for (int k = 0; k <= b; ++k)  // the block and one voxel beyond (periodic)
          for (int j = 0; j <= b; ++j)
            for (int i = 0; i <= b; ++i) {
              const unsigned x = static_cast<unsigned>(bi * b + i) & mask, y = static_cast<unsigned>(bj * b + j) & mask,
                             z = static_cast<unsigned>(bk * b + k) & mask;
              const std::uint32_t v = data_[std::size_t{offset_x(x)} + offset_y(y) + offset_z(z)];
              lo = std::min(lo, v);
              hi = std::max(hi, v);
            }
        block_bounds_[(static_cast<std::size_t>(bk) * nb + bj) * nb + bi] = static_cast<std::uint16_t>(lo | hi << 8);
      }
}

}  // namespace nephos::noise
