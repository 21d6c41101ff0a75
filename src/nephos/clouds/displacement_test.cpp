#include "nephos/clouds/displacement.hpp"

#include <gtest/gtest.h>

namespace nephos::clouds {
namespace {

// Solid-body rotation about `axis` with angular velocity omega [rad/s]: V = omega (axis x p) r.
WindField rotation(const earth::Vec3& axis, double omega, int n = 128) {
  WindField w;
  w.altitude_m = 0;
  w.velocity_m_s = CubeMap<glm::vec3>(n);
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const auto d = w.velocity_m_s.texel_direction(f, i, j);
        w.velocity_m_s.texel(f, i, j) = glm::vec3(omega * earth::radius_m * glm::cross(axis, d));
      }
  return w;
}

double angle_deg(const earth::Vec3& a, const earth::Vec3& b) {
  return std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)) / earth::deg;
}

}  // namespace

TEST(Displacement, ZonalSolidBodyRotationIsExact) {
  // 20 m/s at the equator: omega = 20 / R. After 10 h the upwind point lies omega * 36000 s
  // = 6.47 deg of longitude to the west at every latitude; the analytic answer.
  const double omega = 20.0 / earth::radius_m;
  const WindField w = rotation({0, 0, 1}, omega);
  for (double lat : {0.0, 45.0, -70.0}) {
    const earth::Vec3 p = earth::unit_from_latlon(lat, 10);
    const earth::Vec3 up = trace_upwind(w, p, 36000, 1800);
    const earth::Geodetic g = earth::geodetic(up * earth::radius_m);
    // Tolerance: bilinear interpolation of the rotation field on the curved cube faces (128
    // texels per face) errs by ~1e-4 of the speed: 1e-4 * 6.47 deg ~ 6e-4 deg; RK4 with
    // 30-minute steps adds < 1e-9 deg.
    EXPECT_NEAR(g.lon_deg, 10 - omega * 36000 / earth::deg, 1e-3) << lat;
    EXPECT_NEAR(g.lat_deg, lat, 1e-3) << lat;
  }
}

TEST(Displacement, CrossesThePoleWithoutSingularity) {
  // Rotation about the y axis carries air over the North Pole; 90 deg of arc in the time
  // pi / 2 / omega from the equator at lon 0 must land on the pole's far side, lon 180.
  const double omega = 30.0 / earth::radius_m;
  const WindField w = rotation({0, 1, 0}, omega);
  const earth::Vec3 p = earth::unit_from_latlon(10, 180);  // downwind of the pole
  const double t = 20.0 * earth::deg / omega;              // 20 deg of arc back in time
  const earth::Vec3 up = trace_upwind(w, p, t, 600);
  EXPECT_NEAR(angle_deg(up, p), 20.0, 20.0 * 1e-4);  // interpolation error of the speed, as above
  // Backwards along the flow from (10N, 180E) over the pole ends at (80N, 0E)... or the
  // mirror, depending on the sense of rotation; it must stay on the 0/180 meridian plane.
  EXPECT_NEAR(up.y, 0.0, 1e-6);
}

TEST(Displacement, BackwardsInTimeIsTheReversedWindsTrace) {
  // Tracing a negative duration (where air goes to, as Scene.advance(-h) needs) is tracing the
  // same duration upwind in the reversed wind: the same steps, bit for bit, in 30-minute steps
  // however long (one 5-hour step would leave a sheared flow's curvature unresolved).
  const double omega = 25.0 / earth::radius_m;
  const WindField w = rotation(glm::normalize(earth::Vec3{0.3, 0.2, 1.0}), omega, 32);
  WindField reversed = w;
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i) reversed.velocity_m_s.texel(f, i, j) = -w.velocity_m_s.texel(f, i, j);
  for (double hours : {0.4, 5.0, 11.0})
    for (double lat : {-50.0, 10.0, 75.0}) {
      const earth::Vec3 p = earth::unit_from_latlon(lat, 40);
      EXPECT_EQ(trace_upwind(w, p, -hours * 3600, 1800), trace_upwind(reversed, p, hours * 3600, 1800)) << hours;
    }
  // And back again: a map built forward 6 h, then advanced -6 h, is the identity to within the
  // cube map's interpolation (< 0.01 deg here, as MapsComposeForAnimation).
  const DisplacementMap there_and_back = DisplacementMap::build(w, 6, 64).advanced(w, -6, 1800, 64);
  for (double lat : {-60.0, 0.0, 33.0})
    for (double lon : {-170.0, 120.0}) {
      const earth::Vec3 d = earth::unit_from_latlon(lat, lon);
      EXPECT_LT(angle_deg(there_and_back.upwind(d), d), 0.01) << lat << " " << lon;
    }
}

TEST(Displacement, MapsBuiltTogetherAreEachTexelsOwnTrace) {
  // build_all() traces the durations of one step length together (6 h is the first 12 of 8 h's
  // 16 half-hour steps); every texel must still be exactly trace_upwind() of its direction
  // for its own duration, including a duration of another step length (6.25 h: 13 steps of
  // 1730.8 s) and the identity (0 h), in the order asked for.
  const WindField w = rotation(glm::normalize(earth::Vec3{0.2, -0.4, 1.0}), 25.0 / earth::radius_m, 32);
  const std::vector<double> hours{8, 0, 6, 6.25, 2};
  constexpr int n = 16;
  const std::vector<DisplacementMap> maps = DisplacementMap::build_all(w, hours, n, 1800);
  ASSERT_EQ(maps.size(), hours.size());
  for (std::size_t k = 0; k < hours.size(); ++k) {
    EXPECT_EQ(maps[k].hours(), hours[k]);
    EXPECT_EQ(maps[k].is_identity(), hours[k] == 0);
    if (hours[k] == 0) continue;
    int mismatches = 0;
    for (int f = 0; f < 6; ++f)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const earth::Vec3 d = maps[k].map().texel_direction(f, i, j);
          mismatches += maps[k].map().texel(f, i, j) != glm::vec3(trace_upwind(w, d, hours[k] * 3600.0, 1800));
        }
    EXPECT_EQ(mismatches, 0) << hours[k] << " h";
  }
}

TEST(Displacement, MapsComposeForAnimation) {
  // build(H).advanced(A) equals build(H + A) up to cube-map interpolation (< 0.01 deg here).
  const double omega = 25.0 / earth::radius_m;
  const WindField w = rotation(glm::normalize(earth::Vec3{0.3, 0.2, 1.0}), omega);
  const DisplacementMap a = DisplacementMap::build(w, 6, 64).advanced(w, 4, 1800, 64);
  const DisplacementMap b = DisplacementMap::build(w, 10, 64);
  EXPECT_EQ(a.hours(), 10);
  for (double lat : {-60.0, 0.0, 33.0, 80.0})
    for (double lon : {-170.0, 5.0, 120.0}) {
      const earth::Vec3 d = earth::unit_from_latlon(lat, lon);
      EXPECT_LT(angle_deg(a.upwind(d), b.upwind(d)), 0.01) << lat << " " << lon;
    }
  EXPECT_TRUE(DisplacementMap().is_identity());
}

}  // namespace nephos::clouds
