#include "nephos/clouds/cube_map.hpp"

#include <gtest/gtest.h>

#include "nephos/core/hash.hpp"

namespace nephos::clouds {

TEST(CubeMap, TexelCentresReturnTheirValue) {
  CubeMap<float> c(8);
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < 8; ++j)
      for (int i = 0; i < 8; ++i) c.texel(f, i, j) = static_cast<float>(f * 100 + j * 10 + i);
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < 8; ++j)
      for (int i = 0; i < 8; ++i)
        EXPECT_NEAR(c.sample(c.texel_direction(f, i, j) * 3.0), c.texel(f, i, j), 1e-4);  // float weights
}

TEST(CubeMap, SmoothFieldIsInterpolatedEverywhere) {
  // A linear function of direction, f = x + 2y - z, stored at 64^2 texels per face: bilinear
  // lookup deviates by the curvature of the gnomonic mapping over one texel (< 1e-3), also in
  // the half-texel strips along face edges, which are extrapolated.
  CubeMap<float> c(64);
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < 64; ++j)
      for (int i = 0; i < 64; ++i) {
        const auto d = c.texel_direction(f, i, j);
        c.texel(f, i, j) = static_cast<float>(d.x + 2 * d.y - d.z);
      }
  for (int s = 0; s < 2000; ++s) {
    const earth::Vec3 d =
        glm::normalize(earth::Vec3(uniform01(4, s, 0) - 0.5, uniform01(4, s, 1) - 0.5, uniform01(4, s, 2) - 0.5));
    EXPECT_NEAR(c.sample(d), d.x + 2 * d.y - d.z, 1e-3) << s;
  }
}

}  // namespace nephos::clouds
