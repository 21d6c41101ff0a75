// The per-frame pipeline: ordering, LOD on/off and determinism.
#include "nephos/particles/scene.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>

#include "nephos/core/hash.hpp"
#include "nephos/core/parallel.hpp"

using namespace nephos;
using namespace nephos::particles;

namespace {
ParticleWeather small_weather() {
  ParticleWeather w;
  w.grid.cols = 8, w.grid.rows = 6, w.grid.dx_m = w.grid.dy_m = 20000;
  w.grid.x0_m = -70000, w.grid.y0_m = -50000;
  w.grid.centre_lat_deg = 45, w.grid.centre_lon_deg = 10;
  WeatherFrame f;
  f.valid_time = UtcTime::from_civil(2011, 6, 21, 12);
  for (std::size_t c = 0; c < w.grid.size(); ++c) {
    const bool cloudy = c % 3 != 0;
    f.columns.tau.push_back(cloudy ? static_cast<float>(1 + c % 11) : 0.0f);
    f.columns.base_m.push_back(cloudy ? 1000.0f : std::nanf(""));
    f.columns.top_m.push_back(cloudy ? 2500.0f + static_cast<float>(100 * (c % 5)) : std::nanf(""));
  }
  f.wind.levels = 1;
  f.wind.z_m.assign(w.grid.size(), 2000.0f);
  f.wind.u.assign(w.grid.size(), 10.0f);
  f.wind.v.assign(w.grid.size(), 0.0f);
  f.wind.w.assign(w.grid.size(), 0.0f);
  w.frames.push_back(f);
  return w;
}
}  // namespace

TEST(Scene, RadixOrderEqualsStableSort) {
  std::vector<float> keys(10000);
  for (std::size_t i = 0; i < keys.size(); ++i) keys[i] = static_cast<float>(std::floor(uniform01(5, i) * 500) * 1.5);
  std::vector<std::uint32_t> expected(keys.size());
  std::iota(expected.begin(), expected.end(), 0u);
  std::stable_sort(expected.begin(), expected.end(), [&](auto a, auto b) { return keys[a] > keys[b]; });
  EXPECT_EQ(order_descending(keys), expected);
}

TEST(Scene, SpritesAreBackToFrontAndDeterministic) {
  SceneParams sp;
  sp.generation.count = 20000;
  sp.generation.seed = 3;
  ParticleScene a(small_weather(), sp);
  const realtime::Camera cam = a.default_camera();
  a.move_to(600);
  set_threads(1);
  const auto s1 = a.sprites(600, cam.position);
  set_threads(4);
  const auto s2 = a.sprites(600, cam.position);
  set_threads(0);
  EXPECT_EQ(s1.x, s2.x);
  EXPECT_EQ(s1.grey, s2.grey);
  ASSERT_GT(s1.size(), 100u);
  EXPECT_LT(s1.size(), 20000u);  // the LOD thinned the far particles
  for (std::size_t k = 1; k < s1.size(); ++k) {
    const auto d = [&](std::size_t i) {
      const double dx = s1.x[i] - cam.position.x, dy = s1.y[i] - cam.position.y, dz = s1.z[i] - cam.position.z;
      return dx * dx + dy * dy + dz * dz;
    };
    ASSERT_GE(d(k - 1) * (1 + 1e-6), d(k)) << k;
  }
  // Without LOD every particle is drawn; the particles moved 10 m/s * 600 s east.
  sp.lod = false;
  ParticleScene b(small_weather(), sp);
  b.move_to(600);
  EXPECT_EQ(b.sprites(600, cam.position).size(), 20000u);
  EXPECT_NEAR(b.current().x[7] - b.initial().x[7], 6000.0f, 0.01f);  // float positions ~1e5 m
}
