#include "nephos/weather/sampler.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "nephos/earth/earth.hpp"

namespace nephos::weather {
namespace {
constexpr double nan = std::numeric_limits<double>::quiet_NaN();
}

WeatherSampler::WeatherSampler(const WeatherGrid& weather) : w_(&weather) {}

WeatherSampler::Stencil WeatherSampler::stencil(double lat_deg, double lon_deg) const {
  const LatLonGrid& g = w_->grid();
  Stencil s{};
  s.inside = true;
  const double fy = std::clamp((lat_deg - g.lat0_deg) / g.dlat_deg, 0.0, static_cast<double>(g.nlat - 1));
  s.j0 = std::min(static_cast<int>(fy), g.nlat - 2);
  s.j1 = s.j0 + 1;
  s.wy = fy - s.j0;
  const double fx = earth::wrap_lon_360(lon_deg - g.lon0_deg) / g.dlon_deg;
  if (g.wraps()) {
    s.i0 = static_cast<int>(fx) % g.nlon;
    s.i1 = (s.i0 + 1) % g.nlon;
    s.wx = fx - std::floor(fx);
  } else {
    if (fx > g.nlon - 1 + 1e-9) s.inside = false;
    const double cx = std::min(fx, static_cast<double>(g.nlon - 1));
    s.i0 = std::min(static_cast<int>(cx), g.nlon - 2);
    s.i1 = s.i0 + 1;
    s.wx = cx - s.i0;
  }
  return s;
}

Column WeatherSampler::make_column(const std::array<std::size_t, 4>& cells,
                                   const std::array<double, 4>& weights) const {
  Column c;
  const int nk = w_->level_count();
  const auto& p = w_->pressure_levels_pa();
  for (auto& f : c.f_) f.assign(static_cast<std::size_t>(nk), nan);
  for (int fi = 0; fi < field_count; ++fi) {
    const auto f = static_cast<Field>(fi);
    for (int k = 0; k < nk; ++k) {
      if (!w_->has(f, k)) continue;
      const float* slab = w_->level_data(f, k);
      double sum = 0, wsum = 0;
      for (int q = 0; q < 4; ++q) {
        const float v = slab[cells[static_cast<std::size_t>(q)]];
        if (std::isnan(v) || weights[static_cast<std::size_t>(q)] == 0) continue;
        sum += weights[static_cast<std::size_t>(q)] * v;
        wsum += weights[static_cast<std::size_t>(q)];
      }
      c.f_[static_cast<std::size_t>(fi)][static_cast<std::size_t>(k)] = wsum > 0 ? sum / wsum : nan;
    }
  }
  // The vertical coordinate: levels with a valid geopotential height, ascending in height.
  const auto& gh = c.f_[static_cast<std::size_t>(Field::geopotential_height)];
  std::vector<int> keep;
  for (int k = 0; k < nk; ++k)
    if (!std::isnan(gh[static_cast<std::size_t>(k)]) &&
        (keep.empty() || gh[static_cast<std::size_t>(k)] > gh[static_cast<std::size_t>(keep.back())]))
      keep.push_back(k);
  if (keep.size() < 2) return Column{};
  Column out;
  for (auto& f : out.f_) f.reserve(keep.size());
  for (int k : keep) {
    out.h_.push_back(gh[static_cast<std::size_t>(k)]);
    out.lnp_.push_back(std::log(p[static_cast<std::size_t>(k)]));
    for (int fi = 0; fi < field_count; ++fi)
      out.f_[static_cast<std::size_t>(fi)].push_back(c.f_[static_cast<std::size_t>(fi)][static_cast<std::size_t>(k)]);
  }
  return out;
}

Column WeatherSampler::column(double lat_deg, double lon_deg) const {
  const Stencil s = stencil(lat_deg, lon_deg);
  if (!s.inside) return Column{};
  const auto n = static_cast<std::size_t>(w_->grid().nlon);
  const auto j0 = static_cast<std::size_t>(s.j0), j1 = static_cast<std::size_t>(s.j1);
  const auto i0 = static_cast<std::size_t>(s.i0), i1 = static_cast<std::size_t>(s.i1);
  return make_column({j0 * n + i0, j0 * n + i1, j1 * n + i0, j1 * n + i1},
                     {(1 - s.wy) * (1 - s.wx), (1 - s.wy) * s.wx, s.wy * (1 - s.wx), s.wy * s.wx});
}

Column WeatherSampler::column_at_node(int j, int i) const {
  const std::size_t cell =
      static_cast<std::size_t>(j) * static_cast<std::size_t>(w_->grid().nlon) + static_cast<std::size_t>(i);
  return make_column({cell, cell, cell, cell}, {1, 0, 0, 0});
}

double WeatherSampler::surface_height_m(double lat_deg, double lon_deg) const {
  if (!w_->has_orography()) return 0;
  const Stencil s = stencil(lat_deg, lon_deg);
  const auto& o = w_->orography_m();
  const auto n = static_cast<std::size_t>(w_->grid().nlon);
  auto at = [&](int j, int i) {
    return static_cast<double>(o[static_cast<std::size_t>(j) * n + static_cast<std::size_t>(i)]);
  };
  return (1 - s.wy) * ((1 - s.wx) * at(s.j0, s.i0) + s.wx * at(s.j0, s.i1)) +
         s.wy * ((1 - s.wx) * at(s.j1, s.i0) + s.wx * at(s.j1, s.i1));
}

double Column::interpolate(Field f, double lnp) const {
  const auto& v = f_[static_cast<std::size_t>(f)];
  const int n = static_cast<int>(h_.size());
  // lnp decreases with k. Find the nearest present levels below (larger lnp) and above.
  int below = -1, above = -1;
  for (int k = 0; k < n; ++k) {
    if (std::isnan(v[static_cast<std::size_t>(k)])) continue;
    if (lnp_[static_cast<std::size_t>(k)] >= lnp) {
      below = k;
    } else {
      above = k;
      break;
    }
  }
  if (above < 0)
    return below >= 0 && lnp_[static_cast<std::size_t>(below)] == lnp ? v[static_cast<std::size_t>(below)] : nan;
  if (below < 0) return v[static_cast<std::size_t>(above)];  // under the lowest level: hold its value
  const double a = lnp_[static_cast<std::size_t>(below)], b = lnp_[static_cast<std::size_t>(above)];
  const double t = (lnp - a) / (b - a);
  return v[static_cast<std::size_t>(below)] +
         t * (v[static_cast<std::size_t>(above)] - v[static_cast<std::size_t>(below)]);
}

WeatherSample Column::at(double altitude_m) const {
  WeatherSample s;
  s.altitude_m = altitude_m;
  const double h = earth::geopotential_from_geometric_m(altitude_m);
  s.geopotential_height_gpm = h;
  if (h_.empty()) {
    s.pressure_pa = s.temperature_k = s.relative_humidity = s.omega_pa_s = s.u_m_s = s.v_m_s = s.cloud_water_kg_kg =
        nan;
    return s;
  }
  // ln p is linear in height within each layer (hypsometric equation for an isothermal layer);
  // outside the profile the nearest layer's gradient is extended.
  const auto n = h_.size();
  std::size_t k = std::upper_bound(h_.begin(), h_.end(), h) - h_.begin();
  k = std::clamp<std::size_t>(k, 1, n - 1);
  const double t = (h - h_[k - 1]) / (h_[k] - h_[k - 1]);
  const double lnp = lnp_[k - 1] + t * (lnp_[k] - lnp_[k - 1]);
  s.pressure_pa = std::exp(lnp);
  s.temperature_k = interpolate(Field::temperature, lnp);
  s.relative_humidity = interpolate(Field::relative_humidity, lnp);
  s.omega_pa_s = interpolate(Field::omega, lnp);
  s.u_m_s = interpolate(Field::u_wind, lnp);
  s.v_m_s = interpolate(Field::v_wind, lnp);
  s.cloud_water_kg_kg = interpolate(Field::cloud_water, lnp);
  return s;
}

}  // namespace nephos::weather
