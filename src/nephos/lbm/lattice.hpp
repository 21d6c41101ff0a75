#pragma once
// Lattice geometry and population storage shared by the lattice-Boltzmann solvers.
//
// Layout (after FluidX3D's structure of arrays): population i of cell n at f[i * stride + n]
// (stride = Grid3::direction_stride(), the cell count padded; see there), cells ordered x
// fastest, then y, then z (z is up). Two copies (A/B) for pull streaming: a
// step reads A at x - c_i and writes B at x, so each population is read once and written once
// per cell update: 19 * 4 B * 2 = 152 bytes per cell per component in FP32.
// Populations are stored shifted by their rest value w_i rho_ref (d3q19::equilibrium_shifted).
// Boundaries: periodic in x and y; in z periodic or walls (halfway bounce-back: a population
// that would come from outside is the opposite population of the same cell).
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#if defined(__AVX512F__) || defined(__AVX__)
#include <immintrin.h>
#endif

#include "nephos/lbm/d3q19.hpp"

namespace nephos::lbm {

struct Grid3 {
  int nx = 0, ny = 0, nz = 0;
  std::size_t cells() const { return static_cast<std::size_t>(nx) * ny * nz; }
  std::size_t index(int x, int y, int z) const { return (static_cast<std::size_t>(z) * ny + y) * nx + x; }
  /// Elements from one direction's populations to the next in a direction-major array: the
  /// cell count rounded up to 32768 (64 KiB of FP16, 128 KiB of FP32: a whole number of L2 set
  /// spans, 64 KiB on a 512 KiB 8-way L2), plus 864. Without padding every direction of a
  /// power-of-two lattice starts at the same offset modulo 4 KiB, so the 19 pulled and the 19
  /// written rows of a step fall into the same L1 and L2 sets and evict each other
  /// (docs/PERFORMANCE.md, design choices). With 864, direction i
  /// starts i x 54 cache lines (FP32) or i x 27 (FP16) past a 64 KiB boundary: the directions'
  /// rows spread evenly over the L2 sets (and fall into distinct L1 sets), so the rows the water
  /// model's pass 1 pulls stay in L2 until its pass 2 pulls them again (FP16: 84 % L2 hits in a
  /// cache simulation of the wavefront, against 0.5 % with 32 elements of padding, which
  /// started the 19 directions within 38 (FP32) or 19 (FP16) consecutive sets; docs/lbm.md).
  std::size_t direction_stride() const { return (cells() + 32767) / 32768 * 32768 + 864; }
  /// Elements of a direction-major array of q directions (padding included, left zero).
  std::size_t population_size(int q) const { return static_cast<std::size_t>(q) * direction_stride(); }
  bool operator==(const Grid3&) const = default;
  /// "NXxNYxNZ"
  std::string describe() const;
  /// Parses "NXxNYxNZ" (each 4..4096); ValueError otherwise.
  static Grid3 parse(const std::string& text);
};

enum class ZBoundary { periodic, walls };

/// The pull-streaming sources of one row: per direction i, the source row of population i
/// (element x is the source of cell x, except where the row wraps around x; see at() and
/// periodic_span()). T is the storage type of the populations (float or FP16 bits).
template <class T>
struct RowSourcesOf {
  std::array<const T*, d3q19::q> row{};  ///< source row start for direction i
  std::array<int, d3q19::q> shift{};     ///< source x = x - shift[i] (0 for bounce-back)
  int nx = 0;
  const T* at(int i, int x) const {
    int sx = x - shift[static_cast<std::size_t>(i)];
    sx = sx < 0 ? sx + nx : (sx >= nx ? sx - nx : sx);
    return row[static_cast<std::size_t>(i)] + sx;
  }
};
using RowSources = RowSourcesOf<float>;

/// The pull-streaming sources of row (y, z) for populations stored in `f` (direction-major,
/// f[i * g.direction_stride() + cell]).
template <class T>
RowSourcesOf<T> row_sources(const Grid3& g, const T* f, int y, int z, ZBoundary zb) {
  RowSourcesOf<T> r;
  r.nx = g.nx;
  const std::size_t stride = g.direction_stride();
  for (int i = 0; i < d3q19::q; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    // y in [0, ny), |c| <= 1: one conditional wrap (no integer division on this per-row path).
    int sy = y - d3q19::cy[iu], sz = z - d3q19::cz[iu];
    sy = sy < 0 ? sy + g.ny : (sy >= g.ny ? sy - g.ny : sy);
    if (zb == ZBoundary::periodic) {
      sz = sz < 0 ? sz + g.nz : (sz >= g.nz ? sz - g.nz : sz);
    } else if (sz < 0 || sz >= g.nz) {  // halfway bounce-back at the wall
      r.row[iu] = f + static_cast<std::size_t>(d3q19::opposite[iu]) * stride + g.index(0, y, z);
      r.shift[iu] = 0;
      continue;
    }
    r.row[iu] = f + iu * stride + g.index(0, sy, sz);
    r.shift[iu] = d3q19::cx[iu];
  }
  return r;
}

/// Cells per chunk in the register-resident kernels: one 64-byte line of a population row.
/// A chunk's populations, moments and equilibria stay in vector registers, written per cell in
/// an `omp simd` loop over the chunk.
inline constexpr int chunk_cells = 16;

/// The contiguous pieces of the span row[first + l], l < count <= nx, of a row periodic in x
/// (nx values, -1 <= first <= nx - count + 1): calls piece(source index, destination index,
/// length) once where the span lies inside the row, twice where it wraps around an end.
template <class Piece>
inline void periodic_pieces(int nx, int first, int count, Piece&& piece) {
  if (first >= 0 && first + count <= nx) {
    piece(first, 0, count);
  } else if (first < 0) {  // first == -1: the row's last value, then its head
    piece(nx - 1, 0, 1);
    piece(0, 1, count - 1);
  } else {  // the span runs past the row's end by one: its tail, then the row's first value
    const int k = nx - first;
    piece(first, 0, k);
    piece(0, k, count - k);
  }
}

/// Where a span of a periodic row wraps around an end (see periodic_pieces()), writes its
/// `count` values to edge[0..count) with whole-vector stores only, and returns true; returns
/// false (nothing written) where this path does not apply: without AVX2, or unless count is a
/// multiple of 8 and nx >= 8. load8(k) gives the 8 row values k .. k + 7 as floats
/// (0 <= k <= nx - 8). Why: the lanes copied piece by piece (a lone value, then the rest)
/// were written by stores of other sizes and offsets than the vector loads that read them next,
/// which stalls those loads (no store-to-load forwarding).
template <class Load8>
inline bool wrap_span_vectors([[maybe_unused]] int nx, [[maybe_unused]] int first, [[maybe_unused]] int count,
                              [[maybe_unused]] float* edge, [[maybe_unused]] Load8&& load8) {
#if defined(__AVX2__)
  if (count % 8 != 0 || count < 8 || nx < 8) return false;
  if (first < 0) {  // first == -1: row[nx - 1], row[0], ..., row[count - 2]
    const __m256 head = _mm256_permutevar8x32_ps(load8(0), _mm256_setr_epi32(7, 0, 1, 2, 3, 4, 5, 6));
    const __m256 last = _mm256_permutevar8x32_ps(load8(nx - 8), _mm256_set1_epi32(7));
    _mm256_storeu_ps(edge, _mm256_blend_ps(head, last, 0x01));
    for (int k = 8; k < count; k += 8) _mm256_storeu_ps(edge + k, load8(k - 1));
  } else {  // first == nx - count + 1: row[first], ..., row[nx - 1], row[0]
    for (int k = 0; k + 8 < count; k += 8) _mm256_storeu_ps(edge + k, load8(first + k));
    const __m256 tail = _mm256_permutevar8x32_ps(load8(nx - 8), _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 0));
    const __m256 row0 = _mm256_permutevar8x32_ps(load8(0), _mm256_set1_epi32(0));
    _mm256_storeu_ps(edge + count - 8, _mm256_blend_ps(tail, row0, 0x80));
  }
  return true;
#else
  return false;
#endif
}

/// The `count` values row[x0 + offset + l], l < count <= nx, of a row periodic in x
/// (nx values, |offset| <= 1): a pointer into the row, or, where the span wraps around the row's
/// ends, into `edge` after copying them there.
inline const float* periodic_span(const float* row, int nx, int x0, int offset, int count, float* edge) {
  const int first = x0 + offset;
  if (first >= 0 && first + count <= nx) return row + first;
#if defined(__AVX__)
  if (wrap_span_vectors(nx, first, count, edge, [row](int k) { return _mm256_loadu_ps(row + k); })) return edge;
#endif
  periodic_pieces(nx, first, count, [&](int src, int dst, int n) {
    std::memcpy(edge + dst, row + src, static_cast<std::size_t>(n) * sizeof(float));
  });
  return edge;
}

/// Copies n floats to dst with non-temporal (streaming) stores where the CPU has them and dst
/// is 64-byte aligned: the destination lines are written whole without first being read
/// ("write-allocate"), which would otherwise add half again to the memory traffic of a
/// streaming step (228 instead of 152 B per D3Q19 cell). Call stream_fence() before other
/// threads read dst. Plain copy otherwise; the values written are the same either way.
inline void store_streaming(float* dst, const float* src, std::size_t n) {
#if defined(__AVX512F__)
  if ((reinterpret_cast<std::uintptr_t>(dst) & 63) == 0 && n % 16 == 0) {
    for (std::size_t k = 0; k < n; k += 16) _mm512_stream_ps(dst + k, _mm512_loadu_ps(src + k));
    return;
  }
#elif defined(__AVX__)
  if ((reinterpret_cast<std::uintptr_t>(dst) & 31) == 0 && n % 8 == 0) {
    for (std::size_t k = 0; k < n; k += 8) _mm256_stream_ps(dst + k, _mm256_loadu_ps(src + k));
    return;
  }
#endif
  std::memcpy(dst, src, n * sizeof(float));
}
/// Orders this thread's streaming stores before anything it does next.
inline void stream_fence() {
#if defined(__AVX512F__) || defined(__AVX__)
  _mm_sfence();
#endif
}

}  // namespace nephos::lbm
