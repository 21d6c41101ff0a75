#include "nephos/render/earth_view.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "nephos/atmosphere/band_model.hpp"
#include "nephos/atmosphere/profile.hpp"
#include "nephos/core/simd_math.hpp"
#include "nephos/earth/earth.hpp"

namespace nephos::render {
namespace {
// upper_bound's index in the ascending levels z of zf: walked from `from` where that is a level
// index (a neighbouring query's: a level or two away), else searched; the same index either way.
std::size_t first_above(const std::vector<float>& z, float zf, std::size_t from) {
  const std::size_t n = z.size();
  if (from == 0 || from >= n) return static_cast<std::size_t>(std::upper_bound(z.begin(), z.end(), zf) - z.begin());
  std::size_t hi = from;
  while (hi > 0 && z[hi - 1] > zf) --hi;
  while (hi < n && z[hi] <= zf) ++hi;
  return hi;
}

// v at zq, linear in z between the levels z (ascending), v's ends beyond them. hint: in, where to
// walk from (first_above(); 0: search); out, zq's interval (upper_bound's index), when inside.
double along(const std::vector<float>& z, const std::vector<float>& v, double zq, std::size_t* hint = nullptr) {
  if (z.empty()) return 0;
  if (zq <= z.front()) return v.front();
  if (zq >= z.back()) return v.back();
  const std::size_t hi = first_above(z, static_cast<float>(zq), hint ? *hint : 0);
  if (hint) *hint = hi;
  const double f = (zq - z[hi - 1]) / (z[hi] - z[hi - 1]);
  return v[hi - 1] + f * (v[hi] - v[hi - 1]);
}

// The level interval of the optics levels z holding zq, as upper_bound's index hi (clamped to
// 1..n-1) and zq's share f of the way from z[hi - 1] to z[hi] (clamped to 0..1). hint: as
// along()'s (1 at the ground).
std::pair<std::size_t, double> optics_interval(const std::vector<float>& z, double zq, std::size_t* hint = nullptr) {
  const std::size_t n = z.size();
  std::size_t hi = first_above(z, static_cast<float>(zq), hint ? *hint : 0);
  if (hint) *hint = hi;
  hi = std::clamp<std::size_t>(hi, 1, n - 1);
  return {hi, std::clamp((zq - z[hi - 1]) / (z[hi] - z[hi - 1]), 0.0, 1.0)};
}

// A quantity between two levels' values at share f.
inline double between_levels(float lo, float hi, double f) { return lo + f * (hi - lo); }
}  // namespace

EarthView::EarthView(const weather::WeatherGrid* weather, const Sensor& sensor, const earth::SunPosition& sun,
                     const std::vector<const optics::Band*>& bands, bool atmosphere, double ground_temperature_k,
                     const std::vector<std::array<double, 2>>& condensate_layers)
    : weather_(weather),
      bands_(bands),
      atmosphere_(atmosphere),
      ground_temperature_k_(ground_temperature_k),
      sensor_position_(sensor.position),
      sun_direction_(sun.direction_ecef),
      condensate_layers_(condensate_layers) {
  const auto t0 = std::chrono::steady_clock::now();
  if (weather) {
    grid_ = weather->grid();
    has_condensate_ = weather->has(weather::Field::cloud_water);
  } else {
    grid_ = weather::LatLonGrid{1, 1, 0, 1, 0, 1};
  }
  const std::size_t n = grid_.size();
  nodes_.resize(n);
  // The bands' gas models, fitted once per process, a band per thread (~0.1 s each).
  if (atmosphere_) {
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t b = 0; b < bands_.size(); ++b) atmosphere::gas_model(*bands_[b]);
  }
#pragma omp parallel for schedule(dynamic, 16)
  for (std::size_t k = 0; k < n; ++k)
    build_node(k, static_cast<int>(k / static_cast<std::size_t>(grid_.nlon)),
               static_cast<int>(k % static_cast<std::size_t>(grid_.nlon)));
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void EarthView::build_node(std::size_t k, int j, int i) {
  Node& node = nodes_[k];
  const atmosphere::Profile p = weather_ ? atmosphere::weather_profile(*weather_, j, i) : atmosphere::us_standard();
  node.ground_height_m = static_cast<float>(p.z_m.front());
  for (std::size_t l = 0; l < p.size(); ++l) node.z.push_back(static_cast<float>(p.z_m[l]));
  for (std::size_t l = 0; l < p.size(); ++l) node.t.push_back(static_cast<float>(p.t_k[l]));
  if (weather_ && has_condensate_) {
    // Condensate at the weather's levels, in the profile's altitudes (kg kg^-1 * air density).
    node.condensate.assign(p.size(), 0.0f);
    const std::size_t cell =
        static_cast<std::size_t>(j) * static_cast<std::size_t>(grid_.nlon) + static_cast<std::size_t>(i);
    std::vector<float> zc, qc;
    for (int lev = 0; lev < weather_->level_count(); ++lev) {
      if (!weather_->has(weather::Field::cloud_water, lev) || !weather_->has(weather::Field::geopotential_height, lev))
        continue;
      const float q = weather_->level_data(weather::Field::cloud_water, lev)[cell];
      const float gh = weather_->level_data(weather::Field::geopotential_height, lev)[cell];
      const float t = weather_->level_data(weather::Field::temperature, lev)[cell];
      if (std::isnan(q) || std::isnan(gh) || std::isnan(t)) continue;
      const double rho = weather_->pressure_levels_pa()[static_cast<std::size_t>(lev)] / (287.05 * t);
      zc.push_back(static_cast<float>(earth::geometric_from_geopotential_m(gh)));
      qc.push_back(static_cast<float>(std::max(0.0f, q) * rho * 1000));
    }
    for (std::size_t l = 0; l < p.size() && zc.size() >= 2; ++l)
      node.condensate[l] = node.z[l] > zc.back() ? 0.0f : static_cast<float>(along(zc, qc, node.z[l]));
  }
  node.layers.assign(condensate_layers_.size(), LayerCondensate{});
  for (std::size_t l = 0; l < condensate_layers_.size() && !node.condensate.empty(); ++l) {
    // The midpoint rule over 64 steps of the layer's part above the ground.
    const double z0 = std::max<double>(condensate_layers_[l][0], node.z.front());
    const double z1 = std::min<double>(condensate_layers_[l][1], node.z.back());
    if (!(z1 > z0)) continue;
    constexpr int steps = 64;
    const double dz = (z1 - z0) / steps;
    double path = 0, q2 = 0, qz = 0;
    for (int step = 0; step < steps; ++step) {
      const double z = z0 + (step + 0.5) * dz, q = along(node.z, node.condensate, z);
      path += q * dz, q2 += q * q * dz, qz += q * z * dz;
    }
    if (path > 0) node.layers[l] = {path, q2 / path, along(node.z, node.t, qz / path)};
  }
  // The ground.
  if (weather_) {
    using S = weather::SurfaceField;
    const std::size_t cell =
        static_cast<std::size_t>(j) * static_cast<std::size_t>(grid_.nlon) + static_cast<std::size_t>(i);
    auto f = [&](S s, double fallback) {
      if (!weather_->has(s)) return fallback;
      const float v = weather_->surface(s)[cell];
      return std::isnan(v) ? fallback : static_cast<double>(v);
    };
    node.ground = surface::state(f(S::land_fraction, 0), f(S::sea_ice_fraction, 0), f(S::snow_water_equivalent, 0));
    const double al = f(S::surface_albedo, -1);
    node.ground.broadband_albedo = al > 0 ? al : -1;  // 0: the Sun stayed down for the 6 hours
    node.ground.wind_speed_m_s = std::hypot(f(S::u10, 5), f(S::v10, 0));
  }
  node.ground.skin_temperature_k = weather_ ? p.skin_temperature_k : ground_temperature_k_;
  // The column's optics for this sensor and Sun.
  const double lat = weather_ ? grid_.lat(j) : 0.0, lon = weather_ ? grid_.lon(i) : 0.0;
  const earth::Vec3 up = earth::unit_from_latlon(lat, lon);
  const earth::Vec3 ground = (earth::radius_m + node.ground_height_m) * up;
  const double mu_v = std::max(0.02, glm::dot(up, glm::normalize(sensor_position_ - ground)));
  const double mu_s = glm::dot(up, sun_direction_);
  const double sensor_alt = glm::length(sensor_position_) - earth::radius_m;
  atmosphere::ColumnGeometry g{atmosphere::air_mass(mu_v), mu_s > 0 ? atmosphere::air_mass(mu_s) : -1.0, sensor_alt};
  if (!atmosphere_) return;
  // Nodes far beyond the sensor's horizon are never sampled.
  if (glm::dot(up, glm::normalize(sensor_position_ - ground)) < -0.3) return;
  const std::size_t nb = bands_.size();
  for (std::size_t b = 0; b < nb; ++b) {
    const atmosphere::ClearSkyColumn c = atmosphere::clear_sky_column(p, *bands_[b], g, lat);
    node.sky_down[b] = static_cast<float>(c.sky_down);
    if (b == 0) {
      node.optics_z = c.z_m, node.optics.assign(c.z_m.size() * nb * optics_per_band, 0.0f);
      node.view_air_mass = static_cast<float>(c.view_air_mass), node.sun_air_mass = static_cast<float>(c.sun_air_mass);
    }
    for (std::size_t l = 0; l < c.z_m.size(); ++l) {
      float* o = &node.optics[(l * nb + b) * optics_per_band];
      const double t_view = std::max(static_cast<double>(c.t_view[l]), 1e-30);
      o[0] = static_cast<float>(std::log(t_view));
      const double absorbed = 1 - t_view;  // the air's emission per unit absorptance: a mean Planck radiance
      o[1] = absorbed > 1e-7 ? static_cast<float>(c.path_radiance[l] / absorbed) : 0.0f;
      o[2] = static_cast<float>(std::log(std::clamp(c.t_solar[l] / t_view, 1e-30, 1.0)));  // the Sun path alone
      o[3] = c.tau_rayleigh[l];
    }
  }
}

EarthView::Place EarthView::place(double lat, double lon) const {
  Place s;
  if (!weather_) {
    s.w = {1, 0, 0, 0};
    return s;
  }
  const auto& g = grid_;
  const double fy = std::clamp((lat - g.lat0_deg) / g.dlat_deg, 0.0, static_cast<double>(g.nlat - 1));
  const int j0 = std::min(static_cast<int>(fy), g.nlat - 2);
  const double wy = fy - j0;
  const double fx = earth::wrap_lon_360(lon - g.lon0_deg) / g.dlon_deg;
  int i0, i1;
  double wx;
  if (g.wraps()) {
    i0 = static_cast<int>(fx) % g.nlon, i1 = (i0 + 1) % g.nlon, wx = fx - std::floor(fx);
  } else {
    const double cx = std::clamp(fx, 0.0, static_cast<double>(g.nlon - 1));
    i0 = std::min(static_cast<int>(cx), g.nlon - 2), i1 = i0 + 1, wx = cx - i0;
  }
  const auto n = static_cast<std::size_t>(g.nlon);
  const auto j = static_cast<std::size_t>(j0);
  s.node = {j * n + static_cast<std::size_t>(i0), j * n + static_cast<std::size_t>(i1),
            (j + 1) * n + static_cast<std::size_t>(i0), (j + 1) * n + static_cast<std::size_t>(i1)};
  s.w = {(1 - wy) * (1 - wx), (1 - wy) * wx, wy * (1 - wx), wy * wx};
  return s;
}

void EarthView::air(const Place& s, double z, double mu_view, double mu_sun, AirSample& out,
                    const LevelHint* hint) const {
  air_at_air_masses(s, z, atmosphere::air_mass(std::max(mu_view, 0.02)),
                    mu_sun > 0 ? atmosphere::air_mass(mu_sun) : -1.0, out, hint);
}

void EarthView::air_at_air_masses(const Place& s, double z, double m_view, double m_sun, AirSample& out,
                                  const LevelHint* hint) const {
  const std::size_t nb = bands_.size();
  for (std::size_t b = 0; b < nb; ++b) out.t_view[b] = 1, out.path[b] = 0, out.t_sun[b] = 1, out.tau_rayleigh[b] = 0;
  if (!atmosphere_) return;
  // Per band, the nodes' optical depths carried to the pixel's air masses (exact for a grey
  // absorber) and their other quantities, weighted bilinearly, summed as the nodes store them (a
  // band's four quantities one vector: log t_view, mean Planck radiance, log t_sun, Rayleigh
  // depth); exponentiated once.
  constexpr std::size_t nq = optics_per_band;
  alignas(64) std::array<double, optics::max_band_count * nq> sums{};
  double wsum = 0, wsun = 0;
  for (std::size_t k = 0; k < 4; ++k) {
    if (s.w[k] == 0) continue;
    const Node& node = nodes_[s.node[k]];
    if (node.optics_z.empty()) continue;
    std::size_t from = hint ? (*hint)[k] : 0;
    const auto [hi, f] = optics_interval(node.optics_z, z, hint ? &from : nullptr);  // once for every band
    const float* lo_level = &node.optics[(hi - 1) * nb * nq];
    const float* hi_level = &node.optics[hi * nb * nq];
    const double w = s.w[k], r = w * m_view / node.view_air_mass;
    const bool sun = m_sun > 0 && node.sun_air_mass > 0;
    const double r_sun = sun ? w * m_sun / node.sun_air_mass : 0.0;
    for (std::size_t b = 0; b < nb; ++b) {
      const float *a = lo_level + b * nq, *c = hi_level + b * nq;
      double* sum = &sums[b * nq];
      sum[0] += r * between_levels(a[0], c[0], f), sum[1] += w * between_levels(a[1], c[1], f);
      sum[2] += r_sun * between_levels(a[2], c[2], f), sum[3] += w * between_levels(a[3], c[3], f);
    }
    wsum += w, wsun += sun ? w : 0.0;
  }
  if (wsum <= 0) return;
  // The exponentials of every band in loops that vectorise (core/simd_math.hpp), over the
  // padded lanes (log_t and log_sun are 0 beyond nb).
  const std::size_t lanes = optics::band_lanes(nb);
  const double wsun_or_1 = wsun > 0 ? wsun : 1.0;
  alignas(64) std::array<double, optics::max_band_count> log_t{}, log_sun{}, t_pix, t_sun;
  for (std::size_t b = 0; b < nb; ++b) log_t[b] = sums[b * nq], log_sun[b] = sums[b * nq + 2];
  for (std::size_t b = 0; b < lanes; ++b)
    t_pix[b] = std::exp(log_t[b] / wsum), t_sun[b] = std::exp(log_sun[b] / wsun_or_1);
  for (std::size_t b = 0; b < nb; ++b) {
    // The air's emission: its mean Planck radiance times the pixel's absorptance.
    out.t_view[b] = static_cast<float>(t_pix[b]);
    out.path[b] = static_cast<float>(sums[b * nq + 1] / wsum * (1 - t_pix[b]));
    out.tau_rayleigh[b] = static_cast<float>(sums[b * nq + 3] / wsum);
    if (m_sun <= 0)
      out.t_sun[b] = 0;
    else if (wsun > 0 && bands_[b]->sunlit())  // the Sun's path: bands with sunlight
      out.t_sun[b] = static_cast<float>(t_sun[b]);
  }
}

void EarthView::view_transmittances(const Place& s, const double* z, std::size_t n, double m_view, float* t) const {
  constexpr std::size_t mb = optics::max_band_count;
  const std::size_t nb = bands_.size(), lanes = optics::band_lanes(nb);
  for (std::size_t i = 0; i < n; ++i) std::fill(t + i * mb, t + i * mb + nb, 1.0f);
  if (!atmosphere_ || n == 0) return;
  thread_local std::vector<double> log_t;  // [altitude][lane]
  log_t.assign(n * mb, 0.0);
  double wsum = 0;
  for (std::size_t k = 0; k < 4; ++k) {  // air_at_air_masses()'s sums, each altitude's own
    if (s.w[k] == 0) continue;
    const Node& node = nodes_[s.node[k]];
    if (node.optics_z.empty()) continue;
    const double r = s.w[k] * m_view / node.view_air_mass;
    std::size_t hint = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto [hi, f] = optics_interval(node.optics_z, z[i], &hint);
      const float* lo_level = &node.optics[(hi - 1) * nb * optics_per_band];
      const float* hi_level = &node.optics[hi * nb * optics_per_band];
      for (std::size_t b = 0; b < nb; ++b)
        log_t[i * mb + b] += r * between_levels(lo_level[b * optics_per_band], hi_level[b * optics_per_band], f);
    }
    wsum += s.w[k];
  }
  if (wsum <= 0) return;
  for (std::size_t i = 0; i < n; ++i) {
    alignas(64) std::array<double, mb> t_pix;
    for (std::size_t b = 0; b < lanes; ++b) t_pix[b] = std::exp(log_t[i * mb + b] / wsum);
    for (std::size_t b = 0; b < nb; ++b) t[i * mb + b] = static_cast<float>(t_pix[b]);
  }
}

void EarthView::temperature_k(const Place& s, const double* z, std::size_t n, double* out) const {
  for (std::size_t i = 0; i < n; ++i) out[i] = 0;
  double w = 0;
  for (std::size_t q = 0; q < 4; ++q) {
    if (!(s.w[q] > 0)) continue;
    std::size_t hint = 0;
    for (std::size_t i = 0; i < n; ++i) out[i] += s.w[q] * along(nodes_[s.node[q]].z, nodes_[s.node[q]].t, z[i], &hint);
    w += s.w[q];
  }
  for (std::size_t i = 0; i < n; ++i) out[i] /= w;
}

double EarthView::temperature_k(const Place& s, double z, const double* z_below, std::size_t n, double* condensate,
                                LevelHint* levels) const {
  for (std::size_t i = 0; i < n; ++i) condensate[i] = 0;
  if (levels) levels->fill(0);
  double t = 0, w = 0;
  for (std::size_t q = 0; q < 4; ++q) {
    if (!(s.w[q] > 0)) continue;
    const Node& node = nodes_[s.node[q]];
    std::size_t hint = 0;  // from z's interval, walked down the profile below it
    t += s.w[q] * along(node.z, node.t, z, &hint), w += s.w[q];
    if (levels) (*levels)[q] = hint;
    if (!has_condensate_ || node.condensate.empty()) continue;
    for (std::size_t i = 0; i < n; ++i) condensate[i] += s.w[q] * along(node.z, node.condensate, z_below[i], &hint);
  }
  return t / w;
}

double EarthView::temperature_k(const Place& s, double z) const {
  double t = 0, w = 0;
  for (std::size_t q = 0; q < 4; ++q)
    if (s.w[q] > 0) t += s.w[q] * along(nodes_[s.node[q]].z, nodes_[s.node[q]].t, z), w += s.w[q];
  return t / w;
}

double EarthView::condensate_g_m3(const Place& s, double z) const {
  if (!has_condensate_) return 0;
  double c = 0;
  for (std::size_t q = 0; q < 4; ++q)
    if (s.w[q] > 0 && !nodes_[s.node[q]].condensate.empty())
      c += s.w[q] * along(nodes_[s.node[q]].z, nodes_[s.node[q]].condensate, z);
  return c;
}

EarthView::LayerCondensate EarthView::condensate_layer(const Place& s, std::size_t l) const {
  // The path bilinear; its mean and centroid temperature weighted by each node's share of it
  // (a node without condensate has neither).
  LayerCondensate out;
  for (std::size_t q = 0; q < 4; ++q) {
    if (!(s.w[q] > 0) || l >= nodes_[s.node[q]].layers.size()) continue;
    const LayerCondensate& n = nodes_[s.node[q]].layers[l];
    const double w = s.w[q] * n.path_g_m2;
    out.path_g_m2 += w, out.mean_g_m3 += w * n.mean_g_m3, out.temperature_k += w * n.temperature_k;
  }
  if (out.path_g_m2 > 0) out.mean_g_m3 /= out.path_g_m2, out.temperature_k /= out.path_g_m2;
  return out;
}

std::pair<double, double> EarthView::node_lat_lon_deg(std::size_t k) const {
  const auto n = static_cast<std::size_t>(grid_.nlon);
  return {grid_.lat(static_cast<int>(k / n)), grid_.lon(static_cast<int>(k % n))};
}

surface::State EarthView::ground(const Place& s, std::array<double, optics::max_band_count>* sky_down) const {
  surface::State g;
  g.share = {0, 0, 0, 0};
  g.skin_temperature_k = 0, g.wind_speed_m_s = 0;
  double al = 0, al_w = 0;
  if (sky_down) sky_down->fill(0.0);
  for (std::size_t q = 0; q < 4; ++q) {
    if (s.w[q] == 0) continue;
    if (sky_down)
      for (std::size_t b = 0; b < bands_.size(); ++b) (*sky_down)[b] += s.w[q] * nodes_[s.node[q]].sky_down[b];
    const surface::State& n = nodes_[s.node[q]].ground;
    for (std::size_t k = 0; k < g.share.size(); ++k) g.share[k] += s.w[q] * n.share[k];
    g.skin_temperature_k += s.w[q] * n.skin_temperature_k, g.wind_speed_m_s += s.w[q] * n.wind_speed_m_s;
    if (n.broadband_albedo >= 0) al += s.w[q] * n.broadband_albedo, al_w += s.w[q];
  }
  g.broadband_albedo = al_w > 0.5 ? al / al_w : -1;
  return g;
}

double EarthView::land_share(const Place& s) const {
  double land = 0;
  for (std::size_t q = 0; q < 4; ++q)
    if (s.w[q] != 0) land += s.w[q] * nodes_[s.node[q]].ground.share[1];
  return land;
}

double EarthView::ground_height_m(const Place& s) const {
  double h = 0;
  for (std::size_t q = 0; q < 4; ++q) h += s.w[q] * nodes_[s.node[q]].ground_height_m;
  return h;
}

}  // namespace nephos::render
