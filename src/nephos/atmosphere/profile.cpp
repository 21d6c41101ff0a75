#include "nephos/atmosphere/profile.hpp"

#include <algorithm>
#include <cmath>

#include "nephos/core/error.hpp"
#include "nephos/earth/earth.hpp"

namespace nephos::atmosphere {

namespace data {
extern const double afgl_us_standard[];  // [km, hPa, K, ppmv H2O, ppmv O3] rows
extern const std::size_t afgl_us_standard_rows, afgl_us_standard_cols;
}  // namespace data

namespace {
constexpr double m_air = 28.9644e-3, m_h2o = 18.01528e-3, m_o3 = 47.9982e-3;  // [kg mol^-1]
constexpr double avogadro = 6.02214076e23;
constexpr double loschmidt_m3 = 2.6867811e25;  // [m^-3] at 273.15 K, 1 atm
constexpr double dobson_m2 = 2.6867811e20;     // molecules m^-2 in one Dobson unit
constexpr double eps = m_h2o / m_air;

// Linear interpolation of y over ascending x at xq, clamped to the ends.
double interp(const std::vector<double>& x, const std::vector<double>& y, double xq) {
  if (xq <= x.front()) return y.front();
  if (xq >= x.back()) return y.back();
  const auto hi = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), xq) - x.begin());
  const double f = (xq - x[hi - 1]) / (x[hi] - x[hi - 1]);
  return y[hi - 1] + f * (y[hi] - y[hi - 1]);
}

// Log-linear in pressure: the standard atmosphere's pressure at altitude z.
double standard_pressure_pa(double z_m) {
  const Profile& s = us_standard();
  if (z_m <= s.z_m.front()) return s.p_pa.front();
  if (z_m >= s.z_m.back()) return s.p_pa.back();
  const auto hi = static_cast<std::size_t>(std::upper_bound(s.z_m.begin(), s.z_m.end(), z_m) - s.z_m.begin());
  const double f = (z_m - s.z_m[hi - 1]) / (s.z_m[hi] - s.z_m[hi - 1]);
  return std::exp(std::log(s.p_pa[hi - 1]) + f * (std::log(s.p_pa[hi]) - std::log(s.p_pa[hi - 1])));
}

// The mixing ratio of water vapour at relative humidity rh and temperature t [K], pressure p
// [Pa]: e = rh e_s, over water above 0 C, over ice below -20 C, blended linearly in between.
double h2o_vmr_from_rh(double rh, double t_k, double p_pa) {
  const double f = std::clamp((t_k - 253.15) / 20.0, 0.0, 1.0);
  const double es = f * saturation_pressure_water_pa(t_k) + (1 - f) * saturation_pressure_ice_pa(t_k);
  const double e = std::clamp(rh, 0.0, 1.0) * std::min(es, 0.5 * p_pa);
  return e / p_pa;
}
}  // namespace

double saturation_pressure_water_pa(double t) {
  // Murphy & Koop (2005), eq. 10: 123-332 K.
  const double ln = 54.842763 - 6763.22 / t - 4.210 * std::log(t) + 0.000367 * t +
                    std::tanh(0.0415 * (t - 218.8)) * (53.878 - 1331.22 / t - 9.44523 * std::log(t) + 0.014025 * t);
  return std::exp(ln);
}

double saturation_pressure_ice_pa(double t) {
  // Murphy & Koop (2005), eq. 7: above 110 K.
  return std::exp(9.550426 - 5723.265 / t + 3.53068 * std::log(t) - 0.00728332 * t);
}

double Profile::precipitable_water_kg_m2() const {
  double sum = 0;
  for (std::size_t k = 0; k + 1 < size(); ++k) {
    auto q = [&](std::size_t i) { return eps * h2o_vmr[i] / (1 - (1 - eps) * h2o_vmr[i]); };
    sum += 0.5 * (q(k) + q(k + 1)) * (p_pa[k] - p_pa[k + 1]) / earth::g0_m_s2;
  }
  return sum;
}

double Profile::total_ozone_du() const {
  double n = 0;  // molecules m^-2: vmr dp / (g m_air / N_A)
  for (std::size_t k = 0; k + 1 < size(); ++k)
    n += 0.5 * (o3_vmr[k] + o3_vmr[k + 1]) * (p_pa[k] - p_pa[k + 1]) * avogadro / (earth::g0_m_s2 * m_air);
  return n / dobson_m2;
}

double Profile::temperature_at(double z) const { return interp(z_m, t_k, z); }

const Profile& us_standard() {
  static const Profile s = [] {
    Profile p;
    for (std::size_t r = 0; r < data::afgl_us_standard_rows; ++r) {
      const double* row = &data::afgl_us_standard[r * data::afgl_us_standard_cols];
      p.z_m.push_back(row[0] * 1000);
      p.p_pa.push_back(row[1] * 100);
      p.t_k.push_back(row[2]);
      p.h2o_vmr.push_back(row[3] * 1e-6);
      p.o3_vmr.push_back(row[4] * 1e-6);
    }
    p.skin_temperature_k = p.t_k.front();
    return p;
  }();
  return s;
}

Profile weather_profile(const weather::WeatherGrid& w, int j, int i) {
  using weather::Field;
  using weather::SurfaceField;
  const std::size_t cell = static_cast<std::size_t>(j) * static_cast<std::size_t>(w.grid().nlon) + i;
  const Profile& std_atm = us_standard();
  auto single = [&](SurfaceField f, double fallback) {
    if (!w.has(f)) return fallback;
    const float v = w.surface(f)[cell];
    return std::isnan(v) ? fallback : static_cast<double>(v);
  };
  // The file's levels, bottom first, with a height and a temperature.
  struct Level {
    double z, p, t, rh, o3;
  };
  std::vector<Level> levels;
  for (int k = 0; k < w.level_count(); ++k) {
    if (!w.has(Field::geopotential_height, k) || !w.has(Field::temperature, k)) continue;
    const double gh = w.level_data(Field::geopotential_height, k)[cell];
    const double t = w.level_data(Field::temperature, k)[cell];
    if (std::isnan(gh) || std::isnan(t)) continue;
    const double rh = w.has(Field::relative_humidity, k) ? w.level_data(Field::relative_humidity, k)[cell] : NAN;
    const double o3 = w.has(Field::ozone, k) ? w.level_data(Field::ozone, k)[cell] : NAN;
    const double z = earth::geometric_from_geopotential_m(gh);
    if (!levels.empty() && z <= levels.back().z) continue;
    levels.push_back({z, w.pressure_levels_pa()[static_cast<std::size_t>(k)], t, rh, o3});
  }
  if (levels.size() < 2) throw ValueError("a weather column needs at least two levels with gh and t", {.field = "gh"});
  // The ground: orography, surface pressure (else from the levels, log-linear), the air's
  // temperature extrapolated from the lowest level above it at 6.5 K km^-1.
  const double z_s = w.has_orography() ? std::max(0.0, static_cast<double>(w.orography_m()[cell])) : 0.0;
  auto above = std::find_if(levels.begin(), levels.end(), [&](const Level& l) { return l.z > z_s + 1; });
  if (above == levels.end()) throw ValueError("no weather level above the ground", {.field = "gh"});
  const Level& first = *above;
  const double p_s_fallback = first.p * std::exp(earth::g0_m_s2 * (first.z - z_s) / (287.05 * first.t));
  const double p_s = std::max(single(SurfaceField::surface_pressure, p_s_fallback), first.p * 1.0001);
  const double t_s = first.t + 0.0065 * (first.z - z_s);
  Profile out;
  auto push = [&](double z, double p, double t, double h2o, double o3) {
    out.z_m.push_back(z), out.p_pa.push_back(p), out.t_k.push_back(t);
    out.h2o_vmr.push_back(h2o), out.o3_vmr.push_back(o3);
  };
  auto h2o_at = [&](const Level& l) {
    return l.p >= 100e2 && !std::isnan(l.rh) ? h2o_vmr_from_rh(l.rh, l.t, l.p)
                                             : interp(std_atm.z_m, std_atm.h2o_vmr, l.z);
  };
  auto o3_at = [&](const Level& l) {
    return !std::isnan(l.o3) ? l.o3 * m_air / m_o3 : interp(std_atm.z_m, std_atm.o3_vmr, l.z);
  };
  push(z_s, p_s, t_s, h2o_at(first), o3_at(first));
  for (auto it = above; it != levels.end(); ++it) push(it->z, it->p, it->t, h2o_at(*it), o3_at(*it));
  // Above the file's top: the standard atmosphere, its pressure scaled to meet the top level's
  // and its temperature offset by the difference there, fading over 10 km.
  const double z_top = out.z_m.back(), p_top = out.p_pa.back(), t_top = out.t_k.back();
  const double p_scale = p_top / standard_pressure_pa(z_top), dt = t_top - std_atm.temperature_at(z_top);
  for (std::size_t r = 0; r < std_atm.size(); ++r) {
    const double z = std_atm.z_m[r];
    if (z < z_top + 1000) continue;
    push(z, std_atm.p_pa[r] * p_scale, std_atm.t_k[r] + dt * std::exp(-(z - z_top) / 10e3), std_atm.h2o_vmr[r],
         std_atm.o3_vmr[r]);
  }
  // Ozone below GFS's lowest o3mr level, from the standard profile, scaled to GFS's total.
  if (w.has(SurfaceField::total_ozone)) {
    std::size_t k0 = out.size();
    for (std::size_t k = 0; k < out.size(); ++k)
      if (out.p_pa[k] <= 100e2 + 1) {
        k0 = k;
        break;
      }
    Profile lower = out;
    for (std::size_t k = k0; k < out.size(); ++k) lower.o3_vmr[k] = 0;
    const double du_lower = lower.total_ozone_du(), du_all = out.total_ozone_du();
    const double target = single(SurfaceField::total_ozone, du_all);
    if (du_lower > 0) {
      const double f = std::clamp((target - (du_all - du_lower)) / du_lower, 0.3, 3.0);
      for (std::size_t k = 0; k < k0; ++k) out.o3_vmr[k] *= f;
    }
  }
  out.skin_temperature_k = single(SurfaceField::skin_temperature, t_s);
  return out;
}

}  // namespace nephos::atmosphere
