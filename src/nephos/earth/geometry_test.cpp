#include "nephos/earth/geometry.hpp"

#include <gtest/gtest.h>

namespace nephos::earth {

TEST(Geometry, EcefRoundTrip) {
  const Geodetic g{37.5, -122.25, 1234.5};
  const Geodetic back = geodetic(ecef(g));
  // Round-off of double trigonometry at Earth-radius scale: 1e-9 deg ~ 0.1 mm, 1e-6 m.
  EXPECT_NEAR(back.lat_deg, g.lat_deg, 1e-9);
  EXPECT_NEAR(back.lon_deg, g.lon_deg, 1e-9);
  EXPECT_NEAR(back.alt_m, g.alt_m, 1e-6);
}

TEST(Geometry, RaySphere) {
  const Vec3 o{0, 0, 2 * radius_m}, d{0, 0, -1};
  const auto hit = ray_sphere(o, d, radius_m);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->t0, radius_m, 1e-6);
  EXPECT_NEAR(hit->t1, 3 * radius_m, 1e-6);
  EXPECT_FALSE(ray_sphere(o, Vec3{1, 0, 0}, radius_m));
}

TEST(Geometry, EarthAngularRadiusFromGeostationaryOrbit) {
  // From 35,786 km altitude the Earth's disc has an angular radius of asin(R / (R + h)) = 8.70 deg
  // (commonly quoted as about 8.7 deg). Check with rays: one at 8.69 deg hits, 8.71 misses.
  const Vec3 o = ecef({0, -75.2, 35786e3});
  const Vec3 to_centre = -glm::normalize(o);
  const Vec3 side = local_north(glm::normalize(o));
  auto ray_at = [&](double a_deg) { return std::cos(a_deg * deg) * to_centre + std::sin(a_deg * deg) * side; };
  EXPECT_TRUE(ray_sphere(o, ray_at(8.69), radius_m));
  EXPECT_FALSE(ray_sphere(o, ray_at(8.71), radius_m));
}

TEST(Geometry, LocalFrame) {
  const Vec3 up = unit_from_latlon(45, 30);
  EXPECT_NEAR(glm::dot(up, local_east(up)), 0, 1e-15);
  EXPECT_NEAR(glm::dot(up, local_north(up)), 0, 1e-15);
  EXPECT_GT(local_north(up).z, 0);
}

}  // namespace nephos::earth
