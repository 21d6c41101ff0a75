// Weather reading, sampling and masks on the embedded GFS sample (no speed target in the
// docs/PERFORMANCE.md, so that regressions show).
#include <benchmark/benchmark.h>

#include "nephos/weather/masks.hpp"
#include "nephos/weather/reader.hpp"
#include "nephos/weather/sampler.hpp"

using namespace nephos::weather;

namespace {
const std::filesystem::path sample =
    std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2";

void BM_ReadGrib(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(open_weather(sample));
}
BENCHMARK(BM_ReadGrib)->Unit(benchmark::kMillisecond);

void BM_SampleColumn(benchmark::State& state) {
  const WeatherGrid w = open_weather(sample);
  const WeatherSampler s(w);
  double lat = -80;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.sample(lat, 123.4, 3000));
    lat = lat > 80 ? -80 : lat + 0.37;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SampleColumn);

void BM_Masks(benchmark::State& state) {
  const WeatherGrid w = open_weather(sample);
  const MaskParams p;
  for (auto _ : state) benchmark::DoNotOptimize(compute_masks(w, p));
  state.SetItemsProcessed(state.iterations() * static_cast<long>(w.grid().size()));
}
BENCHMARK(BM_Masks)->Unit(benchmark::kMillisecond);
}  // namespace

BENCHMARK_MAIN();
