#pragma once
// IEEE 754 binary16 ("half") storage of FP32 values for the lattice kernels' optional 16-bit
// population storage: arithmetic stays in FP32, only memory holds halves, which halves the
// bytes a streaming step moves. Conversions round to nearest, ties to even, the same on every
// path (F16C / AVX-512 instructions where the CPU has them, the portable bit manipulation
// below otherwise), so results do not depend on which path ran.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__F16C__) || defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace nephos::lbm {

// GCC 12 warns that the AVX-512 conversion intrinsics read an uninitialised register (their
// _mm256_undefined operand); the warning is spurious.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

/// The portable conversion, round to nearest even; overflow gives infinity, NaN stays NaN.
inline std::uint16_t float_to_half(float value) {
  const std::uint32_t f = std::bit_cast<std::uint32_t>(value);
  const std::uint32_t sign = (f >> 16) & 0x8000u;
  const std::uint32_t abs = f & 0x7fffffffu;
  if (abs >= 0x7f800000u) return static_cast<std::uint16_t>(sign | 0x7c00u | (abs > 0x7f800000u ? 0x200u : 0u));
  if (abs >= 0x477ff000u) return static_cast<std::uint16_t>(sign | 0x7c00u);  // rounds past 65504: infinity
  if (abs < 0x38800000u) {                                                    // below 2^-14: a subnormal half (or zero)
    if (abs < 0x33000000u) return static_cast<std::uint16_t>(sign);           // below half the smallest subnormal
    const std::uint32_t mant = (abs & 0x7fffffu) | 0x800000u;
    const int shift = 126 - static_cast<int>(abs >> 23);  // 14..24
    const std::uint32_t h = mant >> shift, rem = mant & ((1u << shift) - 1u), halfway = 1u << (shift - 1);
    return static_cast<std::uint16_t>(sign | (h + ((rem > halfway || (rem == halfway && (h & 1u))) ? 1u : 0u)));
  }
  const std::uint32_t h = ((abs >> 13) - (112u << 10)), rem = abs & 0x1fffu;  // rebias 127 -> 15
  return static_cast<std::uint16_t>(sign | (h + ((rem > 0x1000u || (rem == 0x1000u && (h & 1u))) ? 1u : 0u)));
}

inline float half_to_float(std::uint16_t half) {
  const std::uint32_t sign = static_cast<std::uint32_t>(half & 0x8000u) << 16;
  const std::uint32_t exp = (half >> 10) & 0x1fu, mant = half & 0x3ffu;
  if (exp == 0x1fu) return std::bit_cast<float>(sign | 0x7f800000u | (mant << 13));
  if (exp != 0) return std::bit_cast<float>(sign | ((exp + 112u) << 23) | (mant << 13));
  const float m = static_cast<float>(mant) * 0x1p-24f;  // subnormal: mant * 2^-24, exact
  return sign ? -m : m;
}

/// out[l] = float(src[l]) * scale for l < n.
inline void halves_to_floats(const std::uint16_t* src, float* out, int n, float scale) {
  int l = 0;
#if defined(__AVX512F__)
  for (; l + 16 <= n; l += 16)
    _mm512_storeu_ps(out + l,
                     _mm512_mul_ps(_mm512_cvtph_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(src + l))),
                                   _mm512_set1_ps(scale)));
#if defined(__AVX512BW__)
  if (l < n) {  // the remainder by masked load and store, not one by one
    const __mmask16 m = static_cast<__mmask16>((1u << (n - l)) - 1u);
    _mm512_mask_storeu_ps(out + l, m,
                          _mm512_mul_ps(_mm512_cvtph_ps(_mm256_maskz_loadu_epi16(m, src + l)), _mm512_set1_ps(scale)));
    return;
  }
#endif
#elif defined(__F16C__)
  for (; l + 8 <= n; l += 8)
    _mm256_storeu_ps(out + l, _mm256_mul_ps(_mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(src + l))),
                                            _mm256_set1_ps(scale)));
#endif
  for (; l < n; ++l) out[l] = half_to_float(src[l]) * scale;
}

// The vector conversion both writers below use: 16 (AVX-512) or 8 (F16C) floats from src,
// times scale, to halves rounded to nearest even.
#if defined(__AVX512F__)
inline __m256i scaled_halves16(const float* src, __m512 scale) {
  return _mm512_cvtps_ph(_mm512_mul_ps(_mm512_loadu_ps(src), scale), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
}
#elif defined(__F16C__)
inline __m128i scaled_halves8(const float* src, __m256 scale) {
  return _mm256_cvtps_ph(_mm256_mul_ps(_mm256_loadu_ps(src), scale), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
}
#endif

/// dst[l] = half(src[l] * scale) for l < n, with ordinary stores (for values read again soon:
/// MPI halo rows, checkpoints).
inline void floats_to_halves(std::uint16_t* dst, const float* src, int n, float scale) {
  int l = 0;
#if defined(__AVX512F__)
  for (; l + 16 <= n; l += 16)
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst + l), scaled_halves16(src + l, _mm512_set1_ps(scale)));
#elif defined(__F16C__)
  for (; l + 8 <= n; l += 8)
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + l), scaled_halves8(src + l, _mm256_set1_ps(scale)));
#endif
  for (; l < n; ++l) dst[l] = float_to_half(src[l] * scale);
}

/// dst[l] = half(src[l] * scale) for l < n, with streaming (non-temporal) stores where dst is
/// 32-byte aligned and n a multiple of 16 (the rest with ordinary ones); call stream_fence()
/// before other threads read dst.
inline void floats_to_halves_streaming(std::uint16_t* dst, const float* src, int n, float scale) {
  int l = 0;
#if defined(__AVX512F__)
  const __m512 s = _mm512_set1_ps(scale);
  if ((reinterpret_cast<std::uintptr_t>(dst) & 63) == 0)  // whole 64-byte lines, one store each
    for (; l + 32 <= n; l += 32)
      _mm512_stream_si512(
          reinterpret_cast<__m512i*>(dst + l),
          _mm512_inserti64x4(_mm512_castsi256_si512(scaled_halves16(src + l, s)), scaled_halves16(src + l + 16, s), 1));
  if ((reinterpret_cast<std::uintptr_t>(dst + l) & 31) == 0)
    for (; l + 16 <= n; l += 16) _mm256_stream_si256(reinterpret_cast<__m256i*>(dst + l), scaled_halves16(src + l, s));
#elif defined(__F16C__)
  if ((reinterpret_cast<std::uintptr_t>(dst) & 15) == 0)
    for (; l + 8 <= n; l += 8)
      _mm_stream_si128(reinterpret_cast<__m128i*>(dst + l), scaled_halves8(src + l, _mm256_set1_ps(scale)));
#endif
  floats_to_halves(dst + l, src + l, n - l, scale);
}

/// floats_to_halves_streaming(), and what the rounding lost added to `lost`: lost[l] +=
/// src[l] - half(src[l] * scale) / scale for l < n. The same bits on every path (the scaling
/// by a power of two and the conversion back are exact, the subtraction and the sum round
/// once each). For mass-conserving FP16 storage: the population kept in FP32 takes it up.
inline void floats_to_halves_streaming_tracked(std::uint16_t* dst, const float* src, int n, float scale, float* lost) {
  int l = 0;
  const float inverse = 1.0f / scale;
#if defined(__F16C__) && defined(__AVX2__)
  if ((reinterpret_cast<std::uintptr_t>(dst) & 15) == 0)
    for (; l + 8 <= n; l += 8) {
      const __m256 v = _mm256_loadu_ps(src + l);
      const __m128i h =
          _mm256_cvtps_ph(_mm256_mul_ps(v, _mm256_set1_ps(scale)), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
      _mm_stream_si128(reinterpret_cast<__m128i*>(dst + l), h);
      const __m256 back = _mm256_mul_ps(_mm256_cvtph_ps(h), _mm256_set1_ps(inverse));
      _mm256_storeu_ps(lost + l, _mm256_add_ps(_mm256_loadu_ps(lost + l), _mm256_sub_ps(v, back)));
    }
#endif
  for (; l < n; ++l) {
    const std::uint16_t h = float_to_half(src[l] * scale);
    dst[l] = h;
    lost[l] += src[l] - half_to_float(h) * inverse;
  }
}

#pragma GCC diagnostic pop

}  // namespace nephos::lbm
