#pragma once
// The Earth as nephos models it: a sphere of the mean radius (IUGG R1), with standard gravity.
// Heights are geometric metres above mean sea level unless the name says otherwise.
#include <cmath>
#include <numbers>

namespace nephos::earth {

inline constexpr double radius_m = 6371008.8;  ///< IUGG mean radius R1 [m]
inline constexpr double g0_m_s2 = 9.80665;     ///< standard gravity [m s^-2] (WMO geopotential metre)
inline constexpr double deg = std::numbers::pi / 180.0;

/// Geometric height [m] from geopotential height [gpm]: z = R H / (R - H).
/// GRIB "gh" is geopotential divided by g0; this inverse of H = R z / (R + z) assumes gravity
/// falls off as (R/(R+z))^2 from g0 at sea level (latitude variation of g ignored: < 0.3%).
constexpr double geometric_from_geopotential_m(double h_gpm) { return radius_m * h_gpm / (radius_m - h_gpm); }
/// Geopotential height [gpm] from geometric height [m].
constexpr double geopotential_from_geometric_m(double z_m) { return radius_m * z_m / (radius_m + z_m); }

/// Longitude wrapped into [0, 360) degrees.
inline double wrap_lon_360(double lon_deg) {
  double l = std::fmod(lon_deg, 360.0);
  if (l < 0) l += 360.0;
  return l >= 360.0 ? 0.0 : l;
}
/// Longitude wrapped into [-180, 180) degrees.
inline double wrap_lon_180(double lon_deg) {
  double l = wrap_lon_360(lon_deg);
  return l >= 180.0 ? l - 360.0 : l;
}

/// Fraction of the sphere's area between two latitudes [deg]: (sin b - sin a) / 2.
inline double area_fraction_between(double lat_a_deg, double lat_b_deg) {
  return 0.5 * std::abs(std::sin(lat_b_deg * deg) - std::sin(lat_a_deg * deg));
}

}  // namespace nephos::earth
