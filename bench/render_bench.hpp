#pragma once
// `nephos bench render`: the four configurations of Table 3 of the fractal-cloud seed for one
// cloud type, each printed beside the seed's GPU figure, plus the pixel-count and field-of-view
// scaling checks and peak memory; then every cloud type at 1000^2 and their mean, the measure
// of the seed's table (an average per shell); what filtering, shadows and the atmosphere each
// cost; the aliasing left at one ray per pixel against a supersampled reference; and the ABI's
// 2 km full disc on the fixed grid in the ten thermal bands, with peak memory.
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
