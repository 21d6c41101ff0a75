#include "nephos/weather/masks.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>

#include "nephos/core/error.hpp"
#include "nephos/core/progress.hpp"
#include "nephos/weather/sampler.hpp"

namespace nephos::weather {

const char* name(CloudType t) {
  static const char* n[] = {"low_stratus", "low_cumulus", "altostratus", "cirrus"};
  return n[static_cast<int>(t)];
}
const char* long_name(CloudType t) {
  static const char* n[] = {"low stratus cloud fraction", "low cumulus cloud fraction", "altostratus cloud fraction",
                            "cirrus cloud fraction"};
  return n[static_cast<int>(t)];
}
CloudType cloud_type_from_name(const std::string& s) {
  for (int t = 0; t < cloud_type_count; ++t)
    if (s == name(static_cast<CloudType>(t))) return static_cast<CloudType>(t);
  throw ValueError("unknown cloud type '" + s + "' (known: low_stratus, low_cumulus, altostratus, cirrus)");
}

MaskParams::MaskParams() {
  constexpr double inf = std::numeric_limits<double>::infinity();
  // Table 1 thresholds; the bands and the choices marked (*) are documented in docs/weather.md.
  (*this)[CloudType::low_stratus] = {0, 3000, -inf, 0.12, -40, inf, TemperatureReference::sample};  // (*) no vz > 0
  (*this)[CloudType::low_cumulus] = {0, 3000, 0.12, 5.99, -40, inf, TemperatureReference::sample};
  (*this)[CloudType::altostratus] = {3000, 7000, -inf, inf, -40, inf, TemperatureReference::sample};  // (*) no vz
  (*this)[CloudType::cirrus] = {3000, 20000, -inf, inf, -inf, -40, TemperatureReference::cloud_top};  // (*) top T
}

MaskParams MaskParams::from(const ParamDict& dict) {
  MaskParams p;
  const ParamDict cf = dict.table("cloud_fraction");
  p.cloud_fraction.rh_exponent = cf.get_in("rh_exponent", p.cloud_fraction.rh_exponent, 1e-3, 100.0);
  p.cloud_fraction.condensate_coefficient =
      cf.get_in("condensate_coefficient", p.cloud_fraction.condensate_coefficient, 0.0, 1e9);
  p.cloud_fraction.min_condensate_kg_kg =
      cf.get_in("min_condensate_kg_kg", p.cloud_fraction.min_condensate_kg_kg, 0.0, 1.0);
  p.cloud_fraction.rh_critical = cf.get_in("rh_critical", p.cloud_fraction.rh_critical, 0.0, 0.999);
  p.cloud_fraction.use_condensate = cf.get("use_condensate", p.cloud_fraction.use_condensate);
  const ParamDict m = dict.table("masks");
  p.vertical_step_m = m.get_in("vertical_step_m", p.vertical_step_m, 1.0, 10000.0);
  p.updraft_ramp_pa_s = m.get_in("updraft_ramp_pa_s", p.updraft_ramp_pa_s, 0.0, 100.0);
  p.temperature_ramp_k = m.get_in("temperature_ramp_k", p.temperature_ramp_k, 0.0, 100.0);
  p.cloud_top_min_fraction = m.get_in("cloud_top_min_fraction", p.cloud_top_min_fraction, 0.0, 1.0);
  for (int t = 0; t < cloud_type_count; ++t) {
    const ParamDict d = m.table(name(static_cast<CloudType>(t)));
    auto& tp = p.types[static_cast<std::size_t>(t)];
    tp.band_bottom_m = d.get_in("band_bottom_m", tp.band_bottom_m, 0.0, 100e3);
    tp.band_top_m = d.get_in("band_top_m", tp.band_top_m, 0.0, 100e3);
    tp.updraft_min_pa_s = d.get("updraft_min_pa_s", tp.updraft_min_pa_s);
    tp.updraft_max_pa_s = d.get("updraft_max_pa_s", tp.updraft_max_pa_s);
    tp.temperature_min_c = d.get("temperature_min_c", tp.temperature_min_c);
    tp.temperature_max_c = d.get("temperature_max_c", tp.temperature_max_c);
    const std::string ref =
        d.get("temperature_at", tp.temperature_at == TemperatureReference::sample ? "sample" : "cloud_top");
    if (ref == "sample")
      tp.temperature_at = TemperatureReference::sample;
    else if (ref == "cloud_top")
      tp.temperature_at = TemperatureReference::cloud_top;
    else
      throw ConfigError(
          "expected \"sample\" or \"cloud_top\", got \"" + ref + "\"",
          {.file = dict.source(), .key = std::string("masks.") + name(static_cast<CloudType>(t)) + ".temperature_at"});
    if (!(tp.band_top_m > tp.band_bottom_m))
      throw ConfigError("band_top_m must exceed band_bottom_m",
                        {.file = dict.source(), .key = std::string("masks.") + name(static_cast<CloudType>(t))});
  }
  return p;
}

double saturation_mixing_ratio(double temperature_k, double pressure_pa) {
  const double tc = temperature_k - 273.15;
  // Alduchov & Eskridge (1996), J. Appl. Meteor. 35, 601-609, eqs. 21 (water) and 23 (ice) [Pa].
  const double e_water = 610.94 * std::exp(17.625 * tc / (tc + 243.04));
  const double e_ice = 611.21 * std::exp(22.587 * tc / (tc + 273.86));
  const double w = std::clamp(tc / 20.0 + 1.0, 0.0, 1.0);  // 1 at 0 degC, 0 at -20 degC
  const double es = std::min(w * e_water + (1 - w) * e_ice, 0.5 * pressure_pa);
  constexpr double eps = 0.622;  // R_d / R_v
  return eps * es / (pressure_pa - (1 - eps) * es);
}

double cloud_fraction(double rh, double qc, double temperature_k, double pressure_pa, const CloudFractionParams& p) {
  if (std::isnan(rh) || std::isnan(temperature_k)) return 0;
  rh = std::clamp(rh, 0.0, 1.0);
  if (std::isnan(qc) || !p.use_condensate) {  // no condensate in the file: a humidity ramp
    return std::clamp((rh - p.rh_critical) / (1 - p.rh_critical), 0.0, 1.0);
  }
  if (qc <= p.min_condensate_kg_kg * pressure_pa / 1e5) return 0;
  const double qs = saturation_mixing_ratio(temperature_k, pressure_pa);
  const double one_minus_rh = std::max(1e-10, 1 - rh);
  // GFS progcld1: tem1 = a / min(max(((1-RH) q_s)^(1/4), 1e-4), 1); value = min(tem1 q_c, 50).
  const double denom = std::clamp(std::sqrt(std::sqrt(one_minus_rh * qs)), 1e-4, 1.0);
  const double arg = std::min(p.condensate_coefficient / denom * qc, 50.0);
  return std::clamp(std::pow(rh, p.rh_exponent) * (1 - std::exp(-arg)), 0.0, 1.0);
}

namespace {
// 1 inside [lo, hi], 0 outside, linear edges of total width `ramp` centred on the bounds.
double gate(double x, double lo, double hi, double ramp) {
  if (std::isnan(x)) return 0;
  auto up = [&](double v, double edge) {
    if (std::isinf(edge)) return edge < 0 ? 1.0 : 0.0;
    if (ramp <= 0) return v >= edge ? 1.0 : 0.0;
    return std::clamp((v - edge) / ramp + 0.5, 0.0, 1.0);
  };
  return up(x, lo) * (1 - up(x, hi));
}

// Maximum-random overlap over samples bottom to top: contiguous cloudy samples form one layer
// whose cover is their maximum; separate layers overlap at random.
struct Overlap {
  double clear = 1, run = 0;
  void add(double c) {
    if (c > 0) {
      run = std::max(run, c);
    } else if (run > 0) {
      clear *= 1 - run;
      run = 0;
    }
  }
  double cover() const { return 1 - clear * (1 - run); }
};
}  // namespace

std::array<std::array<double, 2>, cloud_type_count> condensate_layers_m(const MaskParams& params) {
  std::array<std::array<double, 2>, cloud_type_count> out{};
  for (std::size_t t = 0; t < out.size(); ++t) {
    const CloudTypeMaskParams& a = params.types[t];
    double bottom = a.band_bottom_m;
    for (const CloudTypeMaskParams& b : params.types)  // the bands below that a's overlaps
      if (b.band_bottom_m <= a.band_bottom_m && b.band_top_m < a.band_top_m) bottom = std::max(bottom, b.band_top_m);
    out[t] = {bottom, a.band_top_m};
  }
  return out;
}

WeatherMasks compute_masks(const WeatherGrid& weather, const MaskParams& params) {
  if (auto miss = missing_for_masks(weather); !miss.empty())
    throw FormatError(fmt::format("weather masks need {} on isobaric levels", fmt::join(miss, ", ")),
                      {.file = weather.metadata().source});
  const LatLonGrid& g = weather.grid();
  WeatherMasks out;
  out.grid = g;
  out.condensate_layer_m = condensate_layers_m(params);
  for (auto& v : out.value) v.assign(g.size(), 0.0f);

  double z_lo = 1e30, z_hi = -1e30;
  for (const auto& t : params.types) {
    z_lo = std::min(z_lo, t.band_bottom_m);
    z_hi = std::max(z_hi, t.band_top_m);
  }
  const int n_samples = static_cast<int>(std::ceil((z_hi - z_lo) / params.vertical_step_m));
  const WeatherSampler sampler(weather);
  Progress progress("weather masks", static_cast<std::size_t>(g.nlat));

#pragma omp parallel for schedule(dynamic)
  for (int j = 0; j < g.nlat; ++j) {
    std::vector<double> z(static_cast<std::size_t>(n_samples)), c(z.size()), tc(z.size()), up(z.size());
    for (int i = 0; i < g.nlon; ++i) {
      const Column col = sampler.column_at_node(j, i);
      const std::size_t cell =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(g.nlon) + static_cast<std::size_t>(i);
      if (!col.valid()) continue;
      const double ground = weather.has_orography() ? weather.orography_m()[cell] : -1e30;
      for (int s = 0; s < n_samples; ++s) {
        const auto su = static_cast<std::size_t>(s);
        z[su] = z_lo + (s + 0.5) * params.vertical_step_m;
        const WeatherSample ws = col.at(z[su]);
        c[su] = z[su] < ground ? 0.0
                               : cloud_fraction(ws.relative_humidity, ws.cloud_water_kg_kg, ws.temperature_k,
                                                ws.pressure_pa, params.cloud_fraction);
        tc[su] = ws.temperature_k - 273.15;
        up[su] = ws.updraft_pa_s();
      }
      for (int t = 0; t < cloud_type_count; ++t) {
        const CloudTypeMaskParams& tp = params.types[static_cast<std::size_t>(t)];
        double t_top = std::numeric_limits<double>::quiet_NaN();
        if (tp.temperature_at == TemperatureReference::cloud_top)
          for (int s = n_samples - 1; s >= 0; --s) {
            const auto su = static_cast<std::size_t>(s);
            if (z[su] >= tp.band_bottom_m && z[su] < tp.band_top_m && c[su] > params.cloud_top_min_fraction) {
              t_top = tc[su];
              break;
            }
          }
        Overlap ov;
        for (int s = 0; s < n_samples; ++s) {
          const auto su = static_cast<std::size_t>(s);
          if (z[su] < tp.band_bottom_m || z[su] >= tp.band_top_m) continue;
          const double t_ref = tp.temperature_at == TemperatureReference::sample ? tc[su] : t_top;
          const double w = gate(up[su], tp.updraft_min_pa_s, tp.updraft_max_pa_s, params.updraft_ramp_pa_s) *
                           gate(t_ref, tp.temperature_min_c, tp.temperature_max_c, params.temperature_ramp_k);
          ov.add(c[su] * w);
        }
        out.value[static_cast<std::size_t>(t)][cell] = static_cast<float>(ov.cover());
      }
    }
    progress.advance();
  }
  return out;
}

double area_mean(const LatLonGrid& g, const std::vector<float>& v) {
  double s = 0, w = 0;
  for (int j = 0; j < g.nlat; ++j) {
    const double a = g.cell_area_fraction(j);
    for (int i = 0; i < g.nlon; ++i) {
      const float x = v[static_cast<std::size_t>(j * g.nlon + i)];
      if (std::isnan(x)) continue;
      s += a * x;
      w += a;
    }
  }
  return w > 0 ? s / w : std::numeric_limits<double>::quiet_NaN();
}

double area_correlation(const LatLonGrid& g, const std::vector<float>& a, const std::vector<float>& b) {
  double w = 0, sa = 0, sb = 0;
  for (int j = 0; j < g.nlat; ++j)
    for (int i = 0; i < g.nlon; ++i) {
      const auto q = static_cast<std::size_t>(j * g.nlon + i);
      if (std::isnan(a[q]) || std::isnan(b[q])) continue;
      const double ar = g.cell_area_fraction(j);
      w += ar;
      sa += ar * a[q];
      sb += ar * b[q];
    }
  const double ma = sa / w, mb = sb / w;
  double sab = 0, saa = 0, sbb = 0;
  for (int j = 0; j < g.nlat; ++j)
    for (int i = 0; i < g.nlon; ++i) {
      const auto q = static_cast<std::size_t>(j * g.nlon + i);
      if (std::isnan(a[q]) || std::isnan(b[q])) continue;
      const double ar = g.cell_area_fraction(j);
      sab += ar * (a[q] - ma) * (b[q] - mb);
      saa += ar * (a[q] - ma) * (a[q] - ma);
      sbb += ar * (b[q] - mb) * (b[q] - mb);
    }
  return sab / std::sqrt(saa * sbb);
}

std::vector<LayerAgreement> compare_with_gfs_cloud_cover(const WeatherMasks& masks, const WeatherGrid& weather) {
  std::vector<LayerAgreement> out;
  const LatLonGrid& g = masks.grid;
  auto add = [&](CloudLayer layer, const std::string& label, const std::vector<float>& m) {
    if (!weather.has_cloud_cover(layer)) return;
    const auto& tcc = weather.cloud_cover(layer);
    out.push_back({layer, label, area_mean(g, m), area_mean(g, tcc), area_correlation(g, m, tcc)});
  };
  std::vector<float> low(g.size());
  for (std::size_t q = 0; q < low.size(); ++q)
    low[q] = std::max(masks[CloudType::low_stratus][q], masks[CloudType::low_cumulus][q]);
  add(CloudLayer::low, "max(low_stratus, low_cumulus)", low);
  add(CloudLayer::middle, "altostratus", masks[CloudType::altostratus]);
  add(CloudLayer::high, "cirrus", masks[CloudType::cirrus]);
  return out;
}

}  // namespace nephos::weather
