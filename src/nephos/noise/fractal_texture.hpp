#pragma once
// Tileable 3D fractal textures (the fractal-cloud paper, section 2.1): Perlin gradient-noise fractals and an
// inverted Worley (cellular) fractal, baked once per seed into an N^3 grid of 8-bit values in
// [0, 1] and sampled with periodic trilinear interpolation. 8-bit storage quarters the memory
// of float (three 256^3 textures: 48 MiB of voxels instead of 192) at a quantisation error of at most
// 0.5/255 = 0.002 per voxel (tested); in the cloud function, whose fractal weights sum to 1,
// the error is at most 0.002, a shift of the cloud surface by 0.2 % of the fractal range.
// 8 bits rather than 16 keep more of the texture set in the L3 cache, which random lookups
// reward (docs/PERFORMANCE.md, design choices).
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>
#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "nephos/core/huge_page_allocator.hpp"

namespace nephos::noise {

enum class FractalKind { perlin, worley };

struct FractalSpec {
  FractalKind kind = FractalKind::perlin;
  int base_cells = 4;        ///< lattice cells across the tile at the first octave (tileable: integer)
  int octaves = 4;           ///< each octave doubles the cell count
  double persistence = 0.5;  ///< amplitude factor from one octave to the next
  bool invert = false;       ///< 1 - value (Worley: bright cell centres, dark borders)
};

/// A periodic N x N x N texture of values in [0, 1], stored as uint8 in overlapping bricks of
/// 4 x 4 x 4 voxels (64 bytes: one cache line): brick (bx, by, bz) holds voxels 3 bx .. 3 bx + 3
/// along x (periodically), and likewise along y and z, so neighbouring bricks share a plane of
/// voxels (an apron). Whatever the lookup point, the eight voxels of its trilinear footprint lie
/// in one brick, so a lookup reads exactly one cache line, against 1.95 on average for disjoint
/// 4^3 bricks and 4 rows of a linear layout: at kilometre pixel spacing every lookup misses the
/// caches (docs/PERFORMANCE.md, design choices). The price is memory:
/// ceil(N/3)^3 bricks, about (4/3)^3 = 2.37 times N^3 bytes (39 MiB at 256^3, 4.9 MiB at 128^3).
class Texture3D {
 public:
  using Texel = std::uint8_t;                 ///< storage type of a voxel
  static constexpr float texel_max = 255.0f;  ///< the stored value of 1.0
  static_assert(sizeof(Texel) == 1, "the block bounds pack a block's min and max texel in 16 bits");
  Texture3D() = default;
  explicit Texture3D(int n) : n_(checked_size(n)), nb_((static_cast<unsigned>(n) + 2) / 3), data_(bytes_for(n)) {}
  int size() const { return n_; }
  /// Bytes of voxel storage (the bricks, aprons included).
  std::size_t bytes() const { return data_.size() * sizeof(Texel); }
  /// bytes() of an n^3 texture: ceil(n/3)^3 bricks of 64 bytes.
  static std::size_t bytes_for(int n) {
    const std::size_t nb = (static_cast<std::size_t>(n) + 2) / 3;
    return 64 * nb * nb * nb;
  }

  /// What locating a voxel reads of a texture: its size, bricks per axis and bounds blocks, so
  /// that one loop can locate points in textures of several sizes (a mip pyramid's levels).
  struct Addressing {
    float fn;              ///< n
    unsigned mask;         ///< n - 1 (n is a power of two)
    unsigned nb;           ///< bricks per axis: ceil(n / 3)
    unsigned block_shift;  ///< log2(voxels per bounds block edge)
    unsigned blocks;       ///< bounds blocks per axis: n >> block_shift
  };
  Addressing addressing() const {
    return {static_cast<float>(n_), static_cast<unsigned>(n_ - 1), nb_, block_shift_,
            static_cast<unsigned>(n_) >> block_shift_};
  }

  /// Offset in data() of voxel (i, j, k)'s own copy (in brick (i/3, j/3, k/3); the apron of the
  /// brick before holds another): the sum of one part per axis, nb bricks per axis.
  static std::uint32_t offset_x(unsigned i) { return (i / 3u) * 64u + i % 3u; }
  static std::uint32_t offset_y(unsigned j, unsigned nb) { return (j / 3u) * 64u * nb + (j % 3u) * 4u; }
  static std::uint32_t offset_z(unsigned k, unsigned nb) { return (k / 3u) * 64u * nb * nb + (k % 3u) * 16u; }
  std::uint32_t offset_y(unsigned j) const { return offset_y(j, nb_); }
  std::uint32_t offset_z(unsigned k) const { return offset_z(k, nb_); }
  std::size_t index(int i, int j, int k) const {
    return std::size_t{offset_x(static_cast<unsigned>(i))} + offset_y(static_cast<unsigned>(j)) +
           offset_z(static_cast<unsigned>(k));
  }

  /// The voxels and weights one trilinear lookup uses: computed once (in vectorised loops over
  /// many points), then used for the block bounds and the sample. Voxel (x0 + a, y0 + b, z0 + c)
  /// of the footprint, a, b, c in {0, 1}, is at data()[corner + a + 4 b + 16 c], in one brick.
  struct Footprint {
    std::uint32_t corner;  ///< offset of voxel (x0, y0, z0): index(x0, y0, z0)
    std::uint32_t block;   ///< index into the block bounds (see bounds())
    float tx, ty, tz;
  };
  /// Footprint at texture coordinates (u, v, w) in tile units: 1.0 = one tile; any real value
  /// wraps periodically.
  Footprint footprint(float u, float v, float w) const { return footprint(addressing(), u, v, w); }
  /// footprint() in the texture `a` addresses.
  static Footprint footprint(const Addressing& a, float u, float v, float w) {
    const float x = u * a.fn, y = v * a.fn, z = w * a.fn;
    const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
    const unsigned x0 = static_cast<unsigned>(static_cast<int>(fx)) & a.mask;
    const unsigned y0 = static_cast<unsigned>(static_cast<int>(fy)) & a.mask;
    const unsigned z0 = static_cast<unsigned>(static_cast<int>(fz)) & a.mask;
    const unsigned block =
        ((z0 >> a.block_shift) * a.blocks + (y0 >> a.block_shift)) * a.blocks + (x0 >> a.block_shift);
    return {offset_x(x0) + offset_y(y0, a.nb) + offset_z(z0, a.nb), block, x - fx, y - fy, z - fz};
  }
  /// Blocks per axis of the bounds grid: 64 (a 512 KiB table whatever the texture size; 4^3
  /// voxels per block at 256^3). Against 32 (8^3 voxels), the tighter bounds decide 24 % more
  /// of a GEO frame's samples without a texture fetch.
  static constexpr int bounds_grid = 64;
  /// Voxels per block edge: max(1, n / 64).
  int block_size() const { return 1 << block_shift_; }
  struct Bounds {
    float lo, hi;
  };
  /// Bounds of sample(f) for every f in the same block: the minimum and maximum voxel over the
  /// block grown by one voxel (the trilinear footprint's reach), widened by 1e-6 against the
  /// rounding of the interpolation. The bounds grid (at most 64^3 blocks, 512 KiB) stays in the
  /// L2/L3 caches, so it decides most samples without the texture's cache misses.
  Bounds bounds(const Footprint& f) const { return block_bounds(f.block); }
  /// bounds() of every footprint in block `block` (Footprint::block).
  Bounds block_bounds(std::uint32_t block) const { return bounds_from(block_word(block)); }
  /// The packed bounds of block `block`: min in the low byte, max in the high byte. Batched
  /// lookups load these in a scalar loop and unpack them (bounds_from()) in a vectorised one:
  /// the vectorised loads would be gathers, slower than scalar loads on common x86-64 cores.
  std::uint16_t block_word(std::uint32_t block) const { return block_bounds_[block]; }
  /// The bounds a packed word holds.
  static Bounds bounds_from(unsigned word) {
    return {static_cast<float>(word & 0xffu) * (1.0f / texel_max) - 1e-6f,
            static_cast<float>(word >> 8) * (1.0f / texel_max) + 1e-6f};
  }
  /// Starts loading block_bounds(block)'s cache line.
  void prefetch_bounds(std::uint32_t block) const { __builtin_prefetch(block_bounds_.data() + block); }
  /// Copies every voxel into the aprons of the bricks that share it, then recomputes the block
  /// bounds: call after writing each voxel's own copy (data()[index(i, j, k)]; bake() does).
  void update_bounds();
  /// Starts loading the one cache line sample(f) reads. A pass of these ahead of a pass of
  /// sample() keeps more misses in flight than the sample loop alone, whose longer iterations
  /// fill the core's reorder window.
  void prefetch(const Footprint& f) const { __builtin_prefetch(data_.data() + f.corner); }
  /// Trilinear value at footprint `f`, in [0, 1].
  float sample(const Footprint& f) const {
    const Texel* d = data_.data();
#if defined(__AVX2__) && defined(__FMA__)
    // The eight voxels in one vector (x0 in lanes 0-3, x1 in 4-7; rows y0z0, y1z0, y0z1, y1z1):
    // planes z0 and z0 + 1 of the brick (16 bytes each, the first at a multiple of 16 within the
    // line) in one 32-byte load, one byte shuffle per 128-bit lane taking (y, x) at o, o + 1,
    // o + 4, o + 5 of its plane, the lanes merged. Then the interpolation four, two, then one
    // lane at a time with the scalar form's arithmetic, fused the same way (bit-identical), in
    // fewer instructions (docs/PERFORMANCE.md, design choices).
    const __m256i planes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(d + (f.corner & ~15u)));
    constexpr char z = -128;  // pshufb: a set high bit writes zero (o <= 10 keeps it set)
    const __m256i pick = _mm256_add_epi8(_mm256_set1_epi8(static_cast<char>(f.corner & 15u)),
                                         _mm256_setr_epi8(0, 4, z, z, 1, 5, z, z, z, z, z, z, z, z, z, z,  //
                                                          z, z, 0, 4, z, z, 1, 5, z, z, z, z, z, z, z, z));
    const __m256i picked = _mm256_shuffle_epi8(planes, pick);
    const __m128i v = _mm_or_si128(_mm256_castsi256_si128(picked), _mm256_extracti128_si256(picked, 1));
    const __m256 ab = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(v));
    const __m128 a = _mm256_castps256_ps128(ab), b = _mm256_extractf128_ps(ab, 1);
    const __m128 c = _mm_fmadd_ps(_mm_sub_ps(b, a), _mm_set1_ps(f.tx), a);  // c00 c10 c01 c11
    const __m128 lo = _mm_shuffle_ps(c, c, _MM_SHUFFLE(2, 2, 2, 0)), hi = _mm_shuffle_ps(c, c, _MM_SHUFFLE(3, 3, 3, 1));
    const __m128 c01 = _mm_fmadd_ps(_mm_sub_ps(hi, lo), _mm_set1_ps(f.ty), lo);  // c0, c1
    const float c0 = _mm_cvtss_f32(c01), c1 = _mm_cvtss_f32(_mm_movehdup_ps(c01));
    return std::fma(c1 - c0, f.tz, c0) * (1.0f / texel_max);
#else
    auto row = [&](std::uint32_t yz) {
      const float a = static_cast<float>(d[yz]), b = static_cast<float>(d[yz + 1]);
      return a + f.tx * (b - a);
    };
    const std::uint32_t o = f.corner;
    const float c00 = row(o), c10 = row(o + 4), c01 = row(o + 16), c11 = row(o + 20);
    const float c0 = c00 + f.ty * (c10 - c00), c1 = c01 + f.ty * (c11 - c01);
    return (c0 + f.tz * (c1 - c0)) * (1.0f / texel_max);
#endif
  }
  /// sample(f) and its gradient in tile units (d/du, d/dv, d/dw of the trilinear interpolant,
  /// 1.0 = one tile), from the same eight voxels: the derivative along each axis is the
  /// difference of the two voxel planes, interpolated in the other two axes.
  struct ValueGradient {
    float value, du, dv, dw;
  };
  ValueGradient sample_gradient(const Footprint& f) const {
    const Texel* d = data_.data();
    struct Row {
      float value, dx;
    };
    auto row = [&](std::uint32_t yz) {
      const float a = static_cast<float>(d[yz]), b = static_cast<float>(d[yz + 1]);
      return Row{a + f.tx * (b - a), b - a};
    };
    const std::uint32_t o = f.corner;
    const Row r00 = row(o), r10 = row(o + 4), r01 = row(o + 16), r11 = row(o + 20);
    const float c0 = r00.value + f.ty * (r10.value - r00.value), c1 = r01.value + f.ty * (r11.value - r01.value);
    const float dx0 = r00.dx + f.ty * (r10.dx - r00.dx), dx1 = r01.dx + f.ty * (r11.dx - r01.dx);
    const float dy0 = r10.value - r00.value, dy1 = r11.value - r01.value;
    const float scale = static_cast<float>(n_) / texel_max;  // per voxel and per texel level -> per tile
    return {(c0 + f.tz * (c1 - c0)) * (1.0f / texel_max), (dx0 + f.tz * (dx1 - dx0)) * scale,
            (dy0 + f.tz * (dy1 - dy0)) * scale, (c1 - c0) * scale};
  }
  /// Trilinear value at texture coordinates (u, v, w) (see footprint()).
  float sample(float u, float v, float w) const { return sample(footprint(u, v, w)); }
  /// Value of voxel (i, j, k) in [0, 1].
  float voxel(int i, int j, int k) const { return data_[index(i, j, k)] * (1.0f / texel_max); }
  /// The bricks (see the class comment); voxel (i, j, k)'s own copy at index(i, j, k).
  Texel* data() { return data_.data(); }
  const Texel* data() const { return data_.data(); }

 private:
  [[noreturn]] static void throw_bad_size(int n);
  static int checked_size(int n) {
    if (n < 4 || (n & (n - 1)) != 0) throw_bad_size(n);
    return n;
  }
  int n_ = 0;
  unsigned nb_ = 0;                                                         // bricks per axis: ceil(n / 3)
  std::vector<Texel, HugePageAllocator<Texel>> data_;                       // random access: huge pages
  std::vector<std::uint16_t, TableAllocator<std::uint16_t>> block_bounds_;  // min | max << 8 per block
  unsigned block_shift_ = 0;                                                // log2(voxels per block edge)
};

/// Unquantised fractal value at a point of the unit tile (x, y, z in [0, 1)), before the
/// texture-wide normalisation; periodic with period 1 in each axis.
double fractal_value(const FractalSpec& spec, std::uint64_t seed, double x, double y, double z);

/// Bakes `spec` into an n^3 texture (n a power of two, >= 8), normalised so that its minimum
/// maps to 0 and maximum to 1. Deterministic from `seed` for any thread count.
Texture3D bake(const FractalSpec& spec, std::uint64_t seed, int n);

/// The statistics of a texture's voxels, each in [0, 1] (variance in [0, 1]^2), and
/// `gradient`: the mean squared difference between neighbouring voxels, summed over the three
/// axes (periodic), the mean squared gradient of its interpolant in [0, 1]^2 per voxel^2.
struct TextureStats {
  double mean = 0, variance = 0, lo = 0, hi = 0, gradient = 0;
};
TextureStats texture_stats(const Texture3D& t);

/// `t` box-filtered to half its size: each voxel the mean of a 2 x 2 x 2 block (rounded to the
/// nearest texel level). Its trilinear samples are the texture's averages over footprints of
/// about two voxels, the next level of a mip pyramid (Williams 1983).
Texture3D half_size(const Texture3D& t);

/// A texture's mip pyramid: level 0 the texture itself (not held), level l (1..) the texture
/// box-filtered l times (n / 2^l voxels, down to 4), and one level past the last, the voxels'
/// mean (a constant). stats[l] are each level's voxel statistics, stats.back() the mean's (its
/// variance 0): the variance a footprint of 2^l voxels averages away is stats[0].variance -
/// stats[l].variance (the law of total variance for the block means).
struct MipPyramid {
  std::vector<Texture3D> levels;    ///< levels 1 .. L (levels[l - 1] is level l)
  std::vector<TextureStats> stats;  ///< levels 0 .. L + 1
  /// The mip pyramid of `t` (n >= 8: at least one level).
  static MipPyramid of(const Texture3D& t);
  /// The level past the last texture: the mean.
  int mean_level() const { return static_cast<int>(levels.size()) + 1; }
};

}  // namespace nephos::noise
