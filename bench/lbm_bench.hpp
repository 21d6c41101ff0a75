#pragma once
// `nephos bench lbm`: memory bandwidth (STREAM triad) as the roofline anchor, then the D3Q19
// kernels, each beside the lattice-Boltzmann cloud seed's NVIDIA G80 figures.
#include <cstdint>
#include <string>

namespace nephos::bench {

struct LbmBenchOptions {
  int size = 128;
  int repeat = 10;
  /// Comma-separated subset of: bgk, water, water16 (FP16 storage), percolation, lighting, raycast ("all" by default;
  /// percolation, lighting and ray casting share their inputs, so any of them runs all three).
  std::string kernels = "all";
};

int run_lbm_bench(const LbmBenchOptions& options, std::uint64_t seed);

}  // namespace nephos::bench
