#pragma once
// Counter-based hashing: every random number in nephos is a pure function of (seed, counters),
// never of a shared generator's state. This is what makes outputs bit-identical whatever the
// thread or rank count: a sample's randomness does not depend on which thread drew it first.
#include <cstdint>

namespace nephos {

/// Murmur3's 64-bit finaliser (a bijection with full avalanche).
constexpr std::uint64_t mix64(std::uint64_t x) noexcept {
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  x *= 0xc4ceb9fe1a85ec53ULL;
  x ^= x >> 33;
  return x;
}

/// Hash of a seed and up to four counters. Distinct inputs give independent-looking outputs.
constexpr std::uint64_t hash(std::uint64_t seed, std::uint64_t a = 0, std::uint64_t b = 0, std::uint64_t c = 0,
                             std::uint64_t d = 0) noexcept {
  constexpr std::uint64_t k = 0x9e3779b97f4a7c15ULL;  // golden-ratio increment (splitmix64)
  std::uint64_t h = mix64(seed + k);
  h = mix64(h ^ (a + k));
  h = mix64(h ^ (b + 2 * k));
  h = mix64(h ^ (c + 3 * k));
  h = mix64(h ^ (d + 4 * k));
  return h;
}

/// Uniform double in [0, 1) from the top 53 bits of a hash.
constexpr double to_unit_double(std::uint64_t h) noexcept { return static_cast<double>(h >> 11) * 0x1.0p-53; }

/// Uniform float in [0, 1) from the top 24 bits of a hash.
constexpr float to_unit_float(std::uint64_t h) noexcept { return static_cast<float>(h >> 40) * 0x1.0p-24f; }

/// Uniform double in [0, 1) for (seed, counters).
constexpr double uniform01(std::uint64_t seed, std::uint64_t a = 0, std::uint64_t b = 0, std::uint64_t c = 0,
                           std::uint64_t d = 0) noexcept {
  return to_unit_double(hash(seed, a, b, c, d));
}

}  // namespace nephos
