#pragma once
// `nephos bench particles`: particles generated per second (eqs. 3-5) and frame times (motion,
// level of detail, illumination, sorting, drawing at 1280x720 on the headless renderer) for 10^5
// and 10^6 particles, with and without LOD, on the embedded GFS sample.
#include <cstddef>
#include <cstdint>

namespace nephos::bench {

struct ParticlesBenchOptions {
  int frames = 5;
  std::size_t max_count = 1000000;
  int width = 1280, height = 720;
};

int run_particles_bench(const ParticlesBenchOptions& options, std::uint64_t seed);

}  // namespace nephos::bench
