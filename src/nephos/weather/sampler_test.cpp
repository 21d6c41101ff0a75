#include "nephos/weather/sampler.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "nephos/earth/earth.hpp"
#include "nephos/weather/synthetic.hpp"

namespace nephos::weather {
namespace {

constexpr double r_dry = 287.05, t_iso = 250.0, p0 = 100000.0;
// Geopotential height of pressure p in an isothermal atmosphere: H = (R T / g0) ln(p0 / p).
double iso_height(double p) { return r_dry * t_iso / earth::g0_m_s2 * std::log(p0 / p); }

// A global 2.5-degree grid, isothermal, with analytic fields:
//   t = 250 K; u = 2 lat + 0.1 lon (linear: bilinear is exact inside a cell);
//   v = 10 cos(lon) (periodic); r = 0.5 + 0.1 ln(p/p0) (linear in ln p: log-p interpolation is exact),
//   r absent at 850 hPa.
WeatherGrid analytic_grid() {
  LatLonGrid g{73, 144, -90, 2.5, 0, 2.5};
  WeatherGrid w(g, {100000, 85000, 70000, 50000, 30000});
  for (int k = 0; k < w.level_count(); ++k) {
    const double p = w.pressure_levels_pa()[static_cast<std::size_t>(k)];
    float* gh = w.level_data(Field::geopotential_height, k);
    float* t = w.level_data(Field::temperature, k);
    float* u = w.level_data(Field::u_wind, k);
    float* v = w.level_data(Field::v_wind, k);
    float* r = p == 85000 ? nullptr : w.level_data(Field::relative_humidity, k);
    for (int j = 0; j < g.nlat; ++j)
      for (int i = 0; i < g.nlon; ++i) {
        const auto q = static_cast<std::size_t>(j * g.nlon + i);
        gh[q] = static_cast<float>(iso_height(p));
        t[q] = static_cast<float>(t_iso);
        u[q] = static_cast<float>(2 * g.lat(j) + 0.1 * g.lon(i));
        v[q] = static_cast<float>(10 * std::cos(g.lon(i) * earth::deg));
        if (r) r[q] = static_cast<float>(0.5 + 0.1 * std::log(p / p0));
      }
  }
  return w;
}

TEST(Sampler, BilinearIsExactForLinearFields) {
  const WeatherGrid w = analytic_grid();
  const WeatherSampler s(w);
  const double z = earth::geometric_from_geopotential_m(iso_height(70000));
  // float storage: u ~ 100 has a rounding of 100 * 2^-24 ~ 1e-5; 1e-4 covers it.
  EXPECT_NEAR(s.sample(12.3, 101.7, z).u_m_s, 2 * 12.3 + 0.1 * 101.7, 1e-4);
  EXPECT_NEAR(s.sample(-47.9, 3.1, z).u_m_s, 2 * -47.9 + 0.1 * 3.1, 1e-4);
}

TEST(Sampler, LongitudeWrapsBetweenLastAndFirstColumn) {
  const WeatherGrid w = analytic_grid();
  const WeatherSampler s(w);
  const double z = earth::geometric_from_geopotential_m(iso_height(50000));
  // Between lon 357.5 (column 143) and 360 = 0 (column 0): linear between the node values.
  const double a = 10 * std::cos(357.5 * earth::deg), b = 10.0;
  EXPECT_NEAR(s.sample(0, 358.75, z).v_m_s, 0.5 * (a + b), 1e-5);  // float rounding
  // The same point in the -180..180 convention.
  EXPECT_NEAR(s.sample(0, -1.25, z).v_m_s, 0.5 * (a + b), 1e-5);
}

TEST(Sampler, PolesUseThePoleRow) {
  const WeatherGrid w = analytic_grid();
  const WeatherSampler s(w);
  const double z = earth::geometric_from_geopotential_m(iso_height(50000));
  EXPECT_NEAR(s.sample(90, 10, z).u_m_s, 180 + 1.0, 1e-4);
  EXPECT_NEAR(s.sample(-90, 10, z).u_m_s, -180 + 1.0, 1e-4);
}

TEST(Sampler, PressureFollowsTheHypsometricProfile) {
  const WeatherGrid w = analytic_grid();
  const WeatherSampler s(w);
  // Isothermal: p(H) = p0 exp(-g0 H / (R T)) exactly, at any height between levels.
  for (double h : {500.0, 2345.0, 6000.0, 9000.0}) {
    const double z = earth::geometric_from_geopotential_m(h);
    const double expected = p0 * std::exp(-earth::g0_m_s2 * h / (r_dry * t_iso));
    EXPECT_NEAR(s.sample(10, 20, z).pressure_pa / expected, 1.0, 1e-5);  // float gh storage
  }
}

TEST(Sampler, LogPressureInterpolationSkipsMissingLevels) {
  const WeatherGrid w = analytic_grid();
  const WeatherSampler s(w);
  // At the 850 hPa height r is missing; interpolating 1000 and 700 hPa in ln p must give the
  // exact linear-in-ln-p value 0.5 + 0.1 ln(0.85) (a zero or NaN read would not).
  const double z = earth::geometric_from_geopotential_m(iso_height(85000));
  EXPECT_NEAR(s.sample(0, 0, z).relative_humidity, 0.5 + 0.1 * std::log(0.85), 1e-5);
}

TEST(Sampler, AboveTopIsNaNBelowBottomHolds) {
  const WeatherGrid w = analytic_grid();
  const WeatherSampler s(w);
  EXPECT_TRUE(std::isnan(s.sample(0, 0, 20000).relative_humidity));  // above 300 hPa (~8.9 km)
  EXPECT_NEAR(s.sample(0, 0, -200).relative_humidity, 0.5, 1e-6);    // below 1000 hPa: its value
}

TEST(Sampler, SyntheticAtmosphereMatchesUsStandardAtmosphere) {
  // At the latitude where the synthetic surface temperature is 288.15 K the synthetic
  // troposphere is the 1976 U.S. Standard Atmosphere (lapse 6.5 K/km, 1013.25 hPa).
  // The standard's gradient-layer relation p = p_b (T_b / T)^(g0 M0 / (R* L)) gives
  // 540.20 hPa at 5 km and 264.36 hPa at 10 km geopotential (U.S. Standard Atmosphere 1976,
  // eq. 33a and Table I in geopotential altitude). 0.1 % covers R_d = 287.05 vs 287.0528 and
  // the 0.5-degree bilinear interpolation of gh.
  SyntheticWeatherParams p;
  p.resolution_deg = 0.5;
  const double lat = std::asin(std::sqrt((300.0 - 288.15) / 50.0)) / earth::deg;
  const WeatherGrid w = make_synthetic_weather(p);
  const WeatherSampler s(w);
  EXPECT_NEAR(s.sample(lat, 10, earth::geometric_from_geopotential_m(5000)).pressure_pa / 54019.9, 1.0, 1e-3);
  EXPECT_NEAR(s.sample(lat, 10, earth::geometric_from_geopotential_m(10000)).pressure_pa / 26436.2, 1.0, 1e-3);
  EXPECT_NEAR(s.sample(lat, 10, earth::geometric_from_geopotential_m(5000)).temperature_k, 255.65, 0.05);
}

}  // namespace
}  // namespace nephos::weather
