#pragma once
// `nephos bench render`: the four configurations of Table 3 of the fractal-cloud seed, each
// printed beside the seed's GPU figure, plus the pixel-count and field-of-view scaling checks
// and peak memory.
#include <cstdint>
#include <string>

namespace nephos::bench {

struct RenderBenchOptions {
  std::string type = "low_cumulus";
  int repeat = 3;
  bool quick = false;
};

int run_render_bench(const RenderBenchOptions& options, std::uint64_t seed);

}  // namespace nephos::bench
