#include "nephos/lbm/half.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "nephos/core/hash.hpp"
#include "nephos/lbm/lattice.hpp"
#include "nephos/lbm/vector_math.hpp"

namespace nephos::lbm {

TEST(Half, KnownBinary16Encodings) {
  // IEEE 754 binary16 encodings (the standard's tables): exact values and round-to-nearest-even.
  EXPECT_EQ(float_to_half(1.0f), 0x3c00);
  EXPECT_EQ(float_to_half(-2.0f), 0xc000);
  EXPECT_EQ(float_to_half(65504.0f), 0x7bff);             // largest finite half
  EXPECT_EQ(float_to_half(65520.0f), 0x7c00);             // halfway to 2^16: ties to even, infinity
  EXPECT_EQ(float_to_half(0x1p-14f), 0x0400);             // smallest normal
  EXPECT_EQ(float_to_half(0x1p-24f), 0x0001);             // smallest subnormal
  EXPECT_EQ(float_to_half(0x1p-25f), 0x0000);             // half of it: tie to even (zero)
  EXPECT_EQ(float_to_half(0x1.8p-25f), 0x0001);           // above the tie
  EXPECT_EQ(float_to_half(1.0f / 3.0f), 0x3555);          // 0.333251953125
  EXPECT_EQ(float_to_half(1.0f + 0x1p-11f), 0x3c00);      // tie between 0x3c00 and 0x3c01: even
  EXPECT_EQ(float_to_half(1.0f + 3 * 0x1p-11f), 0x3c02);  // tie between 0x3c01 and 0x3c02: even
  EXPECT_EQ(float_to_half(-0.0f), 0x8000);
  EXPECT_EQ(float_to_half(INFINITY), 0x7c00);
  EXPECT_TRUE(std::isnan(half_to_float(float_to_half(NAN))));
  EXPECT_EQ(half_to_float(0x3555), 0.333251953125f);
  EXPECT_EQ(half_to_float(0x0001), 0x1p-24f);
  EXPECT_EQ(half_to_float(0xfbff), -65504.0f);
}

TEST(Half, EveryHalfRoundTrips) {
  for (std::uint32_t h = 0; h < 0x10000; ++h) {
    const float f = half_to_float(static_cast<std::uint16_t>(h));
    if (std::isnan(f)) continue;
    ASSERT_EQ(float_to_half(f), h) << std::hex << h;
  }
}

TEST(Half, VectorPathsMatchThePortableOne) {
  // The F16C / AVX-512 paths (where compiled in) and the portable conversion give the same
  // bits: results do not depend on the path. Every half, and 1e5 hashed floats over the range
  // the lattice stores (scaled populations, |x| < 2^15).
  std::vector<std::uint16_t> all(0x10000);
  for (std::uint32_t h = 0; h < 0x10000; ++h) all[h] = static_cast<std::uint16_t>(h);
  std::vector<float> f(all.size());
  halves_to_floats(all.data(), f.data(), static_cast<int>(all.size()), 1.0f);
  for (std::uint32_t h = 0; h < 0x10000; ++h) {
    const float ref = half_to_float(all[h]);
    if (std::isnan(ref)) continue;
    ASSERT_EQ(std::bit_cast<std::uint32_t>(f[h]), std::bit_cast<std::uint32_t>(ref)) << std::hex << h;
  }
  const int n = 100000;
  std::vector<float> src(n);
  for (int k = 0; k < n; ++k) {
    const double u = uniform01(7, 0x4a1f, static_cast<std::uint64_t>(k));
    src[static_cast<std::size_t>(k)] = static_cast<float>((u - 0.5) * std::ldexp(1.0, static_cast<int>(u * 60) - 44));
  }
  alignas(64) static std::uint16_t dst[100000 + 32];
  floats_to_halves_streaming(dst, src.data(), n, 1.0f);
  stream_fence();
  for (int k = 0; k < n; ++k) ASSERT_EQ(dst[k], float_to_half(src[static_cast<std::size_t>(k)])) << src[k];
  std::vector<std::uint16_t> plain(static_cast<std::size_t>(n) + 1);  // ordinary stores, unaligned
  floats_to_halves(plain.data() + 1, src.data(), n, 1.0f);
  for (int k = 0; k < n; ++k) ASSERT_EQ(plain[static_cast<std::size_t>(k) + 1], dst[k]) << src[k];
}

TEST(Half, TrackedStoreKeepsWhatRoundingLost) {
  // floats_to_halves_streaming_tracked stores what floats_to_halves stores and adds to `lost`
  // exactly src - (the stored half) / scale, rounded once: the vector path (aligned
  // destination) and the portable one (unaligned) give the same bits. So src[k] = stored +
  // lost to within one float rounding of the difference (conservative FP16 rounding).
  const int n = 4099;
  const float scale = 1024.0f;
  std::vector<float> src(n), lost_vector(n, 0.25f), lost_portable(n, 0.25f);
  for (int k = 0; k < n; ++k) {
    const double u = uniform01(11, 0x7c3, static_cast<std::uint64_t>(k));
    src[static_cast<std::size_t>(k)] = static_cast<float>((u - 0.5) * std::ldexp(1.0, static_cast<int>(u * 20) - 12));
  }
  alignas(64) static std::uint16_t aligned[4099 + 32];
  std::vector<std::uint16_t> unaligned(static_cast<std::size_t>(n) + 1), plain(static_cast<std::size_t>(n));
  floats_to_halves_streaming_tracked(aligned, src.data(), n, scale, lost_vector.data());
  stream_fence();
  // One at a time: only the portable path runs.
  for (int k = 0; k < n; ++k)
    floats_to_halves_streaming_tracked(unaligned.data() + 1 + k, src.data() + k, 1, scale, lost_portable.data() + k);
  floats_to_halves(plain.data(), src.data(), n, scale);
  for (int k = 0; k < n; ++k) {
    const auto ku = static_cast<std::size_t>(k);
    ASSERT_EQ(aligned[k], plain[ku]);
    ASSERT_EQ(unaligned[ku + 1], plain[ku]);
    ASSERT_EQ(std::bit_cast<std::uint32_t>(lost_vector[ku]), std::bit_cast<std::uint32_t>(lost_portable[ku]));
    // lost - 0.25 is the rounding error of the stored value: at most half a half's spacing,
    // 2^-11 of the value (plus the float rounding of the sum with 0.25, 2^-25).
    const double stored = static_cast<double>(half_to_float(plain[ku])) / scale;
    EXPECT_NEAR(static_cast<double>(lost_vector[ku]) - 0.25, static_cast<double>(src[ku]) - stored, 3e-8);
    EXPECT_LE(std::abs(static_cast<double>(src[ku]) - stored), std::ldexp(std::abs(src[ku]), -11) + 1e-12);
  }
}

TEST(VectorMath, ExpMatchesLibm) {
  // exp_nonpositive against libm's expf (correctly rounded to within 1 ulp) over [-87, 0]: at
  // most 2 ulp apart (relative 2.4e-7), every float of the range sampled by 1e6 hashed points
  // plus the ends and exact powers of two.
  auto ulps = [](float a, float b) {
    return std::abs(static_cast<std::int64_t>(std::bit_cast<std::int32_t>(a)) -
                    static_cast<std::int64_t>(std::bit_cast<std::int32_t>(b)));
  };
  EXPECT_EQ(exp_nonpositive(0.0f), 1.0f);
  EXPECT_LE(ulps(exp_nonpositive(-87.0f), std::exp(-87.0f)), 2);
  EXPECT_LE(ulps(exp_nonpositive(-0.6931472f), 0.5f), 2);
  std::int64_t worst = 0;
  for (int k = 0; k < 1000000; ++k) {
    const float x = static_cast<float>(-87.0 * uniform01(11, 0xe4b, static_cast<std::uint64_t>(k)));
    worst = std::max(worst, ulps(exp_nonpositive(x), std::exp(x)));
  }
  EXPECT_LE(worst, 2);
  // Beyond its contract (a negative density in a blown-up run) it stays defined: e^x to 2 ulp
  // up to 88, +inf where e^x overflows a float (above ln(FLT_MAX) = 88.72), NaN for NaN.
  worst = 0;
  for (int k = 0; k < 100000; ++k) {
    const float x = static_cast<float>(88.0 * uniform01(11, 0xe4c, static_cast<std::uint64_t>(k)));
    worst = std::max(worst, ulps(exp_nonpositive(x), std::exp(x)));
  }
  EXPECT_LE(worst, 2);
  for (float x : {88.8f, 100.0f, 2.8e11f, std::numeric_limits<float>::max(), std::numeric_limits<float>::infinity()})
    EXPECT_EQ(exp_nonpositive(x), std::numeric_limits<float>::infinity()) << x;
  EXPECT_TRUE(std::isnan(exp_nonpositive(std::numeric_limits<float>::quiet_NaN())));
}

}  // namespace nephos::lbm
