// nephos_gpu_check: the sprite renderer's check on a lent GPU machine, which cannot install
// nephos's Debian packages and so cannot run the nephos program (scripts/gpu_kit.sh builds this
// small program and gathers what it needs; scripts/gpu_check.sh runs it there). Three modes:
//   frames DIR                   d400 and d200 after 90 frames of the bench's flight, OpenGL ES
//                                3.0 and 3.3 core, with and without the ring: DIR/NAME.png
//   compare DIR_A DIR_B          the same frames from two machines: largest and mean channel
//                                difference [levels], share of pixels more than 2 levels apart
//   bench DIR [FRAMES] [TESTS]   `nephos bench fly`'s own code, its plot written to DIR
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "fly_bench.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/time.hpp"
#include "nephos/io/png.hpp"
#include "nephos/realtime/gl/flight.hpp"
#include "nephos/realtime/weather_input.hpp"

namespace {

using namespace nephos;
using namespace nephos::realtime;

// The frames `frames` makes and `compare` reads: d400 and d200, each API, with and without the ring.
struct Case {
  const char* code;
  GlApi api;
  bool impostors;
  std::string file() const {
    return std::string(code) + "_" + name(api) + (impostors ? "_ring" : "_every_sprite") + ".png";
  }
};

std::vector<Case> cases() {
  std::vector<Case> all;
  for (const char* code : {"d400", "d200"})
    for (GlApi api : {GlApi::gles30, GlApi::gl33})
      for (bool impostors : {true, false}) all.push_back({code, api, impostors});
  return all;
}

int frames(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const SunLight sun = sun_light(UtcTime::parse("2024-06-21T10:00:00Z"), 48.0, 11.0);
  constexpr int n = 90;  // 3 s of flight: past the first frame's whole-ring build
  for (const Case& c : cases()) {
    FlightParams params;
    params.impostors = c.impostors;
    StraightFlight flight(recipe_from_code(parse_weather_code(c.code)), 1, params);
    SpriteRenderer renderer(1280, 720, 1, c.api);
    renderer.set_single_sprite_distance(20000);  // nephos fly's default level of detail
    double ms = 0;
    for (int f = 0; f < n; ++f) ms += flight.next_frame(renderer, sun).milliseconds;
    io::write_png(dir / c.file(), renderer.width(), renderer.height(), 4, straight_alpha(renderer.read_pixels()));
    std::printf("%s %s %s: mean frame %.3f ms over %d frames; %s | %s\n", c.code, name(c.api),
                c.impostors ? "ring" : "every sprite", ms / n, n, renderer.gl_version().c_str(),
                renderer.gl_renderer().c_str());
  }
  return 0;
}

int compare(const std::filesystem::path& a, const std::filesystem::path& b) {
  for (const Case& c : cases()) {
    const std::string file = c.file();
    int wa = 0, ha = 0, ca = 0, wb = 0, hb = 0, cb = 0;
    const auto pa = io::read_png(a / file, wa, ha, ca), pb = io::read_png(b / file, wb, hb, cb);
    if (wa != wb || ha != hb || ca != cb) throw ValueError(file + ": the two frames differ in size");
    int largest = 0;
    double sum = 0;
    std::size_t over = 0;
    for (std::size_t p = 0; p < pa.size(); p += static_cast<std::size_t>(ca)) {
      int most = 0;
      for (std::size_t k = 0; k < 3; ++k) {  // colour channels; the sky's alpha is 255 in both
        const int d = std::abs(int{pa[p + k]} - int{pb[p + k]});
        most = std::max(most, d), sum += d;
      }
      largest = std::max(largest, most), over += most > 2;
    }
    const double pixels = static_cast<double>(pa.size() / static_cast<std::size_t>(ca));
    std::printf("%-28s largest %3d levels, mean %.3f, %.3f %% of the pixels more than 2 apart\n", file.c_str(), largest,
                sum / (3 * pixels), 100.0 * static_cast<double>(over) / pixels);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "frames" && argc == 3) return frames(argv[2]);
    if (mode == "compare" && argc == 4) return compare(argv[2], argv[3]);
    if (mode == "bench" && argc >= 3 && argc <= 5) {
      bench::FlyBenchOptions o;
      if (argc > 3) {
        const std::string f = argv[3];
        if (f.empty() || f.size() > 6 || f.find_first_not_of("0123456789") != std::string::npos || std::stoi(f) < 1)
          throw ValueError("bench FRAMES: expected a whole number of frames from 1 to 999999, got '" + f + "'");
        o.frames = std::stoi(f);
      }
      o.tests = argc > 4 ? argv[4] : "ABCDE";
      o.plot = (std::filesystem::path(argv[2]) / "bench_fly.png").string();
      return bench::run_fly_bench(o, 1);
    }
    std::cerr << "usage: nephos_gpu_check frames DIR | compare DIR_A DIR_B | bench DIR [FRAMES] [TESTS]\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "nephos_gpu_check: error: " << e.what() << "\n";
    return 1;
  }
}
