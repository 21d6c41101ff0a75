#include "nephos/atmosphere/clear_sky.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "nephos/atmosphere/band_model.hpp"
#include "nephos/atmosphere/rayleigh.hpp"
#include "nephos/earth/earth.hpp"

namespace nephos::atmosphere {
namespace {
constexpr double m_air = 28.9644e-3, m_h2o = 18.01528e-3;  // [kg mol^-1]
constexpr double avogadro = 6.02214076e23, boltzmann = 1.380649e-23;
constexpr double atm_cm_m2 = 2.6867811e23;                  // molecules m^-2 in one atm-cm
constexpr double rho0_cm3 = 2.6867811e19 * 273.15 / 296.0;  // CKD reference density [cm^-3]
constexpr double c2_cm_k = 1.438776877;                     // hc/k [cm K]
constexpr double p0 = 101325.0, t0 = 273.15;

// One layer's optics per sub-band: scaled amounts per gas and the continuum optical depth.
struct LayerOptics {
  std::array<double, gas_count> w{};  // scaled amounts
  double tau_cont = 0;                // vertical continuum (+ N2, + Chappuis) optical depth
  double t_mean = 0;                  // layer-mean temperature [K]
};

// The amounts of the layer between levels a (below) and b, in sub-band s.
LayerOptics layer_optics(const Profile& p, std::size_t a, std::size_t b, const SubBand& s) {
  LayerOptics l;
  const double dp = std::max(0.0, p.p_pa[a] - p.p_pa[b]);
  const double pm = 0.5 * (p.p_pa[a] + p.p_pa[b]), tm = 0.5 * (p.t_k[a] + p.t_k[b]);
  const double h2o = 0.5 * (p.h2o_vmr[a] + p.h2o_vmr[b]), o3 = 0.5 * (p.o3_vmr[a] + p.o3_vmr[b]);
  l.t_mean = tm;
  const double molecules_m2 = dp * avogadro / (earth::g0_m_s2 * m_air);  // air in the layer
  const double eps = m_h2o / m_air;
  const double q = eps * h2o / (1 - (1 - eps) * h2o);
  std::array<double, gas_count> u{};
  u[static_cast<std::size_t>(Gas::h2o)] = q * dp / earth::g0_m_s2 * 0.1;  // kg m^-2 -> g cm^-2
  u[static_cast<std::size_t>(Gas::co2)] = co2_vmr * molecules_m2 / atm_cm_m2;
  u[static_cast<std::size_t>(Gas::o3)] = o3 * molecules_m2 / atm_cm_m2;
  u[static_cast<std::size_t>(Gas::n2o)] = n2o_vmr * molecules_m2 / atm_cm_m2;
  u[static_cast<std::size_t>(Gas::ch4)] = ch4_vmr * molecules_m2 / atm_cm_m2;
  u[static_cast<std::size_t>(Gas::o2)] = o2_vmr * molecules_m2 / atm_cm_m2;
  // (P/P0)^n (T0/T)^m as one exponential per gas, the logarithms shared.
  const double log_p = std::log(pm / p0), log_t = std::log(t0 / tm);
  for (std::size_t g = 0; g < gas_count; ++g)
    if (s.gas[g].n > 0) l.w[g] = u[g] * std::exp(s.n[g] * log_p + s.m[g] * log_t);
  // Water-vapour continuum (CKD): tau = R(nu, T) C~(nu, T) (rho / rho0) N_w, R = nu tanh(hc nu / 2kT).
  const double nu = 1e4 / s.wavelength_um;
  const double radiation = nu * std::tanh(c2_cm_k * nu / (2 * tm));
  const double n_air_cm3 = pm / (boltzmann * tm) * 1e-6, n_w_cm3 = h2o * n_air_cm3;
  const double n_w_col_cm2 = h2o * molecules_m2 * 1e-4;
  const double self = s.self_296 > 0 && s.self_260 > 0
                          ? s.self_296 * std::pow(s.self_260 / s.self_296, (296.0 - tm) / 36.0)
                          : s.self_296;
  l.tau_cont = radiation * 1e-20 * (self * n_w_cm3 + s.foreign_296 * (n_air_cm3 - n_w_cm3)) / rho0_cm3 * n_w_col_cm2;
  // N2 collision-induced absorption (per km of air scaled to 0.781 (P/P0)^2 (T0/T)^1.5).
  if (s.n2_per_km > 0) {
    const double dz_km = 287.05 * tm / earth::g0_m_s2 * std::log(p.p_pa[a] / p.p_pa[b]) * 1e-3;
    l.tau_cont += s.n2_per_km * 0.781 * std::pow(pm / p0, 2) * std::pow(t0 / tm, 1.5) * dz_km;
  }
  l.tau_cont += s.o3_visible * u[static_cast<std::size_t>(Gas::o3)];  // Chappuis
  return l;
}

// The profile cut at the sensor: its levels below z_s and one at z_s (interpolated).
Profile below_sensor(const Profile& p, double z_s) {
  if (z_s >= p.z_m.back()) return p;
  Profile q;
  q.skin_temperature_k = p.skin_temperature_k;
  for (std::size_t k = 0; k < p.size(); ++k) {
    if (p.z_m[k] < z_s) {
      q.z_m.push_back(p.z_m[k]), q.p_pa.push_back(p.p_pa[k]), q.t_k.push_back(p.t_k[k]);
      q.h2o_vmr.push_back(p.h2o_vmr[k]), q.o3_vmr.push_back(p.o3_vmr[k]);
      continue;
    }
    if (k == 0) break;
    const double f = (z_s - p.z_m[k - 1]) / (p.z_m[k] - p.z_m[k - 1]);
    auto lin = [&](const std::vector<double>& v) { return v[k - 1] + f * (v[k] - v[k - 1]); };
    q.z_m.push_back(z_s), q.t_k.push_back(lin(p.t_k));
    q.p_pa.push_back(std::exp(std::log(p.p_pa[k - 1]) + f * (std::log(p.p_pa[k]) - std::log(p.p_pa[k - 1]))));
    q.h2o_vmr.push_back(lin(p.h2o_vmr)), q.o3_vmr.push_back(lin(p.o3_vmr));
    break;
  }
  return q;
}

// The cumulative amounts of paths through a column's layers: path k crosses layers k..last
// (from_top: a path down from the top) or 0..k (a path up from the bottom).
struct PathAmounts {
  std::array<std::vector<double>, gas_count> w;  // scaled amount per gas
  std::vector<double> tau;                       // continuum optical depth
  void accumulate(const std::vector<LayerOptics>& layers, bool from_top) {
    const std::size_t n = layers.size();
    for (auto& v : w) v.resize(n);
    tau.resize(n);
    std::array<double, gas_count> sum{};
    double tau_sum = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t k = from_top ? n - 1 - j : j;
      for (std::size_t g = 0; g < gas_count; ++g) sum[g] += layers[k].w[g], w[g][k] = sum[g];
      tau_sum += layers[k].tau_cont, tau[k] = tau_sum;
    }
  }
};

// A column's paths and their transmittances, kept across its sub-bands (no allocation per
// sub-band): the amounts, the transmittances along the view (or the diffuse sky's) and the Sun's
// paths, and scratch.
struct PathWork {
  PathAmounts amounts;
  std::vector<double> t, t_sun, scaled, gas_t;
};

// The transmittance of every path of w.amounts at air mass m into t: the continuum's
// exponential times each absorbing gas's fitted transmittance, in gas order; each gas's over all
// the paths at once (ExpSum::transmittances).
void path_transmittances(const SubBand& s, double m, std::vector<double>& t, PathWork& w) {
  const PathAmounts& a = w.amounts;
  const std::size_t n = a.tau.size();
  t.resize(n), w.scaled.resize(n), w.gas_t.resize(n);
  for (std::size_t k = 0; k < n; ++k) t[k] = std::exp(-a.tau[k] * m);
  for (std::size_t g = 0; g < gas_count; ++g) {
    if (s.gas[g].n == 0) continue;
    for (std::size_t k = 0; k < n; ++k) w.scaled[k] = a.w[g][k] * m;
    s.gas[g].transmittances(w.scaled.data(), n, w.gas_t.data());
    for (std::size_t k = 0; k < n; ++k)
      if (a.w[g][k] > 0) t[k] *= w.gas_t[k];
  }
}

double band_rayleigh_tau(const optics::Band& b, double p_pa, double lat) {
  // The band's mean over five wavelengths (the optical depth varies as lambda^-4 across it).
  double sum = 0;
  for (int i = 0; i < 5; ++i)
    sum += rayleigh_optical_depth(b.lo_um + (i + 0.5) * (b.hi_um - b.lo_um) / 5, p_pa, lat, 0.0);
  return sum / 5;
}

// One sub-band's share of the sky's downwelling thermal radiance at the bottom of a column
// (ClearSkyColumn::sky_down), from its layers (bottom first) and their Planck radiances:
// upwards, B(T_layer) times the drop in the diffuse transmittance from the bottom across it
// (w: the column's path work, reused).
double sky_down_part(const SubBand& s, const std::vector<LayerOptics>& layers, const std::vector<double>& planck,
                     PathWork& w) {
  w.amounts.accumulate(layers, false);
  path_transmittances(s, diffusivity_air_mass, w.t, w);
  double t_below = 1, radiance = 0;
  for (std::size_t k = 0; k < layers.size(); ++k) {
    radiance += planck[k] * (t_below - w.t[k]);
    t_below = w.t[k];
  }
  return s.weight * radiance;
}

// The layers of profile p in sub-band s, and their Planck radiances [W m^-2 sr^-1 um^-1] in a
// thermal band (0 in a solar one: the air's emission is nothing there).
void column_layers(const Profile& p, const SubBand& s, bool thermal, std::vector<LayerOptics>& layers,
                   std::vector<double>& planck) {
  layers.resize(p.size() - 1), planck.resize(p.size() - 1);
  for (std::size_t k = 0; k + 1 < p.size(); ++k) {
    layers[k] = layer_optics(p, k, k + 1, s);
    planck[k] = thermal ? optics::planck(s.wavelength_um, layers[k].t_mean) : 0.0;
  }
}
}  // namespace

namespace {
// Kasten & Young's (1989) zenith-angle term 0.50572 (96.07995 - z)^-1.6364, z in degrees.
double kasten_young_term(double zenith_deg) { return 0.50572 * std::pow(96.07995 - zenith_deg, -1.6364); }

// That term tabulated against s = sqrt(1 - mu) up to 80 degrees, linear between the nodes (the
// closed form beyond, where its curvature grows). The renderer asks for two air masses per pixel
// and layer: a table in the zenith angle needed acos(), a table in mu would meet the term's
// square-root cusp at the zenith, and in s the term is smooth (z ~ sqrt(2) s there), so one
// sqrt() finds the node. Within 1e-8 of the closed form's air mass, relative
// (AirMass.FollowsKastenAndYoungsFormula).
struct KastenYoungTable {
  static constexpr double top_deg = 80.0;
  static constexpr double step_s = 1e-4;  // h^2 / 8 of the term's curvature in s (~1 at 80 deg): 7e-9 relative
  const double mu_top = std::cos(top_deg * M_PI / 180);
  std::vector<double> term;
  KastenYoungTable() : term(static_cast<std::size_t>(std::sqrt(1 - mu_top) / step_s) + 2) {
    for (std::size_t i = 0; i < term.size(); ++i) {
      const double si = static_cast<double>(i) * step_s;  // the last node's mu is still above 0
      term[i] = kasten_young_term(std::acos(1 - si * si) * 180 / M_PI);
    }
  }
  /// The term at mu in [mu_top, 1].
  double at(double mu) const {
    const double x = std::sqrt(std::max(0.0, 1 - mu)) / step_s;
    const auto i = std::min(static_cast<std::size_t>(x), term.size() - 2);
    return term[i] + (x - static_cast<double>(i)) * (term[i + 1] - term[i]);
  }
};
}  // namespace

double air_mass(double mu) {
  static const KastenYoungTable table;
  if (mu >= table.mu_top) return 1 / (std::min(mu, 1.0) + table.at(mu));
  const double zenith_deg = std::acos(std::clamp(mu, -1.0, 1.0)) * 180 / M_PI;
  if (zenith_deg >= 96.0) return 40.0;
  return 1 / (std::max(mu, 0.0) + kasten_young_term(zenith_deg));
}

ClearSkyColumn clear_sky_column(const Profile& full, const optics::Band& b, const ColumnGeometry& g, double lat) {
  const Profile p = below_sensor(full, g.sensor_altitude_m);
  ClearSkyColumn c;
  const std::size_t nl = p.size();
  if (nl < 2) return c;
  c.view_air_mass = g.view_air_mass, c.sun_air_mass = g.sun_air_mass;
  c.z_m.assign(p.z_m.begin(), p.z_m.end());
  c.t_view.assign(nl, 0.0f), c.path_radiance.assign(nl, 0.0f), c.t_solar.assign(nl, 0.0f);
  c.tau_rayleigh.resize(nl);
  const double tau_r_surface = band_rayleigh_tau(b, 101325.0, lat);
  for (std::size_t k = 0; k < nl; ++k) c.tau_rayleigh[k] = static_cast<float>(tau_r_surface * p.p_pa[k] / 101325.0);
  const bool solar = b.sunlit();
  const double m_v = g.view_air_mass, m_2 = g.view_air_mass + std::max(g.sun_air_mass, 0.0);
  // The sky above the ground is all the air, whether or not the sensor is inside it.
  const bool whole = g.sensor_altitude_m >= full.z_m.back();
  std::vector<LayerOptics> layers, sky_layers;
  std::vector<double> planck, sky_planck;
  PathWork w;
  for (const SubBand& s : gas_model(b).sub) {
    column_layers(p, s, b.thermal, layers, planck);
    if (b.thermal) {
      if (!whole) column_layers(full, s, true, sky_layers, sky_planck);
      c.sky_down += whole ? sky_down_part(s, layers, planck, w) : sky_down_part(s, sky_layers, sky_planck, w);
    }
    // Downwards from the sensor (the top level): cumulative amounts, transmittance, emission.
    w.amounts.accumulate(layers, true);
    path_transmittances(s, m_v, w.t, w);
    const bool sunward = solar && g.sun_air_mass > 0;
    if (sunward) path_transmittances(s, m_2, w.t_sun, w);
    const std::vector<double>& t_view = w.t;
    double t_above = 1, radiance = 0;
    c.t_view[nl - 1] += static_cast<float>(s.weight);
    c.t_solar[nl - 1] += static_cast<float>(s.weight);
    for (std::size_t k = nl - 1; k-- > 0;) {
      const double t_here = t_view[k];
      if (b.thermal) radiance += planck[k] * (t_above - t_here);
      t_above = t_here;
      c.t_view[k] += static_cast<float>(s.weight * t_here);
      c.path_radiance[k] += static_cast<float>(s.weight * radiance);
      if (sunward) c.t_solar[k] += static_cast<float>(s.weight * w.t_sun[k]);
    }
  }
  return c;
}

ClearSkySample sample(const ClearSkyColumn& c, double z) {
  ClearSkySample s;
  if (!c.valid()) return s;
  const std::size_t n = c.z_m.size();
  std::size_t hi =
      static_cast<std::size_t>(std::upper_bound(c.z_m.begin(), c.z_m.end(), static_cast<float>(z)) - c.z_m.begin());
  hi = std::clamp<std::size_t>(hi, 1, n - 1);
  const double f = std::clamp((z - c.z_m[hi - 1]) / (c.z_m[hi] - c.z_m[hi - 1]), 0.0, 1.0);
  auto lin = [&](const std::vector<float>& v) { return static_cast<float>(v[hi - 1] + f * (v[hi] - v[hi - 1])); };
  s.t_view = lin(c.t_view), s.path_radiance = lin(c.path_radiance), s.t_solar = lin(c.t_solar);
  s.tau_rayleigh = lin(c.tau_rayleigh);
  return s;
}

double clear_sky_radiance(const ClearSkyColumn& c, const optics::Band& b, double t_surface_k) {
  return optics::band_planck(b, t_surface_k) * c.t_view.front() + c.path_radiance.front();
}

}  // namespace nephos::atmosphere
