#include "nephos/earth/sun.hpp"

#include <gtest/gtest.h>

namespace nephos::earth {

TEST(Sun, MeeusExample25a) {
  // Meeus, Astronomical Algorithms (2nd ed.), Example 25.a: 1992 October 13.0 TD
  // (JD 2448908.5): apparent longitude 199.90895 deg, apparent right ascension 198.38083 deg,
  // apparent declination -7.78507 deg, R = 0.99766 AU. Same algorithm: agreement to 1e-4 deg.
  const SunPosition s = sun_position_jd(2448908.5);
  EXPECT_NEAR(s.apparent_longitude_deg, 199.90895, 1e-4);
  EXPECT_NEAR(s.right_ascension_deg, 198.38083, 1e-4);
  EXPECT_NEAR(s.declination_deg, -7.78507, 1e-4);
  EXPECT_NEAR(s.distance_au, 0.99766, 1e-5);
}

TEST(Sun, SiderealTimeMeeusExample12a) {
  // Meeus Example 12.a: 1987 April 10, 0h UT: mean sidereal time 13h10m46.3668s = 197.693195 deg.
  EXPECT_NEAR(gmst_deg(2446895.5), 197.693195, 1e-5);
}

TEST(Sun, EquinoxAndSolsticeFromTheAlmanac) {
  // U.S. Naval Observatory: 2011 March equinox 23:21 UTC, June solstice 17:16 UTC. At the
  // equinox the declination is 0; at the solstice it equals the obliquity, 23.438 deg in 2011.
  // 0.01 deg: the algorithm's accuracy; the one-minute rounding of the almanac times moves the
  // declination by < 0.0003 deg.
  EXPECT_NEAR(sun_position(UtcTime::from_civil(2011, 3, 20, 23, 21)).declination_deg, 0.0, 0.01);
  EXPECT_NEAR(sun_position(UtcTime::from_civil(2011, 6, 21, 17, 16)).declination_deg, 23.438, 0.01);
}

TEST(Sun, SubsolarPointNearLocalNoon) {
  // At 12:00 UTC the Sun is within the equation of time (|EoT| < 16.5 min = 4.2 deg) of the
  // Greenwich meridian, every day of the year.
  for (int month = 1; month <= 12; ++month)
    EXPECT_LT(std::abs(sun_position(UtcTime::from_civil(2011, month, 15, 12)).subsolar_lon_deg), 4.2) << month;
  const auto s = sun_position(UtcTime::from_civil(2011, 1, 15, 12));
  EXPECT_NEAR(glm::length(s.direction_ecef), 1.0, 1e-12);
  EXPECT_LT(s.direction_ecef.z, 0);  // January: southern summer
}

}  // namespace nephos::earth
