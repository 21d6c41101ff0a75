#pragma once
// Elementary functions written so that GCC vectorises them inside `omp simd` loops (libm's are
// scalar calls there unless -ffast-math, which nephos does not use). Every multiply-add is an
// explicit fma, so a vector body and its scalar remainder round alike (results do not depend on
// how a loop was split).
#include <bit>
#include <cmath>
#include <cstdint>

namespace nephos::lbm {

/// e^x for x <= 0, to 2 ulp (tested against libm); x below -87 gives e^-87 (~1.6e-38). Range
/// reduction x = k ln 2 + r, |r| <= ln 2 / 2 (ln 2 split in two for an exact k ln 2), then e^r
/// by its Taylor polynomial of degree 7 (truncation < 5.3e-9 relative) and 2^k by building the
/// exponent bits. Outside its use (Psi_1 of a negative density: a run blowing up, which the
/// density check then stops) it stays defined: e^x to 2 ulp up to x = 88 (finite up to
/// ln(FLT_MAX) = 88.72), +inf above it (where e^x overflows a float), NaN for NaN. k is clamped
/// to [-126, 127] before its conversion to int, which is undefined behaviour out of range (a
/// NaN, or x = 2.8e11 seen in a blown-up run by an UndefinedBehaviorSanitizer build); inside,
/// the clamp changes nothing.
// Always inlined: called in `omp simd` loops, where an out-of-line call would run lane by lane.
[[gnu::always_inline]] inline float exp_nonpositive(float x) {
  x = x < -87.0f ? -87.0f : x;
  float k = std::floor(std::fma(x, 1.44269504f, 0.5f));  // round(x / ln 2)
  // k in [-126, 0] for x <= 0; clamped for the rest (a NaN k to -126; r then stays NaN).
  k = k > 127.0f ? 127.0f : k;
  k = k >= -126.0f ? k : -126.0f;
  float r = std::fma(k, -0.693145751953125f, x);  // ln 2, high bits (exact product)
  r = std::fma(k, -1.428606765330187e-06f, r);    // ln 2, the rest
  float p = 1.0f / 5040.0f;
  p = std::fma(p, r, 1.0f / 720.0f);
  p = std::fma(p, r, 1.0f / 120.0f);
  p = std::fma(p, r, 1.0f / 24.0f);
  p = std::fma(p, r, 1.0f / 6.0f);
  p = std::fma(p, r, 0.5f);
  p = std::fma(p, r, 1.0f);
  p = std::fma(p, r, 1.0f);
  const std::int32_t bits = (static_cast<std::int32_t>(k) + 127) << 23;  // 2^k
  return p * std::bit_cast<float>(bits);
}

}  // namespace nephos::lbm
