#pragma once
// Positions on and around the spherical Earth (radius earth::radius_m) in an Earth-centred,
// Earth-fixed frame: x towards (0N, 0E), y towards (0N, 90E), z towards the North Pole [m].
#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <optional>

#include "nephos/earth/earth.hpp"

namespace nephos::earth {

using Vec3 = glm::dvec3;

struct Geodetic {
  double lat_deg = 0, lon_deg = 0, alt_m = 0;
};

/// Unit vector of the direction (lat, lon) from the Earth's centre.
inline Vec3 unit_from_latlon(double lat_deg, double lon_deg) {
  const double phi = lat_deg * deg, lam = lon_deg * deg;
  return {std::cos(phi) * std::cos(lam), std::cos(phi) * std::sin(lam), std::sin(phi)};
}
inline Vec3 ecef(const Geodetic& g) { return (radius_m + g.alt_m) * unit_from_latlon(g.lat_deg, g.lon_deg); }
inline Geodetic geodetic(const Vec3& p) {
  const double r = glm::length(p);
  return {std::asin(std::clamp(p.z / r, -1.0, 1.0)) / deg, std::atan2(p.y, p.x) / deg, r - radius_m};
}
/// Local east and north unit vectors at unit position `up` (east = +y at the poles).
inline Vec3 local_east(const Vec3& up) {
  const Vec3 e{-up.y, up.x, 0.0};
  const double l = glm::length(e);
  return l > 1e-12 ? e / l : Vec3{0, 1, 0};
}
inline Vec3 local_north(const Vec3& up) { return glm::cross(up, local_east(up)); }

/// The two ray parameters where o + t d (|d| = 1) meets the sphere of `radius` centred at the
/// origin, t0 <= t1; nullopt when it misses.
struct Interval {
  double t0, t1;
};
inline std::optional<Interval> ray_sphere(const Vec3& o, const Vec3& d, double radius) {
  const double b = glm::dot(o, d);
  const double c = glm::dot(o, o) - radius * radius;
  const double disc = b * b - c;
  if (disc < 0) return std::nullopt;
  const double s = std::sqrt(disc);
  // Numerically stable pair (avoids cancellation when |b| >> s).
  const double q = b > 0 ? -b - s : -b + s;
  double t0 = q, t1 = (q != 0) ? c / q : -b;
  if (t0 > t1) std::swap(t0, t1);
  return Interval{t0, t1};
}

}  // namespace nephos::earth
