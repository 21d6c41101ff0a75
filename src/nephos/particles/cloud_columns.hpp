#pragma once
// The weather a particle system needs, whatever model it came from (WRF or GFS): per column the
// cloud base and top heights and the cloud optical thickness (the particle-cloud paper's eq. 2), and the 3D wind
// on the model's levels, on a planar grid of uniform cells, at one or more times.
//
// Planar grid: x towards the grid's east, y towards its north, both in metres from the region's
// centre; z is height above mean sea level [m]. WRF grids are planar already (projection
// coordinates, spacing DX/DY; winds are grid-relative, so they match). GFS latitude-longitude
// cells are mapped by a local equirectangular projection about the region's centre (see
// docs/particles.md for its error).
#include <cstddef>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "nephos/core/time.hpp"
#include "nephos/weather/weather_grid.hpp"

namespace nephos::particles {

/// Uniform planar cells: column i (x) is the fast index, row j (y) the slow one, as the seed's
/// one-dimensional array A (eqs. 3-4: col = R mod COLS, row = floor(R / COLS)).
struct PlanarGrid {
  int cols = 0, rows = 0;
  double dx_m = 0, dy_m = 0;                      ///< cell size
  double x0_m = 0, y0_m = 0;                      ///< centre of cell (0, 0)
  double centre_lat_deg = 0, centre_lon_deg = 0;  ///< where the plane touches the Earth (for the sun)
  std::size_t size() const { return static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows); }
  double x(double col) const { return x0_m + col * dx_m; }
  double y(double row) const { return y0_m + row * dy_m; }
};

/// Cloud microphysics constants behind eq. 2 (documented in docs/particles.md).
struct ColumnParams {
  double effective_radius_liquid_um = 10;  ///< typical of stratiform water cloud (Stephens 1978)
  double effective_radius_ice_um = 25;     ///< typical of mid-latitude ice cloud
  double cloud_threshold_kg_kg = 1e-6;     ///< a layer is cloudy above this condensate mixing ratio
  /// GFS clwmr is total condensate: ice fraction ramps linearly from 0 at ice_ramp_warm_k to 1 at
  /// ice_ramp_cold_k.
  double ice_ramp_warm_k = 273.15, ice_ramp_cold_k = 253.15;
};

/// Per-column cloud geometry and optical thickness at one time (cols*rows, row-major).
struct CloudColumns {
  std::vector<float> base_m, top_m;  ///< cloud base / top height above MSL [m]; NaN where clear
  std::vector<float> tau;            ///< visible optical thickness (eq. 2), 0 where clear
  float max_tau() const;
  float max_top_m() const;  ///< highest cloud top, 0 if none
  /// Extinction coefficient [1/m] of column c: tau / (top - base), 0 where clear.
  float sigma_per_m(std::size_t c) const;
};

/// The 3D wind on the model's levels: u along x, v along y, w up [m/s], and each level's height
/// [m] per column; level k, row j, column i at (k*rows + j)*cols + i, bottom level first.
struct WindVolume {
  int levels = 0;
  std::vector<float> z_m, u, v, w;
  /// Wind at planar (x, y) and height z: bilinear across the four nearest columns (clamped at the
  /// grid's edges), linear in height between levels (clamped above the top and below the bottom).
  glm::dvec3 sample(const PlanarGrid& g, double x_m, double y_m, double z_m) const;
};

struct WeatherFrame {
  double time_s = 0;  ///< seconds since the first frame
  UtcTime valid_time;
  CloudColumns columns;
  WindVolume wind;
  /// Sizes the fields for `columns` columns and `levels` wind levels; every column clear.
  void allocate(std::size_t columns, int levels);
};

/// Everything the particle system reads: a planar grid and its frames, ascending in time.
struct ParticleWeather {
  PlanarGrid grid;
  std::vector<WeatherFrame> frames;
  std::string source;  ///< file name(s), for metadata
  /// Throws ValueError if frames are empty, unsorted or sized unlike the grid.
  void validate() const;
};

/// The seed's "conversion of the resolution": every cell split into factor x factor cells, the
/// optical thickness interpolated bilinearly (so cloud edges fade over a coarse cell instead of
/// ending in a step), cloud base and top bilinearly over the cloudy neighbours only, the wind and
/// level heights bilinearly (which reproduces WindVolume::sample exactly inside the grid).
/// factor 1 returns a copy. Throws ValueError for factor < 1.
ParticleWeather refine(const ParticleWeather& w, int factor);
/// The factor that brings the larger cell side to at most target_m (1 if it is already).
int refine_factor_for(const PlanarGrid& g, double target_m);

/// Region of interest on the globe [deg]: south, west, north, east (west > east crosses 180 deg).
struct LatLonRegion {
  double lat0_deg = 0, lon0_deg = 0, lat1_deg = 0, lon1_deg = 0;
  static LatLonRegion parse(const std::string& text, const std::string& key);
};

/// What `nephos particles` and its benchmark use on GFS when not told otherwise: the North
/// Atlantic and Europe (fronts in the embedded sample), cells refined to at most 30 km.
inline constexpr LatLonRegion default_gfs_region{30, -50, 65, 10};
inline constexpr double default_refined_cell_m = 30000;

/// Liquid or ice optical thickness of a layer (eq. 2 with Gamma = 2 and the effective radius
/// r_e = <r^3>/<r^2>): tau = 3 * rho_air * q * dz / (2 * rho_condensate * r_e).
double layer_optical_thickness(double air_density_kg_m3, double mixing_ratio_kg_kg, double thickness_m,
                               double condensate_density_kg_m3, double effective_radius_m);

/// One model column, bottom layer first: each layer's lower and upper interface heights [m], air
/// density [kg/m^3] and liquid / ice mixing ratios [kg/kg].
struct LayerColumn {
  std::vector<double> z_lower_m, z_upper_m, air_density, q_liquid, q_ice;
  void resize(std::size_t layers);
};
struct ColumnCloud {
  float base_m, top_m, tau;  ///< NaN, NaN, 0 when no layer is cloudy
};
/// Cloud base (lower interface of the lowest cloudy layer), top (upper interface of the highest)
/// and total optical thickness (liquid + ice, eq. 2) of one column.
ColumnCloud column_cloud(const LayerColumn& c, const ColumnParams& p);
/// Stores column_cloud's result for column c of `columns`.
void store(CloudColumns& columns, std::size_t c, const ColumnCloud& cloud);

inline constexpr double rho_liquid_water = 1000.0;  ///< [kg/m^3]
inline constexpr double rho_ice = 917.0;            ///< [kg/m^3] (hexagonal ice at 0 C)
inline constexpr double r_dry_air = 287.04;         ///< specific gas constant of dry air [J/(kg K)]
inline constexpr double g0 = 9.80665;               ///< standard gravity [m/s^2]

/// GFS (or any WeatherGrid) frames -> particle weather over a region. Needs gh, t, clwmr, u, v
/// at common levels; omega (w) is optional (vertical motion 0 without it, with a warning).
/// Frames are sorted by valid time; all must share one grid. Throws FormatError naming the
/// missing field, ValueError for a region with fewer than 2x2 cells.
ParticleWeather from_weather_grids(const std::vector<weather::WeatherGrid>& grids, const LatLonRegion& region,
                                   const ColumnParams& params = {});

}  // namespace nephos::particles
