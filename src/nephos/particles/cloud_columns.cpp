#include "nephos/particles/cloud_columns.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/earth/earth.hpp"

namespace nephos::particles {

namespace {
constexpr float nan_f = std::numeric_limits<float>::quiet_NaN();
constexpr double deg = M_PI / 180.0;
}  // namespace

float CloudColumns::max_tau() const {
  float m = 0;
  for (float t : tau) m = std::max(m, t);
  return m;
}

float CloudColumns::max_top_m() const {
  float m = 0;
  for (float t : top_m)
    if (!std::isnan(t)) m = std::max(m, t);
  return m;
}

float CloudColumns::sigma_per_m(std::size_t c) const {
  const float depth = top_m[c] - base_m[c];
  return tau[c] > 0 && depth > 0 ? tau[c] / depth : 0.0f;
}

void WeatherFrame::allocate(std::size_t n, int levels) {
  columns.base_m.assign(n, nan_f);
  columns.top_m.assign(n, nan_f);
  columns.tau.assign(n, 0.0f);
  wind.levels = levels;
  for (auto* a : {&wind.z_m, &wind.u, &wind.v, &wind.w}) a->assign(static_cast<std::size_t>(levels) * n, 0.0f);
}

void LayerColumn::resize(std::size_t layers) {
  for (auto* v : {&z_lower_m, &z_upper_m, &air_density, &q_liquid, &q_ice}) v->resize(layers);
}

void store(CloudColumns& columns, std::size_t c, const ColumnCloud& cloud) {
  columns.base_m[c] = cloud.base_m;
  columns.top_m[c] = cloud.top_m;
  columns.tau[c] = cloud.tau;
}

glm::dvec3 WindVolume::sample(const PlanarGrid& g, double x_m, double y_m, double z) const {
  const double fc = std::clamp((x_m - g.x0_m) / g.dx_m, 0.0, static_cast<double>(g.cols - 1));
  const double fr = std::clamp((y_m - g.y0_m) / g.dy_m, 0.0, static_cast<double>(g.rows - 1));
  const int i0 = std::min(static_cast<int>(fc), std::max(g.cols - 2, 0));
  const int j0 = std::min(static_cast<int>(fr), std::max(g.rows - 2, 0));
  const double tx = fc - i0, ty = fr - j0;
  const std::size_t plane = g.size();
  glm::dvec3 out{0.0};
  for (int dj = 0; dj < 2; ++dj)
    for (int di = 0; di < 2; ++di) {
      const int i = std::min(i0 + di, g.cols - 1), j = std::min(j0 + dj, g.rows - 1);
      const double wgt = (di ? tx : 1 - tx) * (dj ? ty : 1 - ty);
      if (wgt == 0) continue;
      const std::size_t c = static_cast<std::size_t>(j) * g.cols + static_cast<std::size_t>(i);
      // Linear in height between the bracketing levels, clamped outside.
      int k = 0;
      while (k + 1 < levels && z_m[(k + 1) * plane + c] < z) ++k;
      const std::size_t a = k * plane + c;
      glm::dvec3 wind{u[a], v[a], w[a]};
      if (k + 1 < levels && z > z_m[a]) {
        const std::size_t b = a + plane;
        const double s = std::clamp((z - z_m[a]) / (z_m[b] - z_m[a]), 0.0, 1.0);
        wind += s * (glm::dvec3{u[b], v[b], w[b]} - wind);
      }
      out += wgt * wind;
    }
  return out;
}

void ParticleWeather::validate() const {
  if (grid.cols < 2 || grid.rows < 2)
    throw ValueError("the particle grid needs at least 2 x 2 columns, got " + std::to_string(grid.cols) + " x " +
                     std::to_string(grid.rows));
  if (frames.empty()) throw ValueError("no weather frames");
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const auto& fr = frames[f];
    if (fr.columns.tau.size() != grid.size() || fr.columns.top_m.size() != grid.size() ||
        fr.columns.base_m.size() != grid.size())
      throw ValueError("frame " + std::to_string(f) + " has columns unlike the grid");
    const std::size_t n3 = static_cast<std::size_t>(fr.wind.levels) * grid.size();
    if (fr.wind.u.size() != n3 || fr.wind.v.size() != n3 || fr.wind.w.size() != n3 || fr.wind.z_m.size() != n3)
      throw ValueError("frame " + std::to_string(f) + " has a wind volume unlike the grid");
    if (f > 0 && !(fr.time_s > frames[f - 1].time_s))
      throw ValueError("frames must be strictly ascending in time (frame " + std::to_string(f) + ")");
  }
}

int refine_factor_for(const PlanarGrid& g, double target_m) {
  return std::max(1, static_cast<int>(std::ceil(std::max(g.dx_m, g.dy_m) / target_m - 1e-9)));
}

ParticleWeather refine(const ParticleWeather& w, int factor) {
  if (factor < 1)
    throw ValueError("the refinement factor must be >= 1, got " + std::to_string(factor), {.key = "refine"});
  w.validate();
  if (factor == 1) return w;
  const PlanarGrid& g = w.grid;
  ParticleWeather out;
  out.source = w.source;
  PlanarGrid& r = out.grid;
  r = g;
  r.cols = g.cols * factor, r.rows = g.rows * factor;
  r.dx_m = g.dx_m / factor, r.dy_m = g.dy_m / factor;
  r.x0_m = g.x0_m - 0.5 * g.dx_m + 0.5 * r.dx_m;
  r.y0_m = g.y0_m - 0.5 * g.dy_m + 0.5 * r.dy_m;
  // Bilinear stencil of every new cell centre in the old grid (clamped at the edges).
  struct Stencil {
    std::size_t c[4];
    double w[4];
  };
  std::vector<Stencil> st(r.size());
  for (int j = 0; j < r.rows; ++j)
    for (int i = 0; i < r.cols; ++i) {
      const double fc = std::clamp((r.x(i) - g.x0_m) / g.dx_m, 0.0, g.cols - 1.0);
      const double fr = std::clamp((r.y(j) - g.y0_m) / g.dy_m, 0.0, g.rows - 1.0);
      const int i0 = std::min(static_cast<int>(fc), g.cols - 2), j0 = std::min(static_cast<int>(fr), g.rows - 2);
      const double tx = fc - i0, ty = fr - j0;
      Stencil& s = st[static_cast<std::size_t>(j) * r.cols + i];
      for (int q = 0; q < 4; ++q) {
        const int di = q & 1, dj = q >> 1;
        s.c[q] = static_cast<std::size_t>(j0 + dj) * g.cols + static_cast<std::size_t>(i0 + di);
        s.w[q] = (di ? tx : 1 - tx) * (dj ? ty : 1 - ty);
      }
    }
  const std::size_t plane = g.size(), rplane = r.size();
  for (const WeatherFrame& f : w.frames) {
    WeatherFrame nf;
    nf.time_s = f.time_s;
    nf.valid_time = f.valid_time;
    nf.allocate(rplane, f.wind.levels);
    const std::size_t nl = static_cast<std::size_t>(f.wind.levels);
    for (std::size_t n = 0; n < rplane; ++n) {
      const Stencil& s = st[n];
      double tau = 0, base = 0, top = 0, wc = 0;
      for (int q = 0; q < 4; ++q) {
        tau += s.w[q] * f.columns.tau[s.c[q]];
        if (f.columns.tau[s.c[q]] > 0 && s.w[q] > 0) {
          base += s.w[q] * f.columns.base_m[s.c[q]];
          top += s.w[q] * f.columns.top_m[s.c[q]];
          wc += s.w[q];
        }
      }
      if (tau > 0 && wc > 0)
        store(nf.columns, n, {static_cast<float>(base / wc), static_cast<float>(top / wc), static_cast<float>(tau)});
      for (std::size_t k = 0; k < nl; ++k) {
        double z = 0, u = 0, v = 0, ww = 0;
        for (int q = 0; q < 4; ++q) {
          const std::size_t a = k * plane + s.c[q];
          z += s.w[q] * f.wind.z_m[a], u += s.w[q] * f.wind.u[a], v += s.w[q] * f.wind.v[a], ww += s.w[q] * f.wind.w[a];
        }
        const std::size_t b = k * rplane + n;
        nf.wind.z_m[b] = static_cast<float>(z), nf.wind.u[b] = static_cast<float>(u);
        nf.wind.v[b] = static_cast<float>(v), nf.wind.w[b] = static_cast<float>(ww);
      }
    }
    out.frames.push_back(std::move(nf));
  }
  return out;
}

LatLonRegion LatLonRegion::parse(const std::string& text, const std::string& key) {
  const auto v = parse_numbers(text, 4, key, "LAT0,LON0,LAT1,LON1 in degrees (south, west, north, east)");
  LatLonRegion r{v[0], v[1], v[2], v[3]};
  if (!(r.lat0_deg >= -90 && r.lat1_deg <= 90 && r.lat0_deg < r.lat1_deg))
    throw ValueError("latitudes must satisfy -90 <= LAT0 < LAT1 <= 90, got '" + text + "'", {.key = key});
  return r;
}

double layer_optical_thickness(double air_density_kg_m3, double mixing_ratio_kg_kg, double thickness_m,
                               double condensate_density_kg_m3, double effective_radius_m) {
  // lambda = 2 pi dh Int r^2 n(r) dr; with the water content W = (4/3) pi rho_c Int r^3 n dr and
  // r_e = Int r^3 n / Int r^2 n this is 3 W dh / (2 rho_c r_e).
  const double water_content = air_density_kg_m3 * std::max(mixing_ratio_kg_kg, 0.0);  // [kg/m^3]
  return 3.0 * water_content * thickness_m / (2.0 * condensate_density_kg_m3 * effective_radius_m);
}

ColumnCloud column_cloud(const LayerColumn& c, const ColumnParams& p) {
  ColumnCloud out{nan_f, nan_f, 0.0f};
  double tau = 0;
  for (std::size_t k = 0; k < c.z_lower_m.size(); ++k) {
    const double q = c.q_liquid[k] + c.q_ice[k];
    if (!(q > p.cloud_threshold_kg_kg)) continue;
    const double dz = c.z_upper_m[k] - c.z_lower_m[k];
    tau += layer_optical_thickness(c.air_density[k], c.q_liquid[k], dz, rho_liquid_water,
                                   p.effective_radius_liquid_um * 1e-6) +
           layer_optical_thickness(c.air_density[k], c.q_ice[k], dz, rho_ice, p.effective_radius_ice_um * 1e-6);
    if (std::isnan(out.base_m)) out.base_m = static_cast<float>(c.z_lower_m[k]);
    out.top_m = static_cast<float>(c.z_upper_m[k]);
  }
  out.tau = static_cast<float>(tau);
  return out;
}

namespace {

// The weather grid's cells inside a region: rows south first, columns eastwards from the
// region's west edge (a region across the date line starts mid-grid), and the first column's
// longitude counted from that edge [deg].
struct RegionCells {
  std::vector<int> rows, cols;
  double first_lon_deg = 0;
};

RegionCells region_cells(const weather::LatLonGrid& g, const LatLonRegion& region) {
  RegionCells rc;
  for (int j = 0; j < g.nlat; ++j)
    if (g.lat(j) >= region.lat0_deg - 1e-9 && g.lat(j) <= region.lat1_deg + 1e-9) rc.rows.push_back(j);
  double span = std::fmod(region.lon1_deg - region.lon0_deg + 720.0, 360.0);
  if (span == 0 && region.lon1_deg != region.lon0_deg) span = 360;
  auto east_of_edge = [&](int n) { return std::fmod(g.lon(n) - region.lon0_deg + 720.0, 360.0); };
  for (int n = 0; n < g.nlon; ++n)
    if (east_of_edge(n) <= span + 1e-9) rc.cols.push_back(n);
  std::sort(rc.cols.begin(), rc.cols.end(), [&](int a, int b) { return east_of_edge(a) < east_of_edge(b); });
  if (rc.rows.size() < 2 || rc.cols.size() < 2)
    throw ValueError("the region holds " + std::to_string(rc.cols.size()) + " x " + std::to_string(rc.rows.size()) +
                         " grid columns of " + g.describe() + "; at least 2 x 2 are needed",
                     {.key = "region"});
  rc.first_lon_deg = region.lon0_deg + east_of_edge(rc.cols.front());
  return rc;
}

// The region's cells as a planar grid centred on the region, x east and y north [m].
PlanarGrid planar_grid(const weather::LatLonGrid& g, const RegionCells& rc) {
  PlanarGrid pg;
  pg.cols = static_cast<int>(rc.cols.size());
  pg.rows = static_cast<int>(rc.rows.size());
  pg.centre_lat_deg = 0.5 * (g.lat(rc.rows.front()) + g.lat(rc.rows.back()));
  const double centre_lon = rc.first_lon_deg + 0.5 * (pg.cols - 1) * g.dlon_deg;
  pg.centre_lon_deg = std::fmod(centre_lon + 540.0, 360.0) - 180.0;
  const double r = earth::radius_m * std::cos(pg.centre_lat_deg * deg);
  pg.dx_m = r * g.dlon_deg * deg;
  pg.dy_m = earth::radius_m * g.dlat_deg * deg;
  pg.x0_m = -0.5 * (pg.cols - 1) * pg.dx_m;
  pg.y0_m = (g.lat(rc.rows.front()) - pg.centre_lat_deg) * deg * earth::radius_m;
  return pg;
}

// The grids in time order; FormatError naming both files where two share a valid time.
std::vector<weather::WeatherGrid> in_time_order(const std::vector<weather::WeatherGrid>& grids) {
  std::vector<weather::WeatherGrid> sorted = grids;
  std::sort(sorted.begin(), sorted.end(),
            [](const auto& a, const auto& b) { return a.metadata().valid_time < b.metadata().valid_time; });
  for (std::size_t f = 1; f < sorted.size(); ++f)
    if (sorted[f].metadata().valid_time == sorted[f - 1].metadata().valid_time)
      throw FormatError(fmt::format("two weather grids at the same valid time {}; give each time once",
                                    sorted[f].metadata().valid_time.iso()),
                        {.file = sorted[f - 1].metadata().source + ", " + sorted[f].metadata().source});
  return sorted;
}

// The pressure levels of `w` that hold every field the particles need; FormatError naming the
// file and field where a field is missing or fewer than two levels hold them all.
std::vector<int> cloud_levels(const weather::WeatherGrid& w) {
  using weather::Field;
  for (Field f : {Field::geopotential_height, Field::temperature, Field::cloud_water, Field::u_wind, Field::v_wind})
    if (!w.has(f))
      throw FormatError("the particle system needs this field, which the file lacks",
                        {.file = w.metadata().source, .field = weather::info(f).grib_short_name});
  std::vector<int> levels;
  for (int k = 0; k < w.level_count(); ++k)
    if (w.has(Field::geopotential_height, k) && w.has(Field::temperature, k) && w.has(Field::cloud_water, k) &&
        w.has(Field::u_wind, k) && w.has(Field::v_wind, k))
      levels.push_back(k);
  if (levels.size() < 2)
    throw FormatError("fewer than 2 pressure levels hold gh, t, clwmr, u and v together",
                      {.file = w.metadata().source, .field = "clwmr"});
  return levels;
}

// One weather time as a frame: per cell its wind on the cloud levels and its cloud column.
WeatherFrame weather_frame(const weather::WeatherGrid& w, const RegionCells& rc, const PlanarGrid& pg,
                           const UtcTime& t0, const ColumnParams& params) {
  using weather::Field;
  const std::vector<int> levels = cloud_levels(w);
  const bool has_omega = std::all_of(levels.begin(), levels.end(), [&](int k) { return w.has(Field::omega, k); });
  if (!has_omega)
    spdlog::warn("{}: no vertical velocity (w) on every cloud level; particles move horizontally only",
                 w.metadata().source);
  WeatherFrame fr;
  fr.valid_time = w.metadata().valid_time;
  fr.time_s = static_cast<double>(fr.valid_time.unix_s - t0.unix_s);
  const std::size_t plane = pg.size(), nl = levels.size();
  fr.allocate(plane, static_cast<int>(nl));
  const auto& p_pa = w.pressure_levels_pa();
  LayerColumn col;
  col.resize(nl);
  std::vector<double> z(nl);
  for (int rj = 0; rj < pg.rows; ++rj)
    for (int ci = 0; ci < pg.cols; ++ci) {
      const int j = rc.rows[static_cast<std::size_t>(rj)], i = rc.cols[static_cast<std::size_t>(ci)];
      const std::size_t c = static_cast<std::size_t>(rj) * pg.cols + static_cast<std::size_t>(ci);
      for (std::size_t m = 0; m < nl; ++m) z[m] = w.value(Field::geopotential_height, levels[m], j, i);
      for (std::size_t m = 0; m < nl; ++m) {
        const int k = levels[m];
        // Layer interfaces half-way between level heights; the outer layers are symmetric.
        col.z_lower_m[m] = m == 0 ? z[0] - 0.5 * (z[1] - z[0]) : 0.5 * (z[m - 1] + z[m]);
        col.z_upper_m[m] = m + 1 == nl ? z[m] + 0.5 * (z[m] - z[m - 1]) : 0.5 * (z[m] + z[m + 1]);
        const double t = w.value(Field::temperature, k, j, i);
        const double rho = p_pa[static_cast<std::size_t>(k)] / (r_dry_air * t);
        const double q = std::max(0.0, static_cast<double>(w.value(Field::cloud_water, k, j, i)));
        const double ice =
            std::clamp((params.ice_ramp_warm_k - t) / (params.ice_ramp_warm_k - params.ice_ramp_cold_k), 0.0, 1.0);
        col.air_density[m] = rho;
        col.q_liquid[m] = q * (1 - ice);
        col.q_ice[m] = q * ice;
        const std::size_t a = m * plane + c;
        fr.wind.z_m[a] = static_cast<float>(z[m]);
        fr.wind.u[a] = w.value(Field::u_wind, k, j, i);
        fr.wind.v[a] = w.value(Field::v_wind, k, j, i);
        // omega [Pa/s] -> w [m/s] by hydrostatic balance: w = -omega / (rho g).
        fr.wind.w[a] = has_omega ? static_cast<float>(-w.value(Field::omega, k, j, i) / (rho * g0)) : 0.0f;
      }
      store(fr.columns, c, column_cloud(col, params));
    }
  return fr;
}

}  // namespace

ParticleWeather from_weather_grids(const std::vector<weather::WeatherGrid>& grids, const LatLonRegion& region,
                                   const ColumnParams& params) {
  if (grids.empty()) throw ValueError("no weather given");
  const weather::LatLonGrid& g = grids.front().grid();
  for (const auto& w : grids)
    if (!(w.grid() == g))
      throw FormatError("all weather files must share one grid (" + g.describe() + " vs " + w.grid().describe() + ")",
                        {.file = w.metadata().source});
  const RegionCells rc = region_cells(g, region);
  ParticleWeather pw;
  pw.grid = planar_grid(g, rc);
  const std::vector<weather::WeatherGrid> sorted = in_time_order(grids);
  const UtcTime t0 = sorted.front().metadata().valid_time;
  pw.source = sorted.front().metadata().source;
  for (std::size_t f = 1; f < sorted.size(); ++f) pw.source += ", " + sorted[f].metadata().source;
  for (const auto& w : sorted) pw.frames.push_back(weather_frame(w, rc, pw.grid, t0, params));
  pw.validate();
  return pw;
}

}  // namespace nephos::particles
