#pragma once
// `nephos bench fly`: the thesis's experiment matrix (tests A-E: 0, 10, 30, 75, 200 clouds) x
// clustered / spread x sort-optimised / not, N frames each at 1280x720 on the headless renderer,
// frame times measured on the CPU around glFinish.
#include <cstdint>
#include <string>

namespace nephos::bench {

struct FlyBenchOptions {
  /// Frames per case: 600 frames at 30 per second of flight are the thesis's 20-second tests
  /// (section 3.5), long enough to include the impostor ring's rebuilds in flight (every 1.2 km,
  /// about 280 frames at 250 kt), not only the first frame's build of all eight.
  int frames = 600;
  std::string tests = "ABCDE";  ///< which of tests A-E to run (letters)
  int width = 1280, height = 720;
  std::string plot = "out/bench_fly.png";  ///< bar plot of p95 frame time per case ("" = none)
  /// Test E's paired measure: frames per block of each renderer in turn (1: frame by frame).
  int paired_block = 30;
};

int run_fly_bench(const FlyBenchOptions& options, std::uint64_t seed);

}  // namespace nephos::bench
