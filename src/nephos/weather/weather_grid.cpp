#include "nephos/weather/weather_grid.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "nephos/core/error.hpp"
#include "nephos/earth/earth.hpp"

namespace nephos::weather {

const std::array<FieldInfo, field_count>& all_fields() {
  static const std::array<FieldInfo, field_count> table{{
      {Field::geopotential_height, "gh", "gpm", "geopotential height", true, -2000, 120000},
      {Field::temperature, "t", "K", "air temperature", true, 100, 400},
      {Field::relative_humidity, "r", "1", "relative humidity", true, -0.05f, 2},
      {Field::omega, "w", "Pa s-1", "vertical velocity (omega, positive = sinking)", true, -200, 200},
      {Field::u_wind, "u", "m s-1", "eastward wind", true, -300, 300},
      {Field::v_wind, "v", "m s-1", "northward wind", true, -300, 300},
      {Field::cloud_water, "clwmr", "kg kg-1", "cloud condensate (liquid + ice) mixing ratio", false, -1e-3f, 0.1f},
      {Field::ozone, "o3mr", "kg kg-1", "ozone mixing ratio", false, -1e-5f, 1e-3f},
  }};
  return table;
}

const FieldInfo& info(Field f) { return all_fields()[static_cast<std::size_t>(f)]; }

const std::array<SurfaceFieldInfo, surface_field_count>& all_surface_fields() {
  using S = SurfaceField;
  static const std::array<SurfaceFieldInfo, surface_field_count> table{{
      {S::land_fraction, "lsm", "surface", "1", 1.0f, "land fraction", -0.01f, 1.01f},
      {S::sea_ice_fraction, "ci", "surface", "1", 1.0f, "sea-ice fraction", -0.01f, 1.01f},
      {S::snow_water_equivalent, "sdwe", "surface", "kg m-2", 1.0f, "snow water equivalent", -1, 1e6f},
      {S::skin_temperature, "t", "surface", "K", 1.0f, "skin temperature", 100, 400},
      {S::surface_albedo, "al", "surface", "1", 0.01f, "surface albedo (6-hour mean)", -0.01f, 1.01f},
      {S::u10, "10u", "heightAboveGround", "m s-1", 1.0f, "eastward wind at 10 m", -150, 150},
      {S::v10, "10v", "heightAboveGround", "m s-1", 1.0f, "northward wind at 10 m", -150, 150},
      {S::surface_pressure, "sp", "surface", "Pa", 1.0f, "surface pressure", 20000, 120000},
      {S::precipitable_water, "pwat", "atmosphereSingleLayer", "kg m-2", 1.0f, "precipitable water", -1, 250},
      {S::total_ozone, "tozne", "atmosphereSingleLayer", "DU", 1.0f, "total column ozone", 50, 1000},
      {S::tropopause_pressure, "trpp", "tropopause", "Pa", 1.0f, "tropopause pressure", 100, 120000},
      {S::tropopause_temperature, "t", "tropopause", "K", 1.0f, "tropopause temperature", 100, 400},
      {S::low_cloud_top_pressure, "pres", "lowCloudTop", "Pa", 1.0f, "low cloud top pressure (6-hour mean)", 0, 120000},
      {S::middle_cloud_top_pressure, "pres", "middleCloudTop", "Pa", 1.0f, "middle cloud top pressure (6-hour mean)", 0,
       120000},
      {S::high_cloud_top_pressure, "pres", "highCloudTop", "Pa", 1.0f, "high cloud top pressure (6-hour mean)", 0,
       120000},
      {S::convective_cloud_top_pressure, "pres", "convectiveCloudTop", "Pa", 1.0f, "convective cloud top pressure", 0,
       120000},
      {S::high_cloud_top_temperature, "t", "highCloudTop", "K", 1.0f, "high cloud top temperature (6-hour mean)", 100,
       400},
      {S::toa_outgoing_longwave, "ulwrf", "nominalTop", "W m-2", 1.0f,
       "outgoing long-wave flux at the top of the atmosphere (6-hour mean)", 0, 1000},
      {S::toa_outgoing_shortwave, "uswrf", "nominalTop", "W m-2", 1.0f,
       "outgoing short-wave flux at the top of the atmosphere (6-hour mean)", 0, 1600},
  }};
  return table;
}

const SurfaceFieldInfo& info(SurfaceField f) { return all_surface_fields()[static_cast<std::size_t>(f)]; }

const char* name(CloudLayer layer) {
  static const char* names[] = {"low", "middle", "high", "convective", "boundary_layer", "total"};
  return names[static_cast<int>(layer)];
}

const char* grib_level_type(CloudLayer layer) {
  static const char* names[] = {"lowCloudLayer",        "middleCloudLayer",        "highCloudLayer",
                                "convectiveCloudLayer", "boundaryLayerCloudLayer", "atmosphereSingleLayer"};
  return names[static_cast<int>(layer)];
}

double LatLonGrid::cell_area_fraction(int j) const {
  const double a = std::clamp(lat(j) - 0.5 * dlat_deg, -90.0, 90.0);
  const double b = std::clamp(lat(j) + 0.5 * dlat_deg, -90.0, 90.0);
  return earth::area_fraction_between(a, b) * (dlon_deg / 360.0);
}

std::string LatLonGrid::describe() const {
  return fmt::format("regular_ll {} x {} (lon x lat), {:g} x {:g} deg, lat {:g}..{:g}, lon {:g}..{:g}{}", nlon, nlat,
                     dlon_deg, dlat_deg, lat(0), lat(nlat - 1), lon(0), lon(nlon - 1), wraps() ? " (global)" : "");
}

WeatherGrid::WeatherGrid(LatLonGrid grid, std::vector<double> pressure_levels_pa)
    : grid_(grid), pressure_pa_(std::move(pressure_levels_pa)) {
  if (grid_.nlat < 2 || grid_.nlon < 2) throw ValueError("a weather grid needs at least 2 x 2 points");
  if (!std::is_sorted(pressure_pa_.begin(), pressure_pa_.end(), std::greater<>()))
    throw ValueError("pressure levels must be sorted by decreasing pressure");
  const std::size_t n = grid_.size() * pressure_pa_.size();
  for (auto& d : data_) d.assign(n, std::numeric_limits<float>::quiet_NaN());
  for (auto& p : present_) p.assign(pressure_pa_.size(), false);
}

bool WeatherGrid::has(Field f) const {
  const auto& p = present_[idx(f)];
  return std::find(p.begin(), p.end(), true) != p.end();
}

std::vector<int> WeatherGrid::levels_of(Field f) const {
  std::vector<int> out;
  for (int k = 0; k < level_count(); ++k)
    if (has(f, k)) out.push_back(k);
  return out;
}

float* WeatherGrid::level_data(Field f, int k) {
  present_[idx(f)][static_cast<std::size_t>(k)] = true;
  return data_[idx(f)].data() + index(k, 0, 0);
}

namespace {
// The grid cell that holds (lat, lon): its south-west node (j0, i0) and the point's position in
// it (wy, wx in [0, 1]); false outside a regional grid. Beyond an outer row within one spacing
// of its pole (a global grid whose rows stop short of the poles, e.g. at +-89.5 deg) the row is
// repeated up to the pole; beyond any other outer row the point is outside, as it is beyond a
// regional grid's outer columns. On grids all the way round longitudes wrap (the last cell
// joins the last column to the first).
struct Cell {
  int j0 = 0, i0 = 0;
  double wy = 0, wx = 0;
};
bool locate_cell(const LatLonGrid& g, double lat_deg, double lon_deg, Cell& c) {
  const double fy_raw = (lat_deg - g.lat0_deg) / g.dlat_deg;
  constexpr double eps = 1e-9;  // rows: a point on an outer row stays inside despite rounding
  const bool reaches_south = g.lat0_deg - g.dlat_deg <= -90 + eps;
  const bool reaches_north = g.lat(g.nlat - 1) + g.dlat_deg >= 90 - eps;
  if ((fy_raw < -eps && !reaches_south) || (fy_raw > g.nlat - 1 + eps && !reaches_north)) return false;
  const double fy = std::clamp(fy_raw, 0.0, static_cast<double>(g.nlat - 1));
  c.j0 = std::min(static_cast<int>(fy), g.nlat - 2);
  c.wy = fy - c.j0;
  const double fx = earth::wrap_lon_360(lon_deg - g.lon0_deg) / g.dlon_deg;
  if (g.wraps()) {
    c.i0 = static_cast<int>(fx) % g.nlon;
    c.wx = fx - std::floor(fx);
    return true;
  }
  if (fx > g.nlon - 1 + 1e-9) return false;
  c.i0 = std::min(static_cast<int>(fx), g.nlon - 2);
  c.wx = fx - c.i0;
  return true;
}

// The Keys (1981) cubic convolution weights, a = -1/2, of the nodes at -1, 0, 1, 2 for a point at
// t in [0, 1] between nodes 0 and 1. They sum to 1.
std::array<double, 4> keys_weights(double t) {
  const double t2 = t * t, t3 = t2 * t;
  return {0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2), 0.5 * (-3 * t3 + 4 * t2 + t), 0.5 * (t3 - t2)};
}
}  // namespace

float sample_bilinear(const LatLonGrid& g, const std::vector<float>& field, double lat_deg, double lon_deg) {
  Cell c;
  if (!locate_cell(g, lat_deg, lon_deg, c)) return std::numeric_limits<float>::quiet_NaN();
  const int j0 = c.j0, i0 = c.i0, i1 = g.wraps() ? (i0 + 1) % g.nlon : i0 + 1;
  const double wy = c.wy, fx = c.wx;
  auto at = [&](int j, int i) {
    return static_cast<double>(
        field[static_cast<std::size_t>(j) * static_cast<std::size_t>(g.nlon) + static_cast<std::size_t>(i)]);
  };
  const double v =
      (1 - wy) * ((1 - fx) * at(j0, i0) + fx * at(j0, i1)) + wy * ((1 - fx) * at(j0 + 1, i0) + fx * at(j0 + 1, i1));
  return static_cast<float>(v);
}

float sample_bicubic(const LatLonGrid& g, const std::vector<float>& field, double lat_deg, double lon_deg) {
  Cell c;
  if (!locate_cell(g, lat_deg, lon_deg, c)) return std::numeric_limits<float>::quiet_NaN();
  // Nodes beyond the outer rows (and a regional grid's outer columns) repeat the outer one.
  auto column = [&](int i) { return g.wraps() ? ((i % g.nlon) + g.nlon) % g.nlon : std::clamp(i, 0, g.nlon - 1); };
  auto at = [&](int j, int i) {
    return static_cast<double>(
        field[static_cast<std::size_t>(std::clamp(j, 0, g.nlat - 1)) * static_cast<std::size_t>(g.nlon) +
              static_cast<std::size_t>(column(i))]);
  };
  const std::array<double, 4> wx = keys_weights(c.wx), wy = keys_weights(c.wy);
  double v = 0;
  for (int b = 0; b < 4; ++b) {
    double row = 0;
    for (int a = 0; a < 4; ++a) row += wx[static_cast<std::size_t>(a)] * at(c.j0 - 1 + b, c.i0 - 1 + a);
    v += wy[static_cast<std::size_t>(b)] * row;
  }
  if (std::isnan(v)) return sample_bilinear(g, field, lat_deg, lon_deg);
  // Within the cell's corner range: no overshoot (ringing) next to a sharp change.
  const double c00 = at(c.j0, c.i0), c10 = at(c.j0, c.i0 + 1), c01 = at(c.j0 + 1, c.i0), c11 = at(c.j0 + 1, c.i0 + 1);
  const double lo = std::min(std::min(c00, c10), std::min(c01, c11)),
               hi = std::max(std::max(c00, c10), std::max(c01, c11));
  return static_cast<float>(std::clamp(v, lo, hi));
}

namespace {
std::vector<std::string> missing(const WeatherGrid& w, std::initializer_list<Field> fields) {
  std::vector<std::string> out;
  for (Field f : fields)
    if (!w.has(f)) out.emplace_back(info(f).grib_short_name);
  return out;
}
}  // namespace

std::vector<std::string> missing_for_masks(const WeatherGrid& w) {
  return missing(w, {Field::geopotential_height, Field::temperature, Field::relative_humidity, Field::omega});
}
std::vector<std::string> missing_for_winds(const WeatherGrid& w) {
  return missing(w, {Field::geopotential_height, Field::u_wind, Field::v_wind});
}
void warn_if_winds_missing(const WeatherGrid& w, std::string_view use) {
  const auto lacks = missing_for_winds(w);
  if (!lacks.empty())
    spdlog::warn("{}: no {} on pressure levels; {} take the wind there as 0", w.metadata().source,
                 fmt::join(lacks, ", "), use);
}

}  // namespace nephos::weather
