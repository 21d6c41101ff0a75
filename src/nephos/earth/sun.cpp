#include "nephos/earth/sun.hpp"

#include <cmath>

namespace nephos::earth {
namespace {
double wrap360(double a) {
  a = std::fmod(a, 360.0);
  return a < 0 ? a + 360.0 : a;
}
}  // namespace

double gmst_deg(double jd) {
  const double t = (jd - 2451545.0) / 36525.0;
  return wrap360(280.46061837 + 360.98564736629 * (jd - 2451545.0) + 0.000387933 * t * t - t * t * t / 38710000.0);
}

SunPosition sun_position_jd(double jd) {
  const double t = (jd - 2451545.0) / 36525.0;                               // Julian centuries
  const double l0 = wrap360(280.46646 + t * (36000.76983 + 0.0003032 * t));  // mean longitude (25.2)
  const double m = wrap360(357.52911 + t * (35999.05029 - 0.0001537 * t));   // mean anomaly (25.3)
  const double e = 0.016708634 - t * (0.000042037 + 0.0000001267 * t);       // eccentricity (25.4)
  const double mr = m * deg;
  const double c = (1.914602 - t * (0.004817 + 0.000014 * t)) * std::sin(mr) +  // equation of centre
                   (0.019993 - 0.000101 * t) * std::sin(2 * mr) + 0.000289 * std::sin(3 * mr);
  const double true_lon = l0 + c;
  const double nu = (m + c) * deg;
  const double r = 1.000001018 * (1 - e * e) / (1 + e * std::cos(nu));  // (25.5)
  const double omega = (125.04 - 1934.136 * t) * deg;
  const double lambda = true_lon - 0.00569 - 0.00478 * std::sin(omega);  // apparent longitude
  const double eps0 = 23.0 + (26.0 + (21.448 - t * (46.8150 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0;  // (22.2)
  const double eps = (eps0 + 0.00256 * std::cos(omega)) * deg;  // apparent obliquity (25.8)
  const double lr = lambda * deg;
  SunPosition s;
  s.apparent_longitude_deg = wrap360(lambda);
  s.right_ascension_deg = wrap360(std::atan2(std::cos(eps) * std::sin(lr), std::cos(lr)) / deg);  // (25.6)
  s.declination_deg = std::asin(std::sin(eps) * std::sin(lr)) / deg;                              // (25.7)
  s.distance_au = r;
  s.gmst_deg = gmst_deg(jd);
  s.subsolar_lat_deg = s.declination_deg;
  s.subsolar_lon_deg = wrap360(s.right_ascension_deg - s.gmst_deg + 180.0) - 180.0;
  s.direction_ecef = unit_from_latlon(s.subsolar_lat_deg, s.subsolar_lon_deg);
  return s;
}

SunPosition sun_position(const UtcTime& t) { return sun_position_jd(2451545.0 + t.days_since_j2000()); }

}  // namespace nephos::earth
