#include "nephos/weather/synthetic.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"
#include "nephos/earth/earth.hpp"

namespace nephos::weather {
namespace {
constexpr double r_dry = 287.05;  // specific gas constant of dry air [J kg-1 K-1]

// A smooth random field on the sphere in [-1, 1]: a few waves with hashed phases.
double pattern(std::uint64_t seed, std::uint64_t channel, double lat_deg, double lon_deg, double h_gpm) {
  const double phi = lat_deg * earth::deg, lam = lon_deg * earth::deg;
  double s = 0, norm = 0;
  for (std::uint64_t k = 0; k < 6; ++k) {
    const double m = 1.0 + static_cast<double>(k % 3) * 2.0;  // zonal wavenumbers 1, 3, 5
    const double n = 1.0 + static_cast<double>(k / 2);
    const double ph1 = 2 * M_PI * uniform01(seed, channel, k, 0), ph2 = 2 * M_PI * uniform01(seed, channel, k, 1);
    const double amp = 1.0 / (1.0 + static_cast<double>(k));
    s += amp * std::cos(m * lam + ph1) * std::cos(n * phi + ph2 + h_gpm * 1e-4);
    norm += amp;
  }
  return s / norm;
}
}  // namespace

double synthetic_temperature_k(double lat_deg, double h_gpm, const SyntheticWeatherParams& p) {
  const double s2 = std::pow(std::sin(lat_deg * earth::deg), 2);
  const double t_surface = 300.0 - 50.0 * s2;         // [K]: 300 at the equator, 250 at the poles
  const double h_tropopause = 16000.0 - 8000.0 * s2;  // [gpm]
  return t_surface - p.lapse_rate_k_per_m * std::min(h_gpm, h_tropopause);
}

WeatherGrid make_synthetic_weather(const SyntheticWeatherParams& p) {
  if (!(p.resolution_deg > 0) || 180.0 / p.resolution_deg != std::round(180.0 / p.resolution_deg))
    throw ValueError(fmt::format("resolution {} deg must divide 180", p.resolution_deg), {.key = "resolution_deg"});
  LatLonGrid g;
  g.nlat = static_cast<int>(std::lround(180.0 / p.resolution_deg)) + 1;
  g.nlon = static_cast<int>(std::lround(360.0 / p.resolution_deg));
  g.lat0_deg = -90;
  g.dlat_deg = p.resolution_deg;
  g.lon0_deg = 0;
  g.dlon_deg = p.resolution_deg;
  std::vector<double> levels;
  for (double h : p.levels_hpa) levels.push_back(h * 100.0);
  std::sort(levels.begin(), levels.end(), std::greater<>());
  WeatherGrid w(g, levels);
  const int nk = w.level_count();
  std::vector<float*> slab(static_cast<std::size_t>(field_count * nk));
  for (int f = 0; f < field_count; ++f)
    if (static_cast<Field>(f) != Field::ozone)  // the synthetic weather has no ozone
      for (int k = 0; k < nk; ++k) slab[static_cast<std::size_t>(f * nk + k)] = w.level_data(static_cast<Field>(f), k);
  auto at = [&](Field f, int k) { return slab[static_cast<std::size_t>(static_cast<int>(f) * nk + k)]; };

#pragma omp parallel for
  for (int j = 0; j < g.nlat; ++j) {
    const double lat = g.lat(j);
    // Hypsometric integration upward from the surface pressure at z = 0 with 10 m steps:
    // d ln p / dH = -g0 / (R_d T(H)); record H where ln p crosses each level.
    std::vector<double> h_level(static_cast<std::size_t>(nk));
    double h = 0, lnp = std::log(p.surface_pressure_hpa * 100.0);
    int k = 0;
    while (k < nk && std::log(levels[static_cast<std::size_t>(k)]) > lnp) {     // levels under the surface
      const double dlnp = std::log(levels[static_cast<std::size_t>(k)]) - lnp;  // > 0: integrate downward
      h_level[static_cast<std::size_t>(k)] = -dlnp * r_dry * synthetic_temperature_k(lat, 0, p) / earth::g0_m_s2;
      ++k;
    }
    constexpr double dh = 10.0;
    while (k < nk) {
      // Midpoint rule on 10 m steps: error ~1e-4 gpm, far below the data's precision.
      const double next = lnp - dh * earth::g0_m_s2 / (r_dry * synthetic_temperature_k(lat, h + 0.5 * dh, p));
      while (k < nk && std::log(levels[static_cast<std::size_t>(k)]) >= next) {
        const double frac = (lnp - std::log(levels[static_cast<std::size_t>(k)])) / (lnp - next);
        h_level[static_cast<std::size_t>(k)] = h + frac * dh;
        ++k;
      }
      lnp = next;
      h += dh;
    }
    for (int i = 0; i < g.nlon; ++i) {
      const double lon = g.lon(i);
      const auto cell = static_cast<std::size_t>(j * g.nlon + i);
      for (int kk = 0; kk < nk; ++kk) {
        const double hk = h_level[static_cast<std::size_t>(kk)];
        const double t = synthetic_temperature_k(lat, hk, p);
        const double moist = pattern(p.seed, 1, lat, lon, hk);
        const double rh = std::clamp(0.55 + 0.5 * moist - 0.3 * std::max(0.0, hk - 12000.0) / 12000.0, 0.02, 1.0);
        const double omega = 0.3 * pattern(p.seed, 2, lat, lon, hk) * std::exp(-std::pow((hk - 5000.0) / 6000.0, 2));
        const double u = 30.0 * std::pow(std::sin(2 * lat * earth::deg), 2) * std::min(hk, 12000.0) / 12000.0;
        const double v = 5.0 * pattern(p.seed, 3, lat, lon, hk);
        const double qc = rh > 0.9 ? 2e-4 * (rh - 0.9) / 0.1 : 0.0;
        at(Field::geopotential_height, kk)[cell] = static_cast<float>(hk);
        at(Field::temperature, kk)[cell] = static_cast<float>(t);
        at(Field::relative_humidity, kk)[cell] = static_cast<float>(rh);
        at(Field::omega, kk)[cell] = static_cast<float>(omega);
        at(Field::u_wind, kk)[cell] = static_cast<float>(u);
        at(Field::v_wind, kk)[cell] = static_cast<float>(v);
        at(Field::cloud_water, kk)[cell] = static_cast<float>(qc);
      }
    }
  }
  w.metadata().source = fmt::format("synthetic seed={}", p.seed);
  w.metadata().valid_time = w.metadata().reference_time = p.valid_time;
  w.metadata().producer = "nephos synthetic";
  return w;
}

}  // namespace nephos::weather
