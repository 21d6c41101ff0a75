#include "nephos/earth/earth.hpp"

#include <gtest/gtest.h>

namespace nephos::earth {

TEST(Earth, GeopotentialToGeometricHeight) {
  // The 1976 U.S. Standard Atmosphere (NOAA/NASA/USAF 1976, Table I) lists geometric 11,019 m
  // for geopotential 11,000 m' with r0 = 6,356,766 m. With our mean radius the same relation
  // gives 11,000 * R / (R - 11,000) = 11,019.0 m; tolerance 1 m covers the radius difference.
  EXPECT_NEAR(geometric_from_geopotential_m(11000.0), 11019.0, 1.0);
  EXPECT_NEAR(geopotential_from_geometric_m(geometric_from_geopotential_m(5000.0)), 5000.0, 1e-9);
  EXPECT_EQ(geometric_from_geopotential_m(0.0), 0.0);
}

TEST(Earth, LongitudeWrapping) {
  EXPECT_DOUBLE_EQ(wrap_lon_360(-75.2), 284.8);
  EXPECT_EQ(wrap_lon_360(360.0), 0.0);
  EXPECT_DOUBLE_EQ(wrap_lon_180(284.8), -75.2);
  EXPECT_EQ(wrap_lon_180(180.0), -180.0);
}

TEST(Earth, AreaFractions) {
  // A hemisphere is half the sphere; the band 0..30 deg holds sin(30)/2 = 1/4 of it.
  EXPECT_DOUBLE_EQ(area_fraction_between(0, 90), 0.5);
  EXPECT_NEAR(area_fraction_between(0, 30), 0.25, 1e-15);  // exact up to rounding of sin(30 deg)
}

}  // namespace nephos::earth
