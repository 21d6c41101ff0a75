#include "nephos/noise/fractal_texture.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"
#include "nephos/core/parallel.hpp"

namespace nephos::noise {

const FractalSpec perlin_spec{FractalKind::perlin, 4, 3, 0.5, false};
const FractalSpec worley_spec{FractalKind::worley, 4, 2, 0.5, true};

TEST(Fractal, IsPeriodicWithPeriodOne) {
  for (const auto& spec : {perlin_spec, worley_spec})
    for (double x : {0.013, 0.37, 0.91}) {
      // Exact periodicity up to the rounding of x + 1 (the lattice index wraps exactly).
      EXPECT_NEAR(fractal_value(spec, 5, x, 0.2, 0.7), fractal_value(spec, 5, x + 1, 0.2, 0.7), 1e-9);
      EXPECT_NEAR(fractal_value(spec, 5, 0.3, x, 0.7), fractal_value(spec, 5, 0.3, x - 1, 0.7), 1e-9);
      EXPECT_NEAR(fractal_value(spec, 5, 0.3, 0.6, x), fractal_value(spec, 5, 0.3, 0.6, x + 2), 1e-9);
    }
}

TEST(Fractal, PerlinVanishesOnTheLattice) {
  // Gradient noise is zero at every lattice point of every octave (Perlin 1985).
  EXPECT_NEAR(fractal_value(perlin_spec, 3, 0.25, 0.5, 0.75), 0.0, 1e-12);
}

TEST(Texture, SpansZeroToOneAndQuantisesWithinHalfAStep) {
  constexpr int n = 16;
  const Texture3D t = bake(perlin_spec, 11, n);
  float lo = 1, hi = 0;
  double raw_lo = 1e9, raw_hi = -1e9;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        lo = std::min(lo, t.voxel(i, j, k));
        hi = std::max(hi, t.voxel(i, j, k));
        const double r = fractal_value(perlin_spec, 11, i / 16.0, j / 16.0, k / 16.0);
        raw_lo = std::min(raw_lo, r);
        raw_hi = std::max(raw_hi, r);
      }
  EXPECT_EQ(lo, 0.0f);
  EXPECT_EQ(hi, 1.0f);
  // The 8-bit value differs from the exact normalised fractal by at most half a step
  // (0.5/255) plus float rounding of the normalisation (~1e-7).
  for (int q = 0; q < 200; ++q) {
    const int i = q % n, j = (q * 7) % n, k = (q * 13) % n;
    const double exact = (fractal_value(perlin_spec, 11, i / 16.0, j / 16.0, k / 16.0) - raw_lo) / (raw_hi - raw_lo);
    EXPECT_NEAR(t.voxel(i, j, k), exact, 0.5 / 255 + 2e-7);
  }
}

TEST(Texture, BakeEqualsThePointEvaluationAtEveryVoxel) {
  // bake() evaluates a row at a time (lattice-cell runs, vectorised); fractal_value() one point
  // at a time. Every texel must be the point value normalised and rounded as bake() documents,
  // exactly. Three base cells make runs of unequal length (16 voxels over 3, 6, 12 cells).
  constexpr int n = 16;
  for (const FractalSpec& spec : {perlin_spec, worley_spec, FractalSpec{FractalKind::perlin, 3, 3, 0.6, false},
                                  FractalSpec{FractalKind::worley, 3, 2, 0.45, true}}) {
    const Texture3D t = bake(spec, 21, n);
    std::vector<float> raw;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
          raw.push_back(static_cast<float>(fractal_value(spec, 21, i * (1.0 / n), j * (1.0 / n), k * (1.0 / n))));
    const auto [lo, hi] = std::minmax_element(raw.begin(), raw.end());
    const float span = std::max(*hi - *lo, 1e-30f);
    int mismatches = 0;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          float v = (raw[(static_cast<std::size_t>(k) * n + j) * n + i] - *lo) / span;
          if (spec.invert) v = 1.0f - v;
          mismatches += t.data()[t.index(i, j, k)] != std::lround(v * Texture3D::texel_max);
        }
    EXPECT_EQ(mismatches, 0) << "kind " << static_cast<int>(spec.kind) << ", " << spec.base_cells << " base cells";
  }
}

TEST(Texture, TrilinearSamplingHitsVoxelsAndWraps) {
  const Texture3D t = bake(worley_spec, 2, 16);
  EXPECT_FLOAT_EQ(t.sample(3 / 16.0f, 5 / 16.0f, 7 / 16.0f), t.voxel(3, 5, 7));
  EXPECT_FLOAT_EQ(t.sample(0.3f, 0.4f, 0.5f), t.sample(1.3f, -0.6f, 2.5f));
  // Halfway between two voxels along x: their mean.
  EXPECT_NEAR(t.sample(3.5f / 16, 5 / 16.0f, 7 / 16.0f), 0.5f * (t.voxel(3, 5, 7) + t.voxel(4, 5, 7)), 1e-6);
  // Across the tile edge: halfway between voxel 15 and voxel 0.
  EXPECT_NEAR(t.sample(15.5f / 16, 0, 0), 0.5f * (t.voxel(15, 0, 0) + t.voxel(0, 0, 0)), 1e-6);
}

TEST(Texture, EveryFootprintLiesInOneCacheLineHoldingItsEightVoxels) {
  // The overlapping-brick layout: for every voxel (i, j, k), the footprint of a lookup inside
  // its cell (the cell from it to its +1 neighbours, wrapping at the tile edge) reads the eight
  // voxels at corner + a + 4 b + 16 c within one 64-byte line, and each is the value of voxel
  // ((i + a) % n, (j + b) % n, (k + c) % n). Sizes from the smallest (two bricks per axis) up,
  // whose last brick wraps past the tile edge by three (n mod 3 = 1) or two (n mod 3 = 2) voxels.
  for (int n : {4, 8, 16, 32}) {
    Texture3D t(n);  // each voxel's own copy written, a value that differs from its neighbours'
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
          t.data()[t.index(i, j, k)] = static_cast<Texture3D::Texel>((i + 5 * j + 37 * k) % 251);
    t.update_bounds();  // fills the aprons
    EXPECT_EQ(t.bytes(), std::size_t{64} * ((n + 2) / 3) * ((n + 2) / 3) * ((n + 2) / 3));
    const auto line = [&](std::size_t offset) { return (reinterpret_cast<std::uintptr_t>(t.data()) + offset) / 64; };
    int wrong = 0;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const float inv = 1.0f / static_cast<float>(n);
          const Texture3D::Footprint f =
              t.footprint((static_cast<float>(i) + 0.5f) * inv, (static_cast<float>(j) + 0.5f) * inv,
                          (static_cast<float>(k) + 0.5f) * inv);
          wrong += f.corner != t.index(i, j, k);
          wrong += line(f.corner) != line(f.corner + 21);
          for (int c = 0; c < 8; ++c) {
            const int a = c & 1, b = (c >> 1) & 1, d = c >> 2;
            wrong += t.data()[f.corner + static_cast<std::uint32_t>(a + 4 * b + 16 * d)] !=
                     t.data()[t.index((i + a) % n, (j + b) % n, (k + d) % n)];
          }
        }
    EXPECT_EQ(wrong, 0) << "n = " << n;
  }
}

TEST(Texture, TrilinearSampleIsTheEightVoxelBlend) {
  // Anywhere in the tile (the wrap included), sample() is the trilinear blend of its eight
  // voxels, computed here in double from voxel(): each voxel's weight is the product of (1 - f)
  // or f per axis. Tolerance 1e-6: float rounding of seven interpolations of values in [0, 1]
  // (~6e-8 each), well below one quantisation step (1/255 = 4e-3).
  const Texture3D t = bake(perlin_spec, 5, 16);
  for (std::uint64_t s = 0; s < 200; ++s) {
    const float u = static_cast<float>(uniform01(7, s, 0, 0)), v = static_cast<float>(uniform01(7, s, 1, 0)),
                w = static_cast<float>(uniform01(7, s, 2, 0));
    const float x = u * 16, y = v * 16, z = w * 16;
    const int i = static_cast<int>(x), j = static_cast<int>(y), k = static_cast<int>(z);
    const double fx = x - static_cast<float>(i), fy = y - static_cast<float>(j), fz = z - static_cast<float>(k);
    double expected = 0;
    for (int c = 0; c < 8; ++c) {
      const int di = c & 1, dj = (c >> 1) & 1, dk = c >> 2;
      expected += (di ? fx : 1 - fx) * (dj ? fy : 1 - fy) * (dk ? fz : 1 - fz) *
                  t.voxel((i + di) % 16, (j + dj) % 16, (k + dk) % 16);
    }
    EXPECT_NEAR(t.sample(u, v, w), expected, 1e-6) << "at (" << u << ", " << v << ", " << w << ")";
  }
}

TEST(Texture, SampleGradientIsTheTrilinearInterpolantsDerivative) {
  // Inside a voxel the trilinear interpolant is linear along each axis, so a central
  // difference that stays in the voxel is its exact derivative (up to float rounding: the
  // step is 1/8 voxel, values ~1, float epsilon 6e-8 -> ~1e-5 of a voxel's slope of ~n).
  const Texture3D t = bake(perlin_spec, 5, 16);
  for (int s = 0; s < 200; ++s) {
    const auto u = static_cast<std::uint64_t>(s);
    // A point at least 1/4 voxel from every voxel face.
    auto coord = [&](int axis) {
      const double cell = std::floor(uniform01(21, u, static_cast<std::uint64_t>(axis)) * 16);
      return static_cast<float>((cell + 0.25 + 0.5 * uniform01(22, u, static_cast<std::uint64_t>(axis))) / 16);
    };
    const float x = coord(0), y = coord(1), z = coord(2), d = 1.0f / 128;  // 1/8 voxel
    const Texture3D::ValueGradient g = t.sample_gradient(t.footprint(x, y, z));
    EXPECT_NEAR(g.value, t.sample(x, y, z), 1e-6);  // the same interpolation (contraction may differ)
    EXPECT_NEAR(g.du, (t.sample(x + d, y, z) - t.sample(x - d, y, z)) / (2 * d), 2e-3);
    EXPECT_NEAR(g.dv, (t.sample(x, y + d, z) - t.sample(x, y - d, z)) / (2 * d), 2e-3);
    EXPECT_NEAR(g.dw, (t.sample(x, y, z + d) - t.sample(x, y, z - d)) / (2 * d), 2e-3);
  }
}

TEST(Texture, DeterministicAcrossThreadsAndSeedDependent) {
  set_threads(1);
  const Texture3D a = bake(perlin_spec, 9, 32);
  set_threads(2);
  const Texture3D b = bake(perlin_spec, 9, 32);
  const Texture3D c = bake(perlin_spec, 10, 32);
  set_threads(0);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.bytes()), 0);
  EXPECT_NE(std::memcmp(a.data(), c.data(), a.bytes()), 0);
}

TEST(Texture, BlockBoundsContainEverySampleInTheBlock) {
  // The bounds that let ray marching skip texture fetches must hold for every lookup: compare
  // against samples at 200,000 hashed positions (including the tile's wrap-around blocks) and
  // against the voxels themselves, whose extremes the bounds may exceed by 1e-6 only.
  const Texture3D t = bake(perlin_spec, 4, 32);
  float lo_seen = 1, hi_seen = 0;
  for (std::uint64_t i = 0; i < 200000; ++i) {
    const auto f = t.footprint(static_cast<float>(uniform01(8, i, 0)), static_cast<float>(uniform01(8, i, 1)),
                               static_cast<float>(uniform01(8, i, 2)));
    const float v = t.sample(f);
    const Texture3D::Bounds b = t.bounds(f);
    ASSERT_LE(b.lo, v) << i;
    ASSERT_GE(b.hi, v) << i;
    lo_seen = std::min(lo_seen, b.lo);
    hi_seen = std::max(hi_seen, b.hi);
  }
  // The texture spans [0, 1], so some block holds each extreme (to the 1e-6 widening).
  EXPECT_NEAR(lo_seen, 0.0f, 2e-6);
  EXPECT_NEAR(hi_seen, 1.0f, 2e-6);
  // Bounds are local, which is what lets them decide samples: on a 128^3 bake of the fine
  // cloud fractal (8 base cells, 4 octaves) the bounds grid has 64 blocks per axis, each
  // spanning 3 of 128 voxels with its margin, and a block's range, averaged over all blocks,
  // is well under the texture's range of 1.
  const Texture3D fine = bake(FractalSpec{FractalKind::perlin, 8, 4, 0.55, false}, 5, 128);
  double range_sum = 0;
  int blocks = 0;
  ASSERT_EQ(fine.block_size(), 2);
  for (int k = 0; k < 128; k += 2)
    for (int j = 0; j < 128; j += 2)
      for (int i = 0; i < 128; i += 2, ++blocks) {
        const Texture3D::Bounds b = fine.bounds(
            fine.footprint(static_cast<float>(i) / 128, static_cast<float>(j) / 128, static_cast<float>(k) / 128));
        range_sum += b.hi - b.lo;
      }
  EXPECT_LT(range_sum / blocks, 0.25);  // measured 0.16 (0.27 with 32 blocks per axis)
}

TEST(MipPyramid, LevelsAreBlockMeansAndTheirVarianceFollowsTheLawOfTotalVariance) {
  // Each level's voxel is the mean of its 2 x 2 x 2 block of the level below, rounded to a texel
  // (at most half a texel, 0.002, off). The variance a level loses is the mean variance within
  // its blocks (law of total variance: var = E[var | block] + var[E | block]), computed here
  // from the voxels directly; equal to the rounding's share, at most (0.5/255)^2 + 2 x 0.002 x
  // the block means' spread, 0.001. Down to 4^3, then the mean level (no variance left). Fault
  // caught: a pyramid averaging 2 x 2 x 1 blocks (lost variance 0.4x the within-block one).
  const Texture3D t = bake(perlin_spec, 9, 32);
  const MipPyramid m = MipPyramid::of(t);
  ASSERT_EQ(m.levels.size(), 3u);  // 16, 8, 4
  ASSERT_EQ(m.stats.size(), 5u);
  EXPECT_EQ(m.levels.back().size(), 4);
  EXPECT_EQ(m.stats.back().variance, 0.0);
  EXPECT_NEAR(m.stats.back().mean, m.stats[0].mean, 1e-12);
  const Texture3D* below = &t;
  for (std::size_t l = 0; l < m.levels.size(); ++l) {
    const Texture3D& lv = m.levels[l];
    double within = 0;
    for (int k = 0; k < lv.size(); ++k)
      for (int j = 0; j < lv.size(); ++j)
        for (int i = 0; i < lv.size(); ++i) {
          double sum = 0, sum2 = 0;
          for (int c = 0; c < 8; ++c) {
            const double v = below->voxel(2 * i + (c & 1), 2 * j + ((c >> 1) & 1), 2 * k + (c >> 2));
            sum += v, sum2 += v * v;
          }
          ASSERT_NEAR(lv.voxel(i, j, k), sum / 8, 0.5 / 255 + 1e-6) << l << " " << i << " " << j << " " << k;
          within += sum2 / 8 - (sum / 8) * (sum / 8);
        }
    within /= static_cast<double>(lv.size()) * lv.size() * lv.size();
    EXPECT_NEAR(m.stats[l].variance - m.stats[l + 1].variance, within, 1e-3) << "level " << l + 1;
    EXPECT_GT(within, 1e-4);
    below = &lv;
  }
}

TEST(Texture, RejectsBadSizes) {
  EXPECT_THROW(bake(perlin_spec, 1, 100), ValueError);
  EXPECT_THROW(bake(FractalSpec{FractalKind::perlin, 8, 4, 0.5, false}, 1, 32), ValueError);  // 64 cells > 32
}

}  // namespace nephos::noise
