#pragma once
// `nephos bench lbm`: memory bandwidth (STREAM triad) as the roofline anchor, then the D3Q19
// kernels, each beside the lattice-Boltzmann cloud seed's NVIDIA G80 figures.
#include <cstdint>

namespace nephos::bench {

struct LbmBenchOptions {
  int size = 128;
  int repeat = 10;
};

int run_lbm_bench(const LbmBenchOptions& options, std::uint64_t seed);

}  // namespace nephos::bench
