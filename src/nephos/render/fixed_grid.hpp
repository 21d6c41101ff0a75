#pragma once
// The GOES-R ABI fixed grid (GOES-R Product User's Guide, Vol. 3 "Level 1b products", section
// 5.1.2.8): a geostationary sensor at the perspective point 35 786 023 m above the GRS80 equator
// at the projection's longitude, sweeping in x (east-west scan angle, the outer axis) and y
// (north-south elevation angle), both in radians. Full-disc, CONUS/PACUS and mesoscale sectors
// at ABI's 0.5, 1 and 2 km sub-satellite resolutions (14, 28 and 56 microradians).
#include <cstdint>
#include <string>
#include <vector>

#include "nephos/earth/geometry.hpp"

namespace nephos::render {

/// The fixed grid's projection: scan angles <-> geodetic latitude and longitude on GRS80.
struct FixedGridProjection {
  static constexpr double semi_major_m = 6378137.0;      ///< GRS80 equatorial radius
  static constexpr double semi_minor_m = 6356752.31414;  ///< GRS80 polar radius (PUG's r_pol)
  static constexpr double perspective_height_m = 35786023.0;
  double lon0_deg = -75.0;  ///< longitude_of_projection_origin

  double satellite_distance_m() const { return semi_major_m + perspective_height_m; }  ///< PUG's H
  /// The perspective point, ECEF [m].
  earth::Vec3 satellite_ecef() const;
  /// Geodetic latitude and longitude [deg] seen at scan angles (x, y) [rad]; false off the Earth.
  bool to_geodetic(double x_rad, double y_rad, double& lat_deg, double& lon_deg) const;
  /// The unit vector at to_geodetic's latitude and longitude for scan angles given by their sines
  /// and cosines, in the frame of the projection's origin (x towards longitude lon0_deg on the
  /// equator, z north); false off the Earth. No angle is formed: a ray per pixel costs no
  /// inverse trigonometry.
  bool geodetic_up_at_origin(double sin_x, double cos_x, double sin_y, double cos_y, earth::Vec3& up) const;
  /// Scan angles [rad] of a point of the ellipsoid; false where the sensor cannot see it.
  bool to_scan(double lat_deg, double lon_deg, double& x_rad, double& y_rad) const;
  /// Unit line of sight (ECEF) at scan angles (x, y).
  earth::Vec3 line_of_sight(double x_rad, double y_rad) const;
};

/// A sector of the fixed grid: its pixel centres x0 + i dx, y0 + j dy (rows from the north).
struct FixedGridSector {
  std::string scene;         ///< "full", "conus" or "meso"
  char abbreviation = 'F';   ///< of the L1b file name: RadF, RadC, RadM
  double resolution_km = 2;  ///< ABI's nominal sub-satellite resolution of the grid (before any step)
  int step = 1;              ///< the native grid coarsened by this factor
  double x0_rad = 0, y0_rad = 0, dx_rad = 56e-6, dy_rad = -56e-6;
  int nx = 0, ny = 0;
  double x(int i) const { return x0_rad + i * dx_rad; }
  double y(int j) const { return y0_rad + j * dy_rad; }
};

/// The sector `scene` ("full", "conus" for GOES-East's CONUS and PACUS west of -105 deg, or
/// "meso:LAT,LON", 1000 km square on the full disc's grid) at resolution_km (0.5, 1 or 2),
/// coarsened by `step` (>= 1). ValueError naming "scene" or "abi_step".
FixedGridSector fixed_grid_sector(const FixedGridProjection& p, const std::string& scene, double resolution_km,
                                  int step);

/// Which pixels of a sector lie on the ellipsoid, and their geodetic extent (PUG Vol. 3's
/// geospatial_lat_lon_extent).
struct SectorCover {
  std::vector<std::uint8_t> on_earth;  ///< 1 where to_geodetic() finds the pixel's centre; rows from the north
  /// The extent [deg] of those pixels' centres, 0 with none. West and east are taken as longitudes
  /// relative to the projection's origin, so that a sector across the date line keeps its west
  /// edge west (GOES-West's full disc: west about 142, east about -56 [deg east]).
  double south = 0, north = 0, west = 0, east = 0;
};

/// The cover of sector `s` of projection `p`. Along a column the latitude rises northwards and
/// along a row the longitude eastwards, and the Earth's pixels of either are one run (the line of
/// sight sweeps a plane or a cone, each meeting the ellipsoid in one arc), so the extremes lie at
/// the runs' ends: to_geodetic() runs at those pixels alone.
SectorCover sector_cover(const FixedGridProjection& p, const FixedGridSector& s);

/// ABI's native resolution [km] of band 1-16: 0.5 (band 2), 1 (bands 1, 3, 5) or 2.
double abi_native_resolution_km(int abi_band);

}  // namespace nephos::render
