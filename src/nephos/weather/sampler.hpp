#pragma once
// Sampling a WeatherGrid at any (latitude, longitude, altitude above mean sea level).
//
// Horizontal: bilinear in latitude/longitude; longitudes wrap on global grids; beyond the
// outermost rows (poles of grids that stop short of +-90) the outermost row is used; outside a
// regional grid the sample is invalid (NaN).
// Vertical: the altitude [m] is converted to geopotential height (earth.hpp), ln p at that height
// comes from the column's (gh, ln p) profile, and each field is interpolated linearly in ln p
// between the nearest levels where that field exists (levels a field lacks are skipped, never
// read as zero). Below a field's lowest level its lowest value is used (pressure is extrapolated
// log-linearly instead); above its highest level the value is NaN.
#include <array>
#include <vector>

#include "nephos/weather/weather_grid.hpp"

namespace nephos::weather {

struct WeatherSample {
  double altitude_m = 0;  ///< geometric, above mean sea level
  double geopotential_height_gpm = 0;
  double pressure_pa = 0;
  double temperature_k = 0;
  double relative_humidity = 0;  ///< fraction (1 = saturated)
  double omega_pa_s = 0;         ///< dp/dt: positive = sinking air
  double u_m_s = 0, v_m_s = 0;
  double cloud_water_kg_kg = 0;  ///< NaN when the file has no clwmr
  /// Upward vertical velocity in pressure units [Pa/s]: -omega (positive = rising air).
  double updraft_pa_s() const { return -omega_pa_s; }
};

/// The vertical profile at one horizontal point.
class Column {
 public:
  WeatherSample at(double altitude_m) const;
  bool valid() const { return !h_.empty(); }
  /// Geopotential height of level k [gpm] (levels bottom first).
  double level_height_gpm(int k) const { return h_[static_cast<std::size_t>(k)]; }
  double field_at_level(Field f, int k) const { return f_[static_cast<std::size_t>(f)][static_cast<std::size_t>(k)]; }

 private:
  friend class WeatherSampler;
  double interpolate(Field f, double lnp) const;
  std::vector<double> h_;    ///< gh per level [gpm], ascending
  std::vector<double> lnp_;  ///< ln(pressure [Pa]) per level
  std::array<std::vector<double>, field_count> f_;
};

class WeatherSampler {
 public:
  explicit WeatherSampler(const WeatherGrid& weather);
  /// The profile at (lat, lon) [deg], bilinear between the four surrounding grid columns.
  Column column(double lat_deg, double lon_deg) const;
  /// The exact profile of grid column (j, i).
  Column column_at_node(int j, int i) const;
  WeatherSample sample(double lat_deg, double lon_deg, double altitude_m) const {
    return column(lat_deg, lon_deg).at(altitude_m);
  }
  /// Surface height [m] from orography (0 if the file has none).
  double surface_height_m(double lat_deg, double lon_deg) const;
  const WeatherGrid& weather() const { return *w_; }

 private:
  struct Stencil {
    int j0, j1, i0, i1;
    double wy, wx;
    bool inside;
  };
  Stencil stencil(double lat_deg, double lon_deg) const;
  Column make_column(const std::array<std::size_t, 4>& cells, const std::array<double, 4>& weights) const;
  const WeatherGrid* w_;
};

}  // namespace nephos::weather
