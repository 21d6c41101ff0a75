#pragma once
// Solar position from the low-precision algorithm of Meeus (Astronomical Algorithms, 2nd ed.,
// ch. 25, as in NOAA's Solar Calculator), accurate to ~0.01 deg for 1900-2100: better than the
// 0.1 deg the renderer needs. Times are taken as UTC: ignoring TT - UTC (~67 s in 2011) moves
// the Sun by < 0.001 deg along the ecliptic; the Earth-fixed direction uses UT via GMST.
#include "nephos/core/time.hpp"
#include "nephos/earth/geometry.hpp"

namespace nephos::earth {

struct SunPosition {
  double right_ascension_deg;     ///< apparent, [0, 360)
  double declination_deg;         ///< apparent
  double apparent_longitude_deg;  ///< ecliptic
  double distance_au;             ///< Earth-Sun distance
  double gmst_deg;                ///< Greenwich mean sidereal time
  double subsolar_lat_deg, subsolar_lon_deg;
  Vec3 direction_ecef;  ///< unit vector from the Earth's centre towards the Sun
};

/// `julian_day` is the Julian Day of the instant (JD 2451545.0 = 2000-01-01T12:00).
SunPosition sun_position_jd(double julian_day);
SunPosition sun_position(const UtcTime& t);

/// Greenwich mean sidereal time [deg] (Meeus eq. 12.4).
double gmst_deg(double julian_day);

}  // namespace nephos::earth
