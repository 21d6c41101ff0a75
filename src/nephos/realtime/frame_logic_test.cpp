#include "nephos/realtime/frame_logic.hpp"

#include <gtest/gtest.h>

#include "nephos/earth/sun.hpp"

namespace nephos::realtime {

TEST(FrameLogic, BackToFrontOrder) {
  const std::vector<glm::dvec3> p{{10, 0, 0}, {-300, 0, 0}, {0, 50, 0}, {0, 0, 2000}, {5, 5, 5}};
  const auto order = back_to_front(p, {0, 0, 0});
  EXPECT_EQ(order, (std::vector<std::size_t>{3, 1, 2, 0, 4}));
  for (std::size_t k = 1; k < order.size(); ++k)
    EXPECT_GE(glm::length(p[order[k - 1]]), glm::length(p[order[k]]));  // never nearer before farther
}

TEST(FrameLogic, ResortOnlyWhenTheViewChanged) {
  ResortPolicy r;
  EXPECT_TRUE(r.due({0, 0, 0}, {1, 0, 0}));  // first frame
  EXPECT_FALSE(r.due({150, 0, 0}, {1, 0, 0}));
  EXPECT_TRUE(r.due({250, 0, 0}, {1, 0, 0}));      // moved > 200 m since the last sort
  EXPECT_FALSE(r.due({250, 0, 0}, {1, 0.05, 0}));  // 2.9 deg turn
  EXPECT_TRUE(r.due({250, 0, 0}, {1, 0.1, 0}));    // 5.7 deg turn
}

TEST(FrameLogic, ImpostorThresholdsAndTheTenThousandFootRule) {
  ImpostorRing ring;  // radius 8 km: re-render beyond 1200 m horizontally or 160 m vertically
  EXPECT_TRUE(ring.needs_update({0, 0, 0}));
  ring.rebuilt_at({0, 0, 3000});
  EXPECT_FALSE(ring.needs_update({1199, 0, 3000}));
  EXPECT_TRUE(ring.needs_update({1201, 0, 3000}));
  EXPECT_FALSE(ring.needs_update({800, 800, 3159}));  // 1131 m and 159 m: both within
  EXPECT_TRUE(ring.needs_update({0, 0, 3161}));       // 2 % of 8 km vertically
  const glm::dvec3 cam{0, 0, 3000};
  EXPECT_TRUE(ring.in_impostor({20000, 0, 2000}, 1000, cam));          // far, same level
  EXPECT_FALSE(ring.in_impostor({5000, 0, 2000}, 1000, cam));          // inside the ring: sprites
  EXPECT_FALSE(ring.in_impostor({20000, 0, 3000 + 3100}, 1000, cam));  // 3100 m > 10,000 ft above
  EXPECT_TRUE(ring.in_impostor({20000, 0, 3000 + 3000}, 1000, cam));   // 3000 m < 3048 m
  EXPECT_EQ(ring.sector({10000, 100, 0}), 0);
  EXPECT_EQ(ring.sector({0, 10000, 0}), 2);
  EXPECT_EQ(ring.sector({-10000, -100, 0}), 4);
  EXPECT_EQ(ring.sector({7000, -7000, 0}), 7);
}

TEST(FrameLogic, SunDirectionAndReddening) {
  // Direction: elevation from sun_light equals 90 deg minus the angle between the local vertical
  // and the Meeus sun vector.
  const UtcTime noon = UtcTime::from_civil(2011, 6, 21, 12), dusk = UtcTime::from_civil(2011, 6, 21, 20, 5);
  const SunLight a = sun_light(noon, 51.5, 0), b = sun_light(dusk, 51.5, 0);
  const double expected =
      90 - std::acos(glm::dot(earth::sun_position(noon).direction_ecef, earth::unit_from_latlon(51.5, 0))) * 180 / M_PI;
  EXPECT_NEAR(a.elevation_deg, expected, 1e-9);
  EXPECT_NEAR(a.elevation_deg, 90 - 51.5 + 23.44, 0.5);  // solstice noon at London: 61.9 deg
  // Low sun: redder (blue loses more than red), dimmer.
  ASSERT_GT(b.elevation_deg, 0);
  ASSERT_LT(b.elevation_deg, 5);
  EXPECT_GT(b.colour.r / b.colour.b, 1.5 * a.colour.r / a.colour.b);
  EXPECT_LT(b.colour.b, a.colour.b);
  // Night: no sunlight.
  EXPECT_EQ(sun_light(UtcTime::from_civil(2011, 6, 21, 0), 51.5, 0).colour, glm::dvec3(0));
}

}  // namespace nephos::realtime

namespace nephos::realtime {

TEST(FlightControls, StandardRateTurnClimbAndSpeedLimits) {
  FlightControls fc;  // heading east, level, 250 kt
  glm::dvec3 p{0, 0, 2000};
  // Level flight: 10 s at 128.6 m/s east.
  fc.step({}, 10.0, p);
  EXPECT_NEAR(p.x, 1286.0, 1e-9);  // exact kinematics up to rounding
  EXPECT_NEAR(p.y, 0.0, 1e-9);
  // A standard-rate turn to the right for 30 s: 90 degrees clockwise, now heading south.
  for (int i = 0; i < 300; ++i) fc.step({.turn = 1}, 0.1, p);
  EXPECT_NEAR(fc.heading_deg, 270.0, 1e-6);
  // Full back stick for 10 s: the flight path angle stops at its 20 degree limit.
  for (int i = 0; i < 100; ++i) fc.step({.climb = 1}, 0.1, p);
  EXPECT_DOUBLE_EQ(fc.path_deg, 20.0);
  const double z = p.z;
  fc.step({}, 1.0, p);
  EXPECT_NEAR(p.z - z, fc.speed_m_s * std::sin(glm::radians(20.0)), 1e-9);  // climb rate = v sin(gamma)
  // Throttle: clamps at the limits.
  for (int i = 0; i < 1000; ++i) fc.step({.throttle = 1}, 0.1, p);
  EXPECT_DOUBLE_EQ(fc.speed_m_s, fc.max_speed_m_s);
  for (int i = 0; i < 1000; ++i) fc.step({.throttle = -1}, 0.1, p);
  EXPECT_DOUBLE_EQ(fc.speed_m_s, fc.min_speed_m_s);
  // Never below the minimum altitude.
  for (int i = 0; i < 2000; ++i) fc.step({.climb = -1}, 0.1, p);
  EXPECT_GE(p.z, fc.min_altitude_m);
}

TEST(FlightControls, LookingAroundTurnsTheViewNotTheAircraft) {
  FlightControls fc;
  fc.look_pitch_deg = 0;
  glm::dvec3 p{0, 0, 1000};
  fc.step({.look_yaw_deg = 90}, 0.0, p);  // look to the right wing: south when heading east
  const glm::dvec3 v = fc.view_direction();
  EXPECT_NEAR(v.x, 0.0, 1e-12);
  EXPECT_NEAR(v.y, -1.0, 1e-12);
  EXPECT_DOUBLE_EQ(fc.heading_deg, 0.0);
}

}  // namespace nephos::realtime
