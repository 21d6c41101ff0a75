#pragma once
// A sensor: a pinhole camera in Earth-fixed space with a focal-plane array of width x height
// pixels and a horizontal field of view (square pixels). Presets for a geostationary full-disc
// imager and a nadir-looking low-orbit imager; a general look-at form for oblique views.
#include <memory>
#include <string>

#include "nephos/core/config.hpp"
#include "nephos/earth/geometry.hpp"
#include "nephos/render/fixed_grid.hpp"

namespace nephos::render {

inline constexpr double geostationary_altitude_m = 35786e3;
/// A pinhole's horizontal field of view lies in (0, max_fov_deg) [deg].
inline constexpr double max_fov_deg = 179;
inline constexpr bool fov_in_range(double fov_deg) { return fov_deg > 0 && fov_deg < max_fov_deg; }
/// A look-at camera's target lies at least this far from it [m].
inline constexpr double min_look_at_distance_m = 1;

/// An ABI sensor on the GOES-R fixed grid (fixed_grid.hpp): its projection, sector, nominal
/// sub-satellite longitude and platform ("G16", "G18").
struct FixedGridView {
  FixedGridProjection projection;
  FixedGridSector sector;
  double nominal_subpoint_lon_deg = -75.2;
  std::string platform = "G16";
  /// The line of sight through image point (x, y) [pixels, (0, 0) the north-west corner] from
  /// `position`: at the ellipsoid point the fixed grid assigns to it, taken at the same
  /// geodetic latitude and longitude on the renderer's sphere (so that pixels co-register with
  /// ABI's); off the ellipsoid, the scan angles' own line of sight.
  earth::Vec3 ray(const earth::Vec3& position, double x, double y) const;
  /// ray(position, i + dx, y) for the pixels i = 0 .. width - 1 into out, the row's scan angle
  /// found once.
  void row_rays(const earth::Vec3& position, double y, double dx, int width, earth::Vec3* out) const;
};

struct Sensor {
  earth::Vec3 position;            ///< ECEF [m]
  earth::Vec3 forward, right, up;  ///< orthonormal attitude (up: image top)
  double fov_deg = 20;             ///< full horizontal field of view
  int width = 1000, height = 1000;
  std::string description;
  std::shared_ptr<const FixedGridView> fixed_grid;  ///< set: rays on the ABI fixed grid, not a pinhole

  /// Unit direction of the ray through image point (x, y) in pixels (0,0 = top-left corner).
  earth::Vec3 ray(double x, double y) const { return ray(x, y, std::tan(0.5 * fov_deg * earth::deg)); }
  /// ray(x, y) with tan(fov_deg / 2) given (computed once for many rays).
  earth::Vec3 ray(double x, double y, double tan_half_fov) const {
    if (fixed_grid) return fixed_grid->ray(position, x, y);
    const double sx = (2.0 * x / width - 1.0) * tan_half_fov;
    const double sy = (1.0 - 2.0 * y / height) * tan_half_fov * height / width;
    return glm::normalize(forward + sx * right + sy * up);
  }
  /// The rays through the points (x + dx, row + dy) of the pixels of image row `row`, out[0 ..
  /// width - 1]: by default their centres (ray(x + 0.5, row + 0.5), with the field of view's
  /// tangent computed once).
  void row_rays(int row, earth::Vec3* out, double dx = 0.5, double dy = 0.5) const {
    if (fixed_grid) return fixed_grid->row_rays(position, row + dy, dx, width, out);
    const double t = std::tan(0.5 * fov_deg * earth::deg);
    for (int x = 0; x < width; ++x) out[x] = ray(x + dx, row + dy, t);
  }

  /// Full disc from geostationary orbit over longitude `lon_deg`, north up; the field of view
  /// holds the Earth plus a 100 km margin for cloud shells.
  static Sensor geostationary(double lon_deg, int width, int height);
  /// Nadir-looking from (lat, lon, altitude), north up.
  static Sensor nadir(double lat_deg, double lon_deg, double altitude_m, double fov_deg, int width, int height);
  /// From `from` towards `target`; `up_hint` (ECEF, need not be exact) sets the image's up, by
  /// default the local vertical at `from`.
  static Sensor look_at(const earth::Geodetic& from, const earth::Geodetic& target, double fov_deg, int width,
                        int height, const earth::Vec3* up_hint = nullptr);
  /// An ABI on the fixed grid: the sector's pixels; fov_deg such that a pixel's angular width is
  /// the grid's spacing (for the ray cones).
  static Sensor abi(const FixedGridView& view);
};

/// The fixed-grid view of "abi:east" (GOES-16: projection origin -75.0, nominal sub-satellite
/// point -75.2), "abi:west" (GOES-18: -137.0, -137.2) or "abi:LON" (both LON), sector `scene` at
/// resolution_km coarsened by `step`. ValueError naming "sensor", "scene" or "abi_step".
FixedGridView abi_view(const std::string& spec, const std::string& scene, double resolution_km, int step);

/// "geo:LON", "leo:LAT,LON,ALT_KM,FOV_DEG", "abi:east|west|LON" (the fixed grid of `scene` at
/// resolution_km, coarsened by abi_step: width and height are the sector's), or a TOML file with a [camera] table
/// (position_lat_deg, position_lon_deg, position_alt_m, look_at_lat_deg, look_at_lon_deg,
/// look_at_alt_m, fov_deg, optional up = [x, y, z] ECEF). Throws ValueError/ConfigError.
Sensor parse_sensor(const std::string& spec, int width, int height, const std::string& scene = "full",
                    double resolution_km = 2, int abi_step = 1);
Sensor sensor_from(const ParamDict& camera, int width, int height);

}  // namespace nephos::render
