#pragma once
// A synthetic but physically consistent atmosphere, deterministic from a seed: for tests and
// for users without a weather file. Temperature follows a latitude-dependent troposphere with a
// constant lapse rate under an isothermal stratosphere; geopotential heights come from the
// hydrostatic (hypsometric) integration of that temperature, so gh, t and p agree exactly as in
// a real analysis. Humidity, omega and condensate are smooth random patterns on the sphere
// (sums of hashed-phase spherical waves), winds are zonal jets plus a random meridional part.
#include <cstdint>
#include <vector>

#include "nephos/weather/weather_grid.hpp"

namespace nephos::weather {

struct SyntheticWeatherParams {
  std::uint64_t seed = 1;
  double resolution_deg = 2.5;  ///< grid spacing (global grid, lat -90..90)
  std::vector<double> levels_hpa = {1000, 975, 950, 925, 900, 850, 800, 750, 700, 650, 600, 550, 500,
                                    450,  400, 350, 300, 250, 200, 150, 100, 70,  50,  30,  20,  10};
  double surface_pressure_hpa = 1013.25;
  double lapse_rate_k_per_m = 0.0065;
  UtcTime valid_time = UtcTime::from_civil(2011, 1, 15, 12);
};

WeatherGrid make_synthetic_weather(const SyntheticWeatherParams& params);

/// Temperature [K] of the synthetic atmosphere at latitude [deg] and geopotential height [gpm].
double synthetic_temperature_k(double lat_deg, double h_gpm, const SyntheticWeatherParams& params);

}  // namespace nephos::weather
