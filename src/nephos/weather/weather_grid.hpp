#pragma once
// WeatherGrid: atmospheric fields on a regular latitude x longitude grid and isobaric levels,
// with each level's geopotential height. The common currency between weather readers (GRIB,
// synthetic) and everything that consumes weather (masks, wind advection, particles).
//
// Conventions (all readers normalise to these):
//  - latitude ascending from the southernmost row: lat(j) = lat0 + j*dlat, dlat > 0 [deg];
//  - longitude ascending eastwards from lon0 in [0, 360): lon(i) = lon0 + i*dlon [deg];
//  - levels sorted by decreasing pressure (bottom of the atmosphere first) [Pa];
//  - data index (level k, row j, column i) -> (k*nlat + j)*nlon + i; NaN where a value is missing;
//  - units are the GRIB ones converted to SI fractions: gh [gpm], t [K], r [fraction 0..1+],
//    w = omega [Pa/s, positive = sinking air], u/v [m/s], clwmr [kg/kg], cloud cover [fraction 0..1].
#include <array>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "nephos/core/time.hpp"

namespace nephos::weather {

/// The 3D fields nephos reads. Order is stable (used as an index).
enum class Field : int {
  geopotential_height,
  temperature,
  relative_humidity,
  omega,
  u_wind,
  v_wind,
  cloud_water,
  ozone
};
inline constexpr int field_count = 8;

struct FieldInfo {
  Field field;
  const char* grib_short_name;  ///< ecCodes shortName
  const char* units;            ///< units as stored in WeatherGrid
  const char* long_name;
  bool required;  ///< required for a complete weather description
  /// The range a value can physically take, in `units` (CF's valid_min, valid_max), wide of
  /// every extreme of the real atmosphere: a file's value outside it is damaged data.
  float valid_min, valid_max;
};
const FieldInfo& info(Field f);
const std::array<FieldInfo, field_count>& all_fields();

/// Single-level fields: the surface, the whole column, the tropopause, GFS's diagnosed cloud
/// tops and its top-of-atmosphere fluxes. Order is stable (used as an index).
enum class SurfaceField : int {
  land_fraction,                  ///< lsm [fraction]
  sea_ice_fraction,               ///< ci [fraction]
  snow_water_equivalent,          ///< sdwe [kg m-2]
  skin_temperature,               ///< t at the surface [K]
  surface_albedo,                 ///< al [fraction], GFS's broadband albedo (a 6-hour mean)
  u10,                            ///< 10u [m s-1], eastward wind 10 m above the ground
  v10,                            ///< 10v [m s-1]
  surface_pressure,               ///< sp [Pa]
  precipitable_water,             ///< pwat [kg m-2]
  total_ozone,                    ///< tozne [Dobson units]
  tropopause_pressure,            ///< trpp [Pa]
  tropopause_temperature,         ///< t at the tropopause [K]
  low_cloud_top_pressure,         ///< pres at lowCloudTop [Pa] (6-hour mean)
  middle_cloud_top_pressure,      ///< pres at middleCloudTop [Pa]
  high_cloud_top_pressure,        ///< pres at highCloudTop [Pa]
  convective_cloud_top_pressure,  ///< pres at convectiveCloudTop [Pa]
  high_cloud_top_temperature,     ///< t at highCloudTop [K]
  toa_outgoing_longwave,          ///< ulwrf at nominalTop [W m-2], a 6-hour mean from GFS's radiation
  toa_outgoing_shortwave,         ///< uswrf at nominalTop [W m-2], a 6-hour mean
};
inline constexpr int surface_field_count = 19;

struct SurfaceFieldInfo {
  SurfaceField field;
  const char* grib_short_name;  ///< ecCodes shortName
  const char* grib_level_type;  ///< ecCodes typeOfLevel
  const char* units;            ///< units as stored in WeatherGrid
  float scale;                  ///< GRIB unit -> stored unit
  const char* long_name;
  float valid_min, valid_max;  ///< as FieldInfo's, in `units`
};
const SurfaceFieldInfo& info(SurfaceField f);
const std::array<SurfaceFieldInfo, surface_field_count>& all_surface_fields();

/// GFS's diagnosed cloud-cover layers (GRIB shortName tcc on the given typeOfLevel).
enum class CloudLayer : int { low, middle, high, convective, boundary_layer, total };
inline constexpr int cloud_layer_count = 6;
const char* name(CloudLayer layer);
const char* grib_level_type(CloudLayer layer);

/// A regular latitude-longitude grid.
struct LatLonGrid {
  int nlat = 0, nlon = 0;
  double lat0_deg = 0, dlat_deg = 1;  ///< southernmost row and spacing (> 0)
  double lon0_deg = 0, dlon_deg = 1;  ///< first column in [0, 360) and spacing (> 0)

  double lat(int j) const { return lat0_deg + j * dlat_deg; }
  double lon(int i) const { return lon0_deg + i * dlon_deg; }
  /// True when the columns go all the way round (nlon * dlon == 360).
  bool wraps() const { return std::abs(nlon * dlon_deg - 360.0) < 1e-6 * 360.0; }
  std::size_t size() const { return static_cast<std::size_t>(nlat) * nlon; }
  /// Fraction of the sphere's area in row j's cells (one cell); rows at +-90 get the polar cap half-cell.
  double cell_area_fraction(int j) const;
  /// "regular_ll 144 x 73, 2.5 x 2.5 deg, lat -90..90, lon 0..357.5"
  std::string describe() const;
  bool operator==(const LatLonGrid&) const = default;
};

struct WeatherMetadata {
  UtcTime reference_time;      ///< analysis / model run time
  double forecast_step_h = 0;  ///< hours from reference to valid time
  UtcTime valid_time;
  std::string source;    ///< file it came from (or "synthetic seed=N")
  std::string producer;  ///< e.g. "kwbc (NCEP)"
  int grib_edition = 0;  ///< 1 or 2; 0 when not from GRIB
};

class WeatherGrid {
 public:
  WeatherGrid() = default;
  /// An empty grid: all fields absent.
  WeatherGrid(LatLonGrid grid, std::vector<double> pressure_levels_pa);

  const LatLonGrid& grid() const { return grid_; }
  const std::vector<double>& pressure_levels_pa() const { return pressure_pa_; }
  int level_count() const { return static_cast<int>(pressure_pa_.size()); }
  WeatherMetadata& metadata() { return meta_; }
  const WeatherMetadata& metadata() const { return meta_; }

  /// Whether field f has data at level k / at any level.
  bool has(Field f, int k) const { return present_[idx(f)][static_cast<std::size_t>(k)]; }
  bool has(Field f) const;
  /// Levels (indices) at which f is present, bottom first.
  std::vector<int> levels_of(Field f) const;

  float value(Field f, int k, int j, int i) const { return data_[idx(f)][index(k, j, i)]; }
  /// The nlat*nlon slab of f at level k (writable); marks the level present.
  float* level_data(Field f, int k);
  const float* level_data(Field f, int k) const { return data_[idx(f)].data() + index(k, 0, 0); }

  /// 2D fields: GFS cloud cover per layer [fraction], orography [m above MSL].
  bool has_cloud_cover(CloudLayer l) const { return !cloud_cover_[static_cast<std::size_t>(l)].empty(); }
  const std::vector<float>& cloud_cover(CloudLayer l) const { return cloud_cover_[static_cast<std::size_t>(l)]; }
  std::vector<float>& cloud_cover_mut(CloudLayer l) { return cloud_cover_[static_cast<std::size_t>(l)]; }
  bool has_orography() const { return !orography_m_.empty(); }
  const std::vector<float>& orography_m() const { return orography_m_; }
  std::vector<float>& orography_m_mut() { return orography_m_; }
  /// Single-level fields (nlat*nlon, grid order), empty where the file lacks them.
  bool has(SurfaceField f) const { return !surface_[static_cast<std::size_t>(f)].empty(); }
  const std::vector<float>& surface(SurfaceField f) const { return surface_[static_cast<std::size_t>(f)]; }
  std::vector<float>& surface_mut(SurfaceField f) { return surface_[static_cast<std::size_t>(f)]; }

  std::size_t index(int k, int j, int i) const {
    return (static_cast<std::size_t>(k) * grid_.nlat + static_cast<std::size_t>(j)) * grid_.nlon +
           static_cast<std::size_t>(i);
  }

 private:
  static std::size_t idx(Field f) { return static_cast<std::size_t>(f); }
  LatLonGrid grid_;
  std::vector<double> pressure_pa_;
  WeatherMetadata meta_;
  std::array<std::vector<float>, field_count> data_;
  std::array<std::vector<bool>, field_count> present_;
  std::array<std::vector<float>, cloud_layer_count> cloud_cover_;
  std::vector<float> orography_m_;
  std::array<std::vector<float>, surface_field_count> surface_;
};

/// Bilinear value of a 2D field (nlat*nlon, grid order) at (lat, lon) [deg]; longitudes wrap on
/// grids all the way round; beyond an outer row within one spacing of its pole (a global grid
/// whose rows stop short of the poles) the outer row holds up to the pole; NaN outside the
/// grid otherwise (beyond a regional grid's outer rows or columns).
float sample_bilinear(const LatLonGrid& g, const std::vector<float>& field, double lat_deg, double lon_deg);
/// Bicubic (Keys 1981 cubic convolution, a = -1/2: Catmull-Rom) value of a 2D field at (lat,
/// lon) [deg] from the 4 x 4 nodes around it, clamped to the range of the cell's four corners:
/// it passes through the nodes, reproduces polynomials up to degree two inside the grid (where
/// they stay within that range, e.g. monotone across the cell), has a continuous gradient
/// wherever the clamp is not active, and never leaves the cell's range (a cloud fraction stays a
/// fraction; no ringing next to a sharp edge). Where a point is inside the grid as for
/// sample_bilinear, nodes beyond the outer rows and columns repeat the outer ones; NaN outside
/// the grid, and where a node it needs is NaN, the bilinear value.
/// Why: thresholding a bilinear field draws the grid (its level sets are straight across a cell
/// where the corners differ along one axis), so clouds from a coarse grid came out as boxes.
float sample_bicubic(const LatLonGrid& g, const std::vector<float>& field, double lat_deg, double lon_deg);

/// Names the fields a capability needs and lacks, e.g. {"r", "w"}; empty when all are there.
std::vector<std::string> missing_for_masks(const WeatherGrid& w);
std::vector<std::string> missing_for_winds(const WeatherGrid& w);
/// Warns (spdlog), naming the file and the fields, when `w` lacks a wind component or gh, which
/// `use` (e.g. "the wind displacement maps") then takes as zero wind; silent otherwise.
void warn_if_winds_missing(const WeatherGrid& w, std::string_view use);

}  // namespace nephos::weather
