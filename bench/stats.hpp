#pragma once
// Summary statistics of benchmark samples (frame times, step times, rates), one definition for
// every `nephos bench` subcommand.
#include <algorithm>
#include <cstddef>
#include <vector>

#include "nephos/core/error.hpp"

namespace nephos::bench {

/// The p-quantile of `v` (0 <= p <= 1): the sample of rank floor(p n) in sorted order, the
/// largest for p = 1. No interpolation, so a reported figure is one that was measured.
inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) throw ValueError("a benchmark statistic of no samples (at least one run is needed)");
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

/// percentile(v, 0.5): for an even count, the upper of the two middle samples.
inline double median(std::vector<double> v) { return percentile(std::move(v), 0.5); }

/// A goal's verdict beside its figure: "met" or "not met"; "-" where the figure is not the
/// goal's (a benchmark run at another size than the goal's).
inline const char* verdict(bool met, bool comparable) { return !comparable ? "-" : met ? "met" : "not met"; }

inline double mean(const std::vector<double>& v) {
  if (v.empty()) throw ValueError("a benchmark statistic of no samples (at least one run is needed)");
  double sum = 0;
  for (double x : v) sum += x;
  return sum / static_cast<double>(v.size());
}

}  // namespace nephos::bench
