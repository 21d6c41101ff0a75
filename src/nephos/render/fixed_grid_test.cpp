#include "nephos/render/fixed_grid.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "nephos/core/error.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/render/sensor.hpp"

namespace nephos::render {
namespace {

// GOES-R PUG Vol. 3 (L1b), section 5.1.2.8.1's worked example: with the projection origin at
// -75 deg, scan angles x = -0.024052 rad, y = 0.095340 rad see latitude 33.846162 deg, longitude
// -84.690932 deg; section 5.1.2.8.2 the reverse. Tolerances: the example's printed digits (1e-6
// deg, 1e-6 rad). Faults caught: the polar radius for the equatorial one, a sign of x (the
// longitude on the other side), geocentric latitude for geodetic (0.19 deg off).
TEST(FixedGrid, ThePugsWorkedExample) {
  FixedGridProjection p;
  p.lon0_deg = -75.0;
  double lat = 0, lon = 0;
  ASSERT_TRUE(p.to_geodetic(-0.024052, 0.095340, lat, lon));
  EXPECT_NEAR(lat, 33.846162, 1e-6);
  EXPECT_NEAR(lon, -84.690932, 1e-6);
  double x = 0, y = 0;
  ASSERT_TRUE(p.to_scan(33.846162, -84.690932, x, y));
  EXPECT_NEAR(x, -0.024052, 1e-6);
  EXPECT_NEAR(y, 0.095340, 1e-6);
}

// Off the disc: beyond the Earth's angular radius (8.7 deg = 0.152 rad) the line of sight misses,
// and the far side of the Earth is not visible.
TEST(FixedGrid, SpaceAndTheFarSideAreNotOnTheGrid) {
  FixedGridProjection p;
  double lat = 0, lon = 0, x = 0, y = 0;
  EXPECT_FALSE(p.to_geodetic(0.16, 0.0, lat, lon));
  EXPECT_FALSE(p.to_scan(0.0, p.lon0_deg + 180, x, y));
  ASSERT_TRUE(p.to_geodetic(0.0, 0.0, lat, lon));  // the sub-satellite point
  EXPECT_NEAR(lat, 0, 1e-12);
  EXPECT_NEAR(lon, p.lon0_deg, 1e-12);
}

// The sectors' sizes are ABI's (PUG Vol. 3, Table 5.1.2.8-1): full disc 5424 / 10848 / 21696
// pixels at 2 / 1 / 0.5 km, CONUS and PACUS 2500 x 1500 at 2 km, a mesoscale sector 500 x 500
// at 2 km; the first full-disc pixel centre is the x variable's add_offset, -0.151844 rad.
TEST(FixedGrid, SectorSizesAreAbis) {
  FixedGridProjection east, west;
  west.lon0_deg = -137;
  for (auto [res, n] : {std::pair{2.0, 5424}, {1.0, 10848}, {0.5, 21696}}) {
    const FixedGridSector f = fixed_grid_sector(east, "full", res, 1);
    EXPECT_EQ(f.nx, n) << res;
    EXPECT_EQ(f.ny, n) << res;
  }
  const FixedGridSector f = fixed_grid_sector(east, "full", 2, 1);
  EXPECT_NEAR(f.x0_rad, -0.151844, 1e-9);
  EXPECT_NEAR(f.y0_rad, 0.151844, 1e-9);
  for (const auto* p : {&east, &west}) {
    const FixedGridSector c = fixed_grid_sector(*p, "conus", 2, 1);
    EXPECT_EQ(c.nx, 2500);
    EXPECT_EQ(c.ny, 1500);
  }
  EXPECT_NEAR(fixed_grid_sector(east, "conus", 2, 1).x0_rad, -0.101332, 1e-6);
  const FixedGridSector m = fixed_grid_sector(east, "meso:35,-90", 2, 1);
  EXPECT_EQ(m.nx, 500);
  EXPECT_EQ(m.ny, 500);
  const FixedGridSector coarse = fixed_grid_sector(east, "full", 2, 8);
  EXPECT_EQ(coarse.nx, 678);
  EXPECT_NEAR(coarse.dx_rad, 8 * 56e-6, 1e-15);
  EXPECT_THROW(fixed_grid_sector(east, "meso:35,100", 2, 1), ValueError);  // not on the disc
  EXPECT_THROW(fixed_grid_sector(east, "hemisphere", 2, 1), ValueError);
  EXPECT_THROW(fixed_grid_sector(east, "full", 2, 0), ValueError);
}

// The sensor's rays reach the renderer's sphere at each pixel's fixed-grid latitude and
// longitude (within 1 mm: double rounding over 36 000 km).
TEST(FixedGrid, RaysMeetTheSphereWhereTheGridSays) {
  const FixedGridView v = abi_view("abi:east", "full", 2, 16);
  const Sensor s = Sensor::abi(v);
  EXPECT_EQ(s.width, 339);
  int on_earth = 0;
  for (int j = 0; j < s.height; j += 13)
    for (int i = 0; i < s.width; i += 13) {
      double lat = 0, lon = 0;
      if (!v.projection.to_geodetic(v.sector.x(i), v.sector.y(j), lat, lon)) continue;
      const earth::Vec3 d = s.ray(i + 0.5, j + 0.5);
      const auto hit = earth::ray_sphere(s.position, d, earth::radius_m);
      ASSERT_TRUE(hit);
      const earth::Vec3 p = s.position + hit->t0 * d;
      EXPECT_LT(glm::length(p - earth::radius_m * earth::unit_from_latlon(lat, lon)), 1e-3);
      ++on_earth;
    }
  EXPECT_GT(on_earth, 400);
}

}  // namespace
}  // namespace nephos::render
