#pragma once
// Atmospheric profiles: one column's temperature, pressure, water vapour and ozone from the
// ground to the top of the atmosphere, from a weather file (GFS) or the AFGL US standard
// atmosphere (Anderson et al. 1986), which also continues a weather file's column above its top.
#include <vector>

#include "nephos/weather/weather_grid.hpp"

namespace nephos::atmosphere {

/// Well-mixed gases' volume mixing ratios [mol mol^-1], 2011 global means (NOAA GML: CO2 390.1
/// ppm, N2O 324 ppb, CH4 1.80 ppm); O2 the dry air's 20.95 %.
inline constexpr double co2_vmr = 390e-6, n2o_vmr = 0.324e-6, ch4_vmr = 1.80e-6, o2_vmr = 0.2095;

/// A column, levels bottom (the ground) to top.
struct Profile {
  std::vector<double> z_m;        ///< geometric altitude above mean sea level
  std::vector<double> p_pa;       ///< pressure
  std::vector<double> t_k;        ///< temperature
  std::vector<double> h2o_vmr;    ///< water vapour volume mixing ratio [mol mol^-1]
  std::vector<double> o3_vmr;     ///< ozone volume mixing ratio [mol mol^-1]
  double skin_temperature_k = 0;  ///< the ground's temperature (may differ from the air's)
  std::size_t size() const { return z_m.size(); }
  /// Precipitable water [kg m^-2] (= mm): the hydrostatic integral of the specific humidity.
  double precipitable_water_kg_m2() const;
  /// Total ozone [Dobson units].
  double total_ozone_du() const;
  /// Temperature [K] at altitude z [m], linear between levels; clamped beyond the ends.
  double temperature_at(double z_m) const;
};

/// The AFGL US standard atmosphere, 0-120 km (data/spectroscopy/afgl_us_standard.csv).
const Profile& us_standard();

/// Saturation vapour pressure [Pa] over liquid water and over ice at temperature t [K]
/// (Murphy & Koop 2005, eqs. 10 and 7).
double saturation_pressure_water_pa(double t_k);
double saturation_pressure_ice_pa(double t_k);

/// The column of grid node (j, i): GFS's levels above the ground (height from gh, temperature
/// t, water vapour from r, ozone from o3mr), the ground from orog, sp and the skin temperature,
/// continued above the file's top by the US standard atmosphere. Where the file lacks a field
/// the standard atmosphere's profile stands in: humidity above 100 hPa (GFS's r is unreliable
/// there), ozone below its lowest o3mr level (scaled so that the column has GFS's tozne).
/// Relative humidity is over liquid water above 0 C, over ice below -20 C and blended in
/// between, as NCEP defines it.
Profile weather_profile(const weather::WeatherGrid& w, int j, int i);

}  // namespace nephos::atmosphere
