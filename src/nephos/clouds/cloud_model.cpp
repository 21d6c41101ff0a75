#include "nephos/clouds/cloud_model.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/simd_math.hpp"

namespace nephos::clouds {

FractalTextures FractalTextures::bake(const CloudModelParams& params, std::uint64_t seed) {
  const int n = params.texture_size;
  auto fit = [n](noise::FractalSpec s) {
    while (s.octaves > 1 && (s.base_cells << (s.octaves - 1)) > n / 2) --s.octaves;
    return s;
  };
  return from(noise::bake(fit(params.coarse), hash(seed, 1), n), noise::bake(fit(params.fine), hash(seed, 2), n),
              noise::bake(fit(params.worley), hash(seed, 3), n));
}

FractalTextures FractalTextures::from(noise::Texture3D coarse, noise::Texture3D fine, noise::Texture3D worley) {
  FractalTextures t{std::move(coarse), std::move(fine), std::move(worley), {}};
  for (int i = 0; i < 3; ++i) t.mips[static_cast<std::size_t>(i)] = noise::MipPyramid::of(t[i]);
  return t;
}

CloudModelParams::CloudModelParams() {
  using optics::Phase;
  // Shell ranges and wind (sampling) altitudes: Table 1. Optics: Table 2 (Miles et al. 2000)
  // for water clouds, the seed's cirrus example (Mitchell et al.) for ice. Shape constants were
  // chosen by eye against GOES imagery scales: docs/render.md.
  auto& st = (*this)[CloudType::low_stratus];
  st.shell_bottom_m = 500, st.shell_top_m = 4000, st.wind_altitude_m = 2000;
  st.fractals = {{{0.55, 60e3, 8}, {0.20, 6e3, 8}, {0.25, 40e3, 8}}};
  st.altitude_length_bottom_m = 300, st.altitude_length_top_m = 300;
  st.phase = Phase::water, st.water_content_g_m3 = 0.4, st.effective_radius_um = 8.15;  // "Stratus": D 16.3 um
  st.asymmetry = 0.86;  // droplets in the visible (Hansen & Travis 1974, Fig. 12)

  auto& cu = (*this)[CloudType::low_cumulus];
  cu.shell_bottom_m = 0, cu.shell_top_m = 6000, cu.wind_altitude_m = 2000;
  cu.fractals = {{{0.35, 30e3, 6}, {0.25, 3e3, 6}, {0.40, 15e3, 6}}};
  cu.altitude_length_bottom_m = 150, cu.altitude_length_top_m = 1200;                   // flat bases, towering tops
  cu.phase = Phase::water, cu.water_content_g_m3 = 0.38, cu.effective_radius_um = 4.3;  // "Stratocumulus" mid-range
  cu.asymmetry = 0.86;

  auto& as = (*this)[CloudType::altostratus];
  as.shell_bottom_m = 6000, as.shell_top_m = 10000, as.wind_altitude_m = 6000;
  as.fractals = {{{0.60, 80e3, 10}, {0.20, 8e3, 10}, {0.20, 50e3, 10}}};
  as.altitude_length_bottom_m = 500, as.altitude_length_top_m = 500;
  as.phase = Phase::water, as.water_content_g_m3 = 0.29, as.effective_radius_um = 7.6;  // "Maritime stratus": D 15.2 um
  as.asymmetry = 0.86;

  auto& ci = (*this)[CloudType::cirrus];
  ci.shell_bottom_m = 6500, ci.shell_top_m = 10000, ci.wind_altitude_m = 6000;
  ci.fractals = {{{0.50, 120e3, 12}, {0.30, 10e3, 12}, {0.20, 60e3, 12}}};
  ci.altitude_length_bottom_m = 600, ci.altitude_length_top_m = 600;
  ci.phase = Phase::ice, ci.water_content_g_m3 = 0.01, ci.effective_radius_um = 45;  // D 90 um, 0.01 g/m3
  ci.asymmetry = 0.77;  // ice crystals (Key, Yang, Baum & Nasiri 2002: 0.75-0.80 in the visible)
}

void CloudModelParams::set_texture_size(int n, const std::string& key) {
  if (n < min_texture_size || n > max_texture_size || (n & (n - 1)) != 0)
    throw ValueError(
        fmt::format("texture size must be a power of two from {} to {}, got {}", min_texture_size, max_texture_size, n),
        {.key = key});
  // Three N^3 voxel grids of one byte each in overlapping bricks (~2.37 N^3 bytes each), and
  // while one is baked its N^3 float values.
  require_memory(3.0 * static_cast<double>(noise::Texture3D::bytes_for(n)) + 4.0 * std::pow(n, 3), key,
                 fmt::format("three {}^3 fractal textures", n));
  texture_size = n;
}

void CloudModelParams::set_displace_hours(double hours, const std::string& key) {
  require_range(hours, 0, max_displace_hours, key, "the wind displacement [h]");
  for (auto& t : types)
    for (auto& f : t.fractals) f.displace_hours = hours;
}

CloudModelParams CloudModelParams::from(const ParamDict& dict) {
  // Ranges: what the model can use, not what is typical (docs/render.md). Shells and winds
  // within 100 km of the surface.
  constexpr double max_altitude_m = 100e3;
  CloudModelParams p;
  const ParamDict t = dict.table("textures");
  p.texture_size = t.get_in("size", p.texture_size, min_texture_size, max_texture_size);
  const ParamDict d = dict.table("displacement");
  p.displacement_cube_size = d.get_in("cube_size", p.displacement_cube_size, 4, 2048);
  p.displacement_step_s = d.get_in("step_s", p.displacement_step_s, 1.0, 86400.0);
  p.mask_cube_size = dict.table("masks_cube").get_in("size", p.mask_cube_size, 4, 4096);
  p.follow_weather_tops = dict.table("masks_cube").get("follow_weather_tops", p.follow_weather_tops);
  const ParamDict clouds = dict.table("clouds");
  static const char* fractal_names[] = {"coarse", "fine", "worley"};
  for (int k = 0; k < weather::cloud_type_count; ++k) {
    const ParamDict c = clouds.table(weather::name(static_cast<CloudType>(k)));
    auto& q = p.types[static_cast<std::size_t>(k)];
    q.shell_bottom_m = c.get_in("shell_bottom_m", q.shell_bottom_m, 0.0, max_altitude_m);
    q.shell_top_m = c.get_in("shell_top_m", q.shell_top_m, 0.0, max_altitude_m);
    q.wind_altitude_m = c.get_in("wind_altitude_m", q.wind_altitude_m, 0.0, max_altitude_m);
    for (int i = 0; i < 3; ++i) {
      const ParamDict f = c.table(fractal_names[i]);
      auto& term = q.fractals[static_cast<std::size_t>(i)];
      term.weight = f.get_in("weight", term.weight, -100.0, 100.0);
      term.length_scale_m = f.get_in("length_scale_m", term.length_scale_m, 1.0, 1e8);
      term.displace_hours = f.get_in("displace_hours", term.displace_hours, 0.0, max_displace_hours);
    }
    q.calibrate = c.get("calibrate", q.calibrate);
    q.bias = c.get("bias", q.bias);
    q.mask_weight = c.get("mask_weight", q.mask_weight);
    q.mask_displace_hours = c.get_in("mask_displace_hours", q.mask_displace_hours, 0.0, max_displace_hours);
    q.threshold = c.get("threshold", q.threshold);
    q.altitude_scale = c.get_in("altitude_scale", q.altitude_scale, 0.0, 1e3);
    q.altitude_length_bottom_m = c.get_in("altitude_length_bottom_m", q.altitude_length_bottom_m, 1.0, 1e6);
    q.altitude_length_top_m = c.get_in("altitude_length_top_m", q.altitude_length_top_m, 1.0, 1e6);
    q.min_mask = c.get_in("min_mask", q.min_mask, 0.0, 1.0);
    q.water_content_g_m3 = c.get_in("water_content_g_m3", q.water_content_g_m3, 1e-6, 100.0);
    q.effective_radius_um = c.get_in("effective_radius_um", q.effective_radius_um, 0.1, 1e4);
    q.asymmetry = c.get_in("asymmetry", q.asymmetry, 0.0, 0.99);
    const std::string phase = c.get("phase", q.phase == optics::Phase::water ? "water" : "ice");
    if (phase != "water" && phase != "ice")
      throw ConfigError(
          "expected \"water\" or \"ice\"",
          {.file = dict.source(), .key = fmt::format("clouds.{}.phase", weather::name(static_cast<CloudType>(k)))});
    q.phase = phase == "water" ? optics::Phase::water : optics::Phase::ice;
    if (!(q.shell_top_m > q.shell_bottom_m))
      throw ConfigError(
          "shell_top_m must exceed shell_bottom_m",
          {.file = dict.source(), .key = fmt::format("clouds.{}", weather::name(static_cast<CloudType>(k)))});
  }
  return p;
}

namespace {
// Fields of a lat-lon grid resampled onto n x n cube maps, one per field, NaN read as 0. The
// texels' latitudes and longitudes are computed once for every field (a geodetic conversion
// costs more than the lookups). Bicubic, not bilinear: a threshold on a bilinear field draws the
// grid's cells (boxes of 2.5 degrees from the embedded GFS sample); the bicubic one keeps the
// values at the nodes and within each cell's range, with round edges (weather::sample_bicubic).
std::vector<CubeMap<float>> resample_to_cubes(const weather::LatLonGrid& grid,
                                              const std::vector<const std::vector<float>*>& fields, int n) {
  std::vector<CubeMap<float>> cubes(fields.size(), CubeMap<float>(n));
  if (cubes.empty()) return cubes;
#pragma omp parallel for collapse(2) schedule(static)
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const earth::Geodetic g = earth::geodetic(cubes.front().texel_direction(f, i, j) * earth::radius_m);
        for (std::size_t t = 0; t < fields.size(); ++t) {
          const float v = weather::sample_bicubic(grid, *fields[t], g.lat_deg, g.lon_deg);
          cubes[t].texel(f, i, j) = std::isnan(v) ? 0.0f : v;
        }
      }
  return cubes;
}
}  // namespace

std::vector<CubeMap<float>> mask_cubes(const weather::WeatherMasks& masks, const std::vector<CloudType>& types, int n) {
  std::vector<const std::vector<float>*> fields;
  for (CloudType t : types) fields.push_back(&masks[t]);
  return resample_to_cubes(masks.grid, fields, n);
}

namespace {
// Geometric height [m] at pressure p [Pa] of grid node `cell`: gh linear in ln p between the
// levels around it; NaN outside them or where p is NaN.
float height_at_pressure(const weather::WeatherGrid& w, std::size_t cell, float p) {
  if (std::isnan(p) || p <= 0) return NAN;
  const auto& levels = w.pressure_levels_pa();
  for (int k = 0; k + 1 < w.level_count(); ++k) {
    const double p0 = levels[static_cast<std::size_t>(k)], p1 = levels[static_cast<std::size_t>(k + 1)];
    if (!(p <= p0 && p >= p1)) continue;
    if (!w.has(weather::Field::geopotential_height, k) || !w.has(weather::Field::geopotential_height, k + 1))
      return NAN;
    const double h0 = w.level_data(weather::Field::geopotential_height, k)[cell];
    const double h1 = w.level_data(weather::Field::geopotential_height, k + 1)[cell];
    const double f = std::log(p0 / p) / std::log(p0 / p1);
    return static_cast<float>(earth::geometric_from_geopotential_m(h0 + f * (h1 - h0)));
  }
  return NAN;
}
}  // namespace

std::vector<CubeMap<float>> cloud_top_lifts(const weather::WeatherGrid& w, const CloudModelParams& params,
                                            const std::vector<CloudType>& types, int n) {
  using S = weather::SurfaceField;
  const std::size_t cells = w.grid().size();
  std::vector<std::vector<float>> lift(types.size(), std::vector<float>(cells, 0.0f));
  for (std::size_t t = 0; t < types.size(); ++t) {
    const CloudTypeParams& p = params[types[t]];
    std::vector<S> fields;
    switch (types[t]) {
      case CloudType::low_stratus:
      case CloudType::low_cumulus:
        fields = {S::low_cloud_top_pressure};
        break;
      case CloudType::altostratus:
        fields = {S::middle_cloud_top_pressure};
        break;
      case CloudType::cirrus:
        fields = {S::high_cloud_top_pressure, S::convective_cloud_top_pressure};
        break;
    }
    const double down = -0.5 * (p.shell_top_m - p.shell_bottom_m), up = 18000.0 - p.shell_top_m;
    for (std::size_t c = 0; c < cells; ++c) {
      float top = NAN;
      for (S f : fields)
        if (w.has(f)) {
          const float h = height_at_pressure(w, c, w.surface(f)[c]);
          if (!std::isnan(h) && (std::isnan(top) || h > top)) top = h;
        }
      if (!std::isnan(top)) lift[t][c] = static_cast<float>(std::clamp(top - p.shell_top_m, down, up));
    }
  }
  std::vector<const std::vector<float>*> fields;
  for (const auto& l : lift) fields.push_back(&l);
  return resample_to_cubes(w.grid(), fields, n);
}

CloudShell::CloudShell(CloudType type, const CloudTypeParams& params, std::shared_ptr<const FractalTextures> textures,
                       std::shared_ptr<const CubeMap<float>> mask, std::vector<DisplacementMap> maps,
                       std::shared_ptr<const CubeMap<float>> lift)
    : type_(type), p_(params), tex_(std::move(textures)), mask_(std::move(mask)), maps_(std::move(maps)) {
  if (maps_.size() != 4) throw ValueError("a cloud shell needs 4 displacement maps (mask + 3 fractals)");
  r_bottom_ = earth::radius_m + p_.shell_bottom_m;
  r_top_ = earth::radius_m + p_.shell_top_m;
  fractal_max_ = fractal_min_ = 0;
  for (const auto& f : p_.fractals) {
    fractal_max_ += std::max(0.0, f.weight);
    fractal_min_ += std::min(0.0, f.weight);
  }
  bias_ = p_.bias;
  mask_weight_ = p_.mask_weight;
  barrier_z0_ = p_.shell_bottom_m - 1000;
  const int nz = static_cast<int>(p_.shell_top_m - p_.shell_bottom_m) + 2001;
  barrier_bottom_.resize(static_cast<std::size_t>(nz)), barrier_top_.resize(static_cast<std::size_t>(nz));
  for (int i = 0; i < nz; ++i) {
    const double alt = barrier_z0_ + i;
    barrier_bottom_[static_cast<std::size_t>(i)] =
        static_cast<float>(p_.altitude_scale * std::exp(-(alt - p_.shell_bottom_m) / p_.altitude_length_bottom_m));
    barrier_top_[static_cast<std::size_t>(i)] =
        static_cast<float>(p_.altitude_scale * std::exp((alt - p_.shell_top_m) / p_.altitude_length_top_m));
  }
  build_term_mips();
  const std::vector<double> f = fractal_sample();
  build_coverage(f);
  build_detail_tables();
  if (p_.calibrate) calibrate();
  if (lift) apply_lift(std::move(lift));
  build_skip_map();
}

std::vector<double> CloudShell::fractal_sample() const {
  constexpr int n = 32768;
  std::vector<double> f(n);
  for (int s = 0; s < n; ++s) {
    double sum = 0;
    for (int i = 0; i < 3; ++i) {
      const auto u = static_cast<std::uint64_t>(s);
      sum += p_.fractals[static_cast<std::size_t>(i)].weight *
             (*tex_)[i].sample(static_cast<float>(uniform01(99, u, static_cast<std::uint64_t>(i), 0)),
                               static_cast<float>(uniform01(99, u, static_cast<std::uint64_t>(i), 1)),
                               static_cast<float>(uniform01(99, u, static_cast<std::uint64_t>(i), 2)));
    }
    f[static_cast<std::size_t>(s)] = sum;
  }
  std::sort(f.begin(), f.end());
  return f;
}

std::vector<std::vector<double>> CloudShell::column_sample() const {
  // Vertical columns through the unlifted shell, from two bottom length scales below its base to
  // two top ones above its top, at column_levels altitudes. Each term's column starts at a
  // hashed point of its tile and runs along a hashed direction (the terms' upwind points
  // differ, as in fractal_sample()), dz / LS_i tiles per metre of height. Per squeeze class j
  // the shell is lowered by shell_bottom + s_j, its top s_j nearer its bottom (bottom_lift()),
  // and each column's G_j = max over z of F(z) - barrier(z) in that shell.
  const int n = column_count, levels = column_levels, nj = squeeze_classes_;
  const double z0 = p_.shell_bottom_m - 2 * p_.altitude_length_bottom_m;
  const double dz = (p_.shell_top_m + 2 * p_.altitude_length_top_m - z0) / (levels - 1);
  std::vector<std::vector<double>> g(static_cast<std::size_t>(nj), std::vector<double>(static_cast<std::size_t>(n)));
#pragma omp parallel for schedule(static)
  for (int s = 0; s < n; ++s) {
    const auto u = static_cast<std::uint64_t>(s);
    std::array<earth::Vec3, 3> q0, step;
    for (std::uint64_t i = 0; i < 3; ++i) {
      q0[i] = {uniform01(98, u, i, 0), uniform01(98, u, i, 1), uniform01(98, u, i, 2)};
      const double cz = 2 * uniform01(98, u, i, 3) - 1, az = 2 * M_PI * uniform01(98, u, i, 4);
      const double sz = std::sqrt(1 - cz * cz);
      step[i] = earth::Vec3{sz * std::cos(az), sz * std::sin(az), cz} * (dz / p_.fractals[i].length_scale_m);
    }
    std::array<double, column_levels> f{};
    for (int k = 0; k < levels; ++k)
      for (std::size_t i = 0; i < 3; ++i) {
        const earth::Vec3 q = q0[i] + static_cast<double>(k) * step[i];
        f[static_cast<std::size_t>(k)] +=
            p_.fractals[i].weight * (*tex_)[static_cast<int>(i)].sample(static_cast<float>(q.x - std::floor(q.x)),
                                                                        static_cast<float>(q.y - std::floor(q.y)),
                                                                        static_cast<float>(q.z - std::floor(q.z)));
      }
    for (int j = 0; j < nj; ++j) {
      const double squeeze = nj > 1 ? j / inv_squeeze_step_m_ : 0.0;
      const double lift = squeeze > 0 ? -(p_.shell_bottom_m + squeeze) : 0.0;
      double best = -std::numeric_limits<double>::infinity();
      for (int k = 0; k < levels; ++k)
        best = std::max(best, f[static_cast<std::size_t>(k)] - barrier(z0 + k * dz + lift, lift));
      g[static_cast<std::size_t>(j)][static_cast<std::size_t>(s)] = best;
    }
  }
  for (auto& column : g) std::sort(column.begin(), column.end());
  return g;
}

void CloudShell::calibrate() {
  // phi(m) = threshold - Q_G(1 - m) at 1024 intervals of m, Q_G the sample quantile (linear
  // between order statistics) of the columns' G, so that a fraction m of columns reach
  // CF > threshold somewhere in their height: the projected cover, what a cloud fraction (the
  // masks', GFS's) means. Per squeeze class where the weather can lower the shell onto the
  // ground (cloud_top_lifts(): at most half its depth), so that a thinned shell keeps its cover.
  const double max_squeeze = 0.5 * (p_.shell_top_m - p_.shell_bottom_m) - p_.shell_bottom_m;
  squeeze_classes_ = max_squeeze > 0 ? squeeze_class_count : 1;
  inv_squeeze_step_m_ = max_squeeze > 0 ? (squeeze_classes_ - 1) / max_squeeze : 0.0;
  const std::vector<std::vector<double>> g = column_sample();
  bias_ = 0;
  const std::size_t row = mask_term_intervals + 1;
  mask_terms_.resize(static_cast<std::size_t>(squeeze_classes_) * row);
  for (std::size_t j = 0; j < g.size(); ++j) {
    const std::vector<double>& gj = g[j];
    const auto n = static_cast<double>(gj.size());
    for (int k = 0; k <= mask_term_intervals; ++k) {
      const double at = (1.0 - static_cast<double>(k) / mask_term_intervals) * (n - 1);
      const auto i = std::min(static_cast<std::size_t>(at), gj.size() - 2);
      const double q = gj[i] + (at - static_cast<double>(i)) * (gj[i + 1] - gj[i]);
      mask_terms_[j * row + static_cast<std::size_t>(k)] = p_.threshold - q;
    }
  }
}

void CloudShell::build_coverage(const std::vector<double>& f) {
  // Z = (F - mean) / sd with the mean and sd the filter uses (the voxels' mean and sigma_max_:
  // where every term is averaged away, u = (b + mean - thr) / sd and coverage is exactly the
  // sample's P(F > thr - b)); coverage(u) = P(Z > -u), the empirical exceedance (linear between
  // order statistics), tabulated over [-max Z, -min Z].
  double mean = 0;
  for (const TermMips& tm : term_mips_) mean += tm.mean_weighted;
  const double sd = sigma_max_;
  coverage_.assign(coverage_intervals + 1, 0.0);
  if (!(sd > 0)) {  // no fractal detail: a footprint is all on CF's side
    u_min_ = -1e-9, u_max_ = 1e-9, coverage_scale_ = coverage_intervals / (u_max_ - u_min_);
    for (int k = 0; k <= coverage_intervals; ++k) coverage_[static_cast<std::size_t>(k)] = k >= coverage_intervals / 2;
    return;
  }
  u_min_ = -(f.back() - mean) / sd, u_max_ = -(f.front() - mean) / sd;
  coverage_scale_ = coverage_intervals / (u_max_ - u_min_);
  const double nf = static_cast<double>(f.size() - 1);
  for (std::size_t k = 0; k < z_nodes_.size(); ++k)
    z_nodes_[k] = (f[static_cast<std::size_t>((static_cast<double>(k) + 0.5) / z_node_count * nf)] - mean) / sd;
  for (int k = 0; k <= coverage_intervals; ++k) {
    const double u = u_min_ + (u_max_ - u_min_) * k / coverage_intervals;
    const double fz = mean - u * sd;  // F at Z = -u: P(F > fz)
    const auto it = std::upper_bound(f.begin(), f.end(), fz);
    const auto i = static_cast<std::size_t>(it - f.begin());  // f[i - 1] <= fz < f[i]
    double below;                                             // the fractional rank of fz
    if (i == 0)
      below = 0;
    else if (i == f.size())
      below = nf;
    else
      below = static_cast<double>(i - 1) + (fz - f[i - 1]) / (f[i] - f[i - 1]);
    coverage_[static_cast<std::size_t>(k)] = 1 - below / nf;
  }
}

namespace {

// Texel (i, j) of face f of `out` (n x n) gets the largest of the (2 n + 5)^2 lattice values
// over its own texel grown by one texel on every side: lattice points 2i .. 2i + 6 along each
// axis (texel i spans 2i + 2 .. 2i + 4), separably, first along a, then over rows along b.
// Loops over i innermost, so that they vectorise (max is exact: any order gives the same).
void texel_maxima(const std::vector<float>& lattice, int n, int f, CubeMap<float>& out) {
  constexpr float lowest = -std::numeric_limits<float>::infinity();
  const int m = 2 * n + 5;
  std::vector<float> row_max(static_cast<std::size_t>(m) * n);
#pragma omp parallel for schedule(static)
  for (int b = 0; b < m; ++b) {
    const float* in = lattice.data() + static_cast<std::size_t>(b) * m;
    float* o = row_max.data() + static_cast<std::size_t>(b) * n;
    std::fill(o, o + n, lowest);
    for (int a = 0; a <= 6; ++a)
#pragma omp simd
      for (int i = 0; i < n; ++i) o[i] = std::max(o[i], in[2 * i + a]);
  }
#pragma omp parallel for schedule(static)
  for (int j = 0; j < n; ++j) {
    float* o = &out.texel(f, 0, j);
    std::fill(o, o + n, lowest);
    for (int b = 2 * j; b <= 2 * j + 6; ++b) {
      const float* in = row_max.data() + static_cast<std::size_t>(b) * n;
#pragma omp simd
      for (int i = 0; i < n; ++i) o[i] = std::max(o[i], in[i]);
    }
  }
}

// Added to each side of a point's altitude window [m]: the barrier tables' float rounding and
// linear interpolation move their values by < 1e-5 relative, a few millimetres of altitude.
constexpr double window_margin_m = 10;

}  // namespace

std::pair<double, double> CloudShell::point_window(double mask, double lift) const {
  // classify_filtered()'s first stage (mask_stage) gives u_min where the mask is below min_mask
  // or where bias + phi(m) - barrier + F_max < threshold + u_min sigma_max; the two barriers are
  // positive, so either one above the rest, the budget b, suffices: A exp(-(z - bottom - lift_b)
  // / L_b) > b below the window, A exp((z - top - lift) / L_t) > b above it.
  constexpr double nowhere = std::numeric_limits<double>::infinity();
  if (mask < p_.min_mask) return {nowhere, -nowhere};
  const double budget = bias_ + mask_term(mask, squeeze_m(lift)) + fractal_max_ - p_.threshold - u_min_ * sigma_max_;
  if (!(budget > 0)) return {nowhere, -nowhere};
  if (!(p_.altitude_scale > 0)) return {-nowhere, nowhere};
  const double reach = std::log(budget / p_.altitude_scale);
  return {p_.shell_bottom_m + bottom_lift(lift) - p_.altitude_length_bottom_m * reach - window_margin_m,
          p_.shell_top_m + lift + p_.altitude_length_top_m * reach + window_margin_m};
}

void CloudShell::build_skip_map() {
  // n x n texels per face (~0.18 deg, ~20 km at n = 512); each holds the widest window bounds
  // (point_window() of the displaced mask and lift) over its own texel grown by one texel on
  // every side, taken over a lattice of half-texel spacing (7 x 7 points per texel, the lattice
  // shared between texels), so a lookup anywhere in the texel bounds them within one texel
  // width around it. The mask itself is bilinear on a ~20 km cube map of the 0.25 deg GFS grid:
  // half-texel sampling resolves it. 6 MiB per map.
  constexpr int n = 512, m = 2 * n + 5;  // lattice points per face edge: u = (l - 2) / n - 1
  window_bottom_m_ = CubeMap<float>(n), window_top_m_ = CubeMap<float>(n);
  const std::size_t lattice_size = static_cast<std::size_t>(m) * m;
  std::vector<float> top(lattice_size), below(lattice_size);  // below: -bottom, so both take maxima
  for (int f = 0; f < 6; ++f) {
#pragma omp parallel
    {
      std::vector<double> x(m), y(m), z(m), ux(m), uy(m), uz(m);
#pragma omp for schedule(static)
      for (int b = 0; b < m; ++b) {
        // The row's directions as mask_at() forms them (so that the map bounds exactly the values
        // evaluate() sees), their upwind points in one batch (bit for bit the one-point call's).
        for (int a = 0; a < m; ++a) {
          const earth::Vec3 d = CubeMap<float>::face_point(f, (a - 2.0) / n - 1.0, (b - 2.0) / n - 1.0);
          const double inv_r = 1 / std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
          x[a] = d.x * inv_r, y[a] = d.y * inv_r, z[a] = d.z * inv_r;
        }
        maps_[0].upwind(x.data(), y.data(), z.data(), static_cast<std::size_t>(m), ux.data(), uy.data(), uz.data());
        for (int a = 0; a < m; ++a) {
          const earth::Vec3 u{ux[a], uy[a], uz[a]};
          const double mask = mask_->sample(u);  // the lift matters only where the mask does
          const auto [bottom_m, top_m] = point_window(mask, lift_ && mask >= p_.min_mask ? lift_->sample(u) : 0.0);
          const std::size_t k = static_cast<std::size_t>(b) * m + a;
          top[k] = static_cast<float>(top_m), below[k] = static_cast<float>(-bottom_m);
        }
      }
    }
    texel_maxima(top, n, f, window_top_m_);
    texel_maxima(below, n, f, window_bottom_m_);
  }
  for (float& v : window_bottom_m_.data()) v = -v;
  // The smallest texel on a gnomonic face spans 2/n of the tangent plane at the face corner,
  // an angle of about (2/n)/3 rad; one such texel of margin is what a lookup guarantees.
  skip_radius_rad_ = (2.0 / n) / 3.0;
}

void CloudShell::altitude_window(const double* x, const double* y, const double* z, std::size_t n, double* lo,
                                 double* hi) const {
  using Cube = CubeMap<float>;
  const float* bottom = window_bottom_m_.data().data();
  const float* top = window_top_m_.data().data();
  const int size = window_top_m_.size();
  const auto row = static_cast<std::size_t>(size);
  constexpr std::size_t block = 256;
  alignas(64) std::uint32_t idx[block];
  alignas(64) float tx[block], ty[block];
  for (std::size_t b0 = 0; b0 < n; b0 += block) {
    const std::size_t m = std::min(block, n - b0);
    Cube::locate_many(size, x + b0, y + b0, z + b0, m, idx, tx, ty);
    for (std::size_t i = 0; i < m; ++i) {
      // The four texels around the point; the one it lies in bounds its neighbourhood.
      const std::size_t k = idx[i];
      lo[b0 + i] = std::min({bottom[k], bottom[k + 1], bottom[k + row], bottom[k + row + 1]});
      hi[b0 + i] = std::max({top[k], top[k + 1], top[k + row], top[k + row + 1]});
    }
  }
}

double CloudShell::barrier_term(const std::vector<float>& table, double alt, bool top) const {
  const double x = alt - barrier_z0_;
  if (x < 0 || x >= static_cast<double>(table.size() - 1))
    return p_.altitude_scale * (top ? std::exp((alt - p_.shell_top_m) / p_.altitude_length_top_m)
                                    : std::exp(-(alt - p_.shell_bottom_m) / p_.altitude_length_bottom_m));
  const auto i = static_cast<std::size_t>(x);
  const double t = x - static_cast<double>(i);
  return table[i] + t * (table[i + 1] - table[i]);
}

double CloudShell::barrier(double alt, double lift) const {
  return barrier_term(barrier_bottom_, alt - bottom_lift(lift), false) + barrier_term(barrier_top_, alt - lift, true);
}

void CloudShell::set_lift(std::shared_ptr<const CubeMap<float>> lift) {
  apply_lift(std::move(lift));
  build_skip_map();  // the altitude window moves with the lift
}

void CloudShell::apply_lift(std::shared_ptr<const CubeMap<float>> lift) {
  if (lift && lift->size() != mask_->size())
    throw ValueError(
        fmt::format("a shell's lift map must be its mask's size ({}), not {}", mask_->size(), lift->size()));
  lift_ = std::move(lift);
  double lo = 0, hi = 0;
  if (lift_)
    for (float v : lift_->data()) lo = std::min(lo, static_cast<double>(v)), hi = std::max(hi, static_cast<double>(v));
  r_bottom_ = earth::radius_m + p_.shell_bottom_m + bottom_lift(lo);
  r_top_ = earth::radius_m + p_.shell_top_m + hi;
}

double CloudShell::lift_at(const earth::Vec3& p) const {
  if (!lift_) return 0;
  const double r = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
  return lift_->sample(maps_[0].upwind(p * (1 / r)));
}

double CloudShell::mask_at(const earth::Vec3& p) const {
  // The arithmetic of evaluate()'s first stage (and of the skip maps' lattice, build_skip_map()).
  const double r = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
  return mask_->sample(maps_[0].upwind(p * (1 / r)));
}

std::size_t CloudShell::active_terms(std::array<int, 3>& terms) const {
  std::size_t nt = 0;
  for (int i : order_)
    if (p_.fractals[static_cast<std::size_t>(i)].weight != 0) terms[nt++] = i;
  return nt;
}

bool CloudShell::shares_upwind(const std::array<int, 3>& terms, std::size_t t) const {
  return t > 0 && maps_[static_cast<std::size_t>(terms[t] + 1)].hours() ==
                      maps_[static_cast<std::size_t>(terms[t - 1] + 1)].hours();
}

double CloudShell::evaluate(const earth::Vec3& p, bool early_out) const {
  double out;
  evaluate(&p, 1, &out, early_out);
  return out;
}

namespace {

constexpr std::size_t eval_chunk = 128;  // points evaluated together (working set ~40 KiB)

// Texture footprints of a chunk of points, one array per field (noise::Texture3D::Footprint).
struct Footprints {
  alignas(64) std::uint32_t corner[eval_chunk], block[eval_chunk];
  alignas(64) float tx[eval_chunk], ty[eval_chunk], tz[eval_chunk];
  void set(std::size_t a, const noise::Texture3D::Footprint& f) {
    corner[a] = f.corner, block[a] = f.block, tx[a] = f.tx, ty[a] = f.ty, tz[a] = f.tz;
  }
  noise::Texture3D::Footprint operator[](std::size_t a) const { return {corner[a], block[a], tx[a], ty[a], tz[a]}; }
};

}  // namespace

// The working set of one chunk, as structure of arrays so that the geometric stages vectorise.
struct CloudShell::EvalWork {
  // Every point of the chunk: unit direction, radius, the mask's upwind direction.
  alignas(64) double x[eval_chunk], y[eval_chunk], z[eval_chunk], r[eval_chunk];
  alignas(64) double mx[eval_chunk], my[eval_chunk], mz[eval_chunk];
  // Where the mask and the barrier table are read (CubeMap::Location; table index and weight).
  alignas(64) std::uint32_t mask_index[eval_chunk];
  alignas(64) float mask_tx[eval_chunk], mask_ty[eval_chunk];
  // The points left after the first stage, compacted: chunk index, direction, radius, partial
  // CF, the upwind direction of the current term, footprints and bounds per term (in order).
  alignas(64) std::uint32_t id[eval_chunk];
  alignas(64) double lx[eval_chunk], ly[eval_chunk], lz[eval_chunk], lr[eval_chunk], v[eval_chunk];
  alignas(64) double ux[eval_chunk], uy[eval_chunk], uz[eval_chunk];
  std::array<Footprints, 3> f;
  alignas(64) double lo[3][eval_chunk], hi[3][eval_chunk];
  alignas(64) std::uint16_t words[eval_chunk];          // the current term's packed block bounds
  std::array<std::uint32_t, eval_chunk> sel, sel_next;  // compacted positions still undecided
  alignas(64) float texel[eval_chunk];                  // the current term's samples, in sel order
  // Filtered only, per live point: sigma, each fractal's pyramid level (by fractal index), and
  // per term (in order) the level's texture (null: the mean level).
  alignas(64) double sigma[eval_chunk];
  double u_min = 0, u_max = 0;  // the shell's range of u (CloudShell::u_min(), u_max())
  std::uint8_t level[3][eval_chunk];
  const noise::Texture3D* level_tex[3][eval_chunk];
  // Bounds of the terms from position t on: their local bounds' sum (sides fixed by the sign of
  // each weight).
  void rest(std::size_t a, std::size_t t, std::size_t nt, double& lo_sum, double& hi_sum) const {
    lo_sum = hi_sum = 0;
    for (std::size_t u = t; u < nt; ++u) lo_sum += lo[u][a], hi_sum += hi[u][a];
  }
  // The side of the threshold the bounds [v + lo, v + hi] decide: filtered, beyond the reach of
  // the sub-pixel detail (u outside [u_min, u_max]), else the threshold itself.
  template <bool Filtered>
  void decide(std::size_t a, double cf, double lo_rest, double hi_rest, double thr, bool& below, bool& above) const {
    if constexpr (Filtered) {
      below = (cf + hi_rest < thr + u_min * sigma[a]), above = (cf + lo_rest > thr + u_max * sigma[a]);
    } else {
      below = (cf + hi_rest < thr), above = (cf + lo_rest > thr);
    }
  }
  // What a decided point returns: a bound on its side (classify()), or filtered an end of u.
  template <bool Filtered>
  double decided(double cf, double lo_rest, double hi_rest, bool below) const {
    if constexpr (Filtered) return below ? u_min : u_max;
    return cf + (below ? hi_rest : lo_rest);
  }
  // What an exact value returns: CF, or filtered, u = (CF - thr) / sigma within [u_min, u_max].
  template <bool Filtered>
  double exact(std::size_t a, double cf, double thr) const {
    if constexpr (Filtered) {
      if (!(sigma[a] > 0)) return cf > thr ? u_max : u_min;
      return std::clamp((cf - thr) / sigma[a], u_min, u_max);
    }
    return cf;
  }
};

namespace {

// std::min and std::max by value (as in the renderer's vectorised loops: GCC 12 vectorises these).
[[gnu::always_inline]] inline double min_v(double a, double b) { return b < a ? b : a; }
[[gnu::always_inline]] inline double max_v(double a, double b) { return a < b ? b : a; }

// log2(x) for x > 0 (normal), within 0.008: the exponent's bits and a quadratic in the
// mantissa m in [1, 2) (log2 m ~ (m - 1)(1.3466 - 0.3466 (m - 1)), exact at m = 1 and 2). What
// a pyramid level needs, without a library call per point.
double fast_log2(double x) {
  const auto bits = std::bit_cast<std::uint64_t>(x);
  const double e = static_cast<double>(static_cast<int>((bits >> 52) & 0x7ff) - 1023);
  const double f = std::bit_cast<double>((bits & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL) - 1.0;
  return e + f * (1.3466 - 0.3466 * f);
}

// A counter-based hash of a point's coordinates: the random rounding of its pyramid levels.
std::uint64_t point_hash(const earth::Vec3& p) {
  return mix64(std::bit_cast<std::uint64_t>(p.x) ^
               mix64(std::bit_cast<std::uint64_t>(p.y) ^ mix64(std::bit_cast<std::uint64_t>(p.z))));
}

}  // namespace

void CloudShell::build_term_mips() {
  sigma_max_ = 0;
  for (int i = 0; i < 3; ++i) {
    const FractalTerm& term = p_.fractals[static_cast<std::size_t>(i)];
    const noise::MipPyramid& mip = tex_->mips[static_cast<std::size_t>(i)];
    TermMips& tm = term_mips_[static_cast<std::size_t>(i)];
    tm = TermMips{};
    for (std::size_t l = 0; l < TermMips::max_levels; ++l) {
      const noise::Texture3D* lt = tex_->level(i, static_cast<int>(l));
      tm.addressing[l] = (lt ? *lt : (*tex_)[i]).addressing();
    }
    if (mip.stats.empty()) {  // no pyramid: every footprint reads level 0
      tm.top_level = 1, tm.top = 0;
      tm.hi[0] = tm.hi[1] = std::max(0.0, term.weight);
      continue;
    }
    // A footprint of width w is a box of standard deviation w / sqrt(12); a trilinear sample of
    // level l averages with one of 2^l voxels / 2 (a box of 2^l voxels under a tent of as many):
    // equal at 2^l voxels = w / sqrt(3), so the level is log2(w / voxel) - log2(sqrt(3)).
    tm.log2_voxels_per_m = std::log2((*tex_)[i].size() / term.length_scale_m) - 0.5 * std::log2(3.0);
    tm.mean_weighted = term.weight * mip.stats[0].mean;
    sigma_max_ = std::sqrt(sigma_max_ * sigma_max_ + term.weight * term.weight * mip.stats[0].variance);
    tm.mean = mip.stats.back().mean;
    const double w = term.weight;
    const double gradient_0 = mip.stats[0].gradient * std::pow((*tex_)[i].size() / term.length_scale_m, 2);
    if (mip.stats.size() > TermMips::max_levels)
      throw ValueError(fmt::format("a mip pyramid of {} levels: at most {}", mip.stats.size(), TermMips::max_levels));
    for (std::size_t l = 0; l < mip.stats.size(); ++l) {
      const noise::TextureStats& st = mip.stats[l];
      tm.lost_variance[l] = w * w * (mip.stats[0].variance - st.variance);
      // Per voxel^2 to per m^2: level l has size / 2^l voxels per tile (none past the last).
      const double voxels_per_m = std::ldexp((*tex_)[i].size(), -static_cast<int>(l)) / term.length_scale_m;
      tm.lost_gradient[l] = w * w * (gradient_0 - st.gradient * voxels_per_m * voxels_per_m);
      tm.hi[l] = std::max(w * st.lo, w * st.hi);
    }
    tm.top_level = static_cast<int>(mip.stats.size()) - 1;
    tm.top = tm.top_level;
  }
}

void CloudShell::build_detail_tables() {
  // Footprints from 1 m to 2^26 m (beyond the Earth's size), 8 nodes per octave.
  const std::size_t n = 26 * footprint_nodes_per_octave + 1;
  detail_length_.assign(n, std::numeric_limits<double>::infinity()), detail_variance_.assign(n, 0.0);
  detail_gradient_variance_.assign(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const double log2_s = static_cast<double>(k) / footprint_nodes_per_octave;
    double var = 0, rate = 0, grad = 0;  // sigma^2, its share-weighted sum of the bands' rates 1 / length; |grad|^2
    for (std::size_t i = 0; i < 3; ++i) {
      const TermMips& tm = term_mips_[i];
      if (tm.top_level < 1 || tm.top <= 0) continue;
      const FractalTerm& term = p_.fractals[i];
      const double voxel_m = term.length_scale_m / (*tex_)[static_cast<int>(i)].size();
      const double x = std::clamp(log2_s + tm.log2_voxels_per_m, 0.0, tm.top);
      const int lx = std::min(static_cast<int>(x), tm.top_level - 1);
      const auto lg = static_cast<std::size_t>(lx);
      grad += tm.lost_gradient[lg] + (x - lx) * (tm.lost_gradient[lg + 1] - tm.lost_gradient[lg]);
      for (int l = 0; l < tm.top_level && l < x; ++l) {
        const auto lu = static_cast<std::size_t>(l);
        const double share = std::min(1.0, x - l) * (tm.lost_variance[lu + 1] - tm.lost_variance[lu]);
        var += share, rate += share / (voxel_m * std::exp2(l + 0.5));
      }
    }
    detail_variance_[k] = var, detail_gradient_variance_[k] = grad;
    if (var > 0) detail_length_[k] = var / rate;
  }
  log_clear_.resize(coverage_.size());
  for (std::size_t k = 0; k < coverage_.size(); ++k) log_clear_[k] = std::log(std::max(1 - coverage_[k], 1e-12));
}

void PathCoverage::split(const CloudShell& s) {
  split_ = true;
  const double var = s.detail_variance(footprint_m_), renewing = s.detail_variance(std::min(footprint_m_, path_m_));
  if (!(renewing > 1e-6 * var)) return;  // nothing renews along so short a path: the likeliest step
  scale_ = std::sqrt(var / renewing), rate_ = 1 / s.detail_length_m(std::min(footprint_m_, path_m_));
  const double shared = std::sqrt(std::max(0.0, var - renewing) / renewing);  // sigma_c / sigma_renewing
  for (std::size_t k = 0; k < shift_.size(); ++k) shift_[k] = s.z_nodes()[k] * shared;
}

double PathCoverage::chance() const {
  if (rate_ <= 0) return c_max_;  // no cloud met (0), or none renewing: the likeliest step
  // The exponentials in a loop that vectorises (core/simd_math.hpp), then summed in order.
  std::array<double, CloudShell::z_node_count> clear_at;
  for (std::size_t k = 0; k < clear_at.size(); ++k) clear_at[k] = std::exp(log_clear_[k]);
  double clear = 0;
  for (const double c : clear_at) clear += c / static_cast<double>(clear_at.size());
  return std::max(c_max_, 1 - clear);
}

// The stages are always inlined into evaluate(): they are its parts, and separately compiled
// they would lose the knowledge that out does not alias the chunk's working set.

// Stage 1: direction, radius, the mask at its upwind point and the altitude barriers; points
// that cannot reach the level set get their value here and leave, the others are compacted
// into w's live arrays. Returns their count. Filtered: also each point's pyramid levels and
// sigma, and the bound of the filtered fractal sum from its levels' ranges.
template <bool Filtered>
[[gnu::always_inline]] inline std::size_t CloudShell::mask_stage(const earth::Vec3* p, std::size_t c0, std::size_t m,
                                                                 double* out, EvalWork& w) const {
  const double thr = p_.threshold;
  const CubeMap<float>& mask_cube = *mask_;
  const float* mask_texels = mask_cube.data().data();
  const float* lift_texels = lift_ ? lift_->data().data() : nullptr;
  const int mask_n = mask_cube.size();
  const float* bb = barrier_bottom_.data();
  const float* bt = barrier_top_.data();
  const std::size_t bt_end = barrier_top_.size() - 1;
  const double bt_last = static_cast<double>(bt_end), beyond_ends = 1 - 1e-6;
#pragma omp simd
  for (std::size_t j = 0; j < m; ++j) {
    const earth::Vec3& q = p[c0 + j];
    const double r = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    const double inv_r = 1 / r;  // one division instead of three
    w.r[j] = r, w.x[j] = q.x * inv_r, w.y[j] = q.y * inv_r, w.z[j] = q.z * inv_r;
  }
  maps_[0].upwind(w.x, w.y, w.z, m, w.mx, w.my, w.mz);
  CubeMap<float>::locate_many(mask_n, w.mx, w.my, w.mz, m, w.mask_index, w.mask_tx, w.mask_ty);
  // The mask's, the lift's and the barrier table's loads in this scalar loop, not in the
  // vectorised ones above (CubeMap::locate_many: vectorised, GCC gathers them, slower on AMD
  // cores than scalar loads from cached lines; the cube maps are read coherently along image
  // rows). The lift reads the mask's texels' positions in its own map of the same size.
  std::size_t live = 0;
  for (std::size_t j = 0; j < m; ++j) {
    using Cube = CubeMap<float>;
    const Cube::Location l{w.mask_index[j], w.mask_tx[j], w.mask_ty[j]};
    const double mask = Cube::blend_at(l, mask_texels, l.index, 1, static_cast<std::size_t>(mask_n));
    const double lift =
        lift_texels ? Cube::blend_at(l, lift_texels, l.index, 1, static_cast<std::size_t>(mask_n)) : 0.0;
    const double alt = w.r[j] - earth::radius_m, xt = alt - barrier_z0_ - lift;
    const double xb = alt - barrier_z0_ - bottom_lift(lift);
    // Filtered: out of reach whatever the footprint (sigma at most sigma_max_, the fractal sum
    // within its bounds); the footprint's own reach is level_stage()'s.
    const double margin = Filtered ? u_min_ * sigma_max_ : 0.0;
    const double smooth = bias_ + mask_term(mask, squeeze_m(lift));
    double bar;
    if (xb >= 0 && xb <= bt_last - 1 && xt >= 0 && xt <= bt_last - 1) {
      const auto ib = static_cast<std::size_t>(xb), it = static_cast<std::size_t>(xt);
      bar = bb[ib] + (xb - static_cast<double>(ib)) * (bb[ib + 1] - bb[ib]) + bt[it] +
            (xt - static_cast<double>(it)) * (bt[it + 1] - bt[it]);
    } else if (Filtered && smooth - beyond_ends * ((xb < 0 ? bb[0] : 0.0) + (xt > bt_last ? bt[bt_end] : 0.0)) <
                               thr + margin - fractal_max_) {
      // Beyond a table's end its barrier exceeds the end value (both barriers are positive and
      // monotone; beyond_ends covers the values' float rounding): a filtered point this bound
      // puts out of reach takes u_min whatever its exact barrier, found without exp.
      bar = std::numeric_limits<double>::infinity();
    } else {
      bar = barrier(alt, lift);  // off the tables
    }
    const double base = smooth - bar;
    if (mask < p_.min_mask) {
      out[c0 + j] = Filtered ? u_min_ : std::min(base + fractal_max_, thr) - 1.0;
    } else if (base + fractal_max_ < thr + margin) {
      out[c0 + j] = Filtered ? u_min_ : base + fractal_max_;  // cannot reach the level set
    } else {
      w.id[live] = static_cast<std::uint32_t>(j);
      w.lx[live] = w.x[j], w.ly[live] = w.y[j], w.lz[live] = w.z[j], w.lr[live] = w.r[j];
      w.v[live] = base;
      ++live;
    }
  }
  return live;
}

// Stage 1b, filtered: each live point's pyramid levels (randomly rounded: 21 bits of the
// point's hash per term), sigma, and the bound of its filtered fractal sum from its levels'
// ranges, in a loop that vectorises (the tables are fixed arrays); the points this bound puts
// out of reach leave. Returns the count left.
[[gnu::always_inline]] inline std::size_t CloudShell::level_stage(const earth::Vec3* p, const double* footprint_m,
                                                                  std::size_t c0, std::size_t nlive, double* out,
                                                                  EvalWork& w) const {
  alignas(64) double f_max[eval_chunk];
  const TermMips* tm = term_mips_.data();
#pragma omp simd
  for (std::size_t a = 0; a < nlive; ++a) {
    const std::size_t j = c0 + w.id[a];
    const double log2_s = fast_log2(max_v(footprint_m[j], 1e-3));
    const std::uint64_t h = point_hash(p[j]);
    double var = 0, fm = 0;
    for (int i = 0; i < 3; ++i) {
      const TermMips& m = tm[i];
      const double x = min_v(max_v(log2_s + m.log2_voxels_per_m, 0.0), m.top);
      const int l = std::min(static_cast<int>(x), m.top_level - 1);
      const double f = x - l, u = static_cast<double>((h >> (21 * i)) & 0x1fffff) * 0x1.0p-21;
      const auto lu = static_cast<std::size_t>(l);
      var += m.lost_variance[lu] + f * (m.lost_variance[lu + 1] - m.lost_variance[lu]);
      const std::size_t lv = lu + (u < f ? 1 : 0);
      w.level[i][a] = static_cast<std::uint8_t>(lv);
      fm += m.hi[lv];
    }
    w.sigma[a] = std::sqrt(var), f_max[a] = fm;
  }
  std::size_t kept = 0;
  for (std::size_t a = 0; a < nlive; ++a) {
    if (w.v[a] + f_max[a] < p_.threshold + u_min_ * w.sigma[a]) {
      out[c0 + w.id[a]] = u_min_;
      continue;
    }
    w.id[kept] = w.id[a], w.lx[kept] = w.lx[a], w.ly[kept] = w.ly[a], w.lz[kept] = w.lz[a], w.lr[kept] = w.lr[a];
    w.v[kept] = w.v[a], w.sigma[kept] = w.sigma[a];
    for (int i = 0; i < 3; ++i) w.level[i][kept] = w.level[i][a];
    ++kept;
  }
  return kept;
}

// Stage 2: the upwind points and texture footprints of every fractal term (texture
// coordinates in tiles, reduced in double before the float lookup) and, for classify(), the
// terms' bounds over the footprints' blocks. Filtered: each point's footprint in its level's
// texture; the mean level's value is its own bound.
template <bool Filtered>
[[gnu::always_inline]] inline void CloudShell::footprint_stage(const std::array<int, 3>& terms, std::size_t nt,
                                                               std::size_t nlive, bool early_out, EvalWork& w) const {
  for (std::size_t t = 0; t < nt; ++t) {
    const int i = terms[t];
    const FractalTerm& term = p_.fractals[static_cast<std::size_t>(i)];
    const DisplacementMap& map = maps_[static_cast<std::size_t>(i + 1)];
    if (!shares_upwind(terms, t)) map.upwind(w.lx, w.ly, w.lz, nlive, w.ux, w.uy, w.uz);
    const noise::Texture3D& tex = (*tex_)[i];
    const double inv_ls = 1 / term.length_scale_m;
    Footprints& f = w.f[t];
    if constexpr (Filtered) {
      // Each point's footprint in its level's texture, in a loop that vectorises (the levels'
      // addressing from a table); then the level textures and their bounds' prefetches.
      const noise::Texture3D::Addressing* addressing = term_mips_[static_cast<std::size_t>(i)].addressing.data();
      const std::uint8_t* level = w.level[i];
#pragma omp simd
      for (std::size_t a = 0; a < nlive; ++a) {
        const double k = w.lr[a] * inv_ls;
        const double qx = w.ux[a] * k, qy = w.uy[a] * k, qz = w.uz[a] * k;
        f.set(a, noise::Texture3D::footprint(addressing[level[a]], static_cast<float>(qx - std::floor(qx)),
                                             static_cast<float>(qy - std::floor(qy)),
                                             static_cast<float>(qz - std::floor(qz))));
      }
      for (std::size_t a = 0; a < nlive; ++a) {
        const noise::Texture3D* lt = tex_->level(i, level[a]);
        w.level_tex[t][a] = lt;
        if (lt) lt->prefetch_bounds(f.block[a]);
      }
      continue;
    }
#pragma omp simd
    for (std::size_t a = 0; a < nlive; ++a) {
      const double k = w.lr[a] * inv_ls;
      const double qx = w.ux[a] * k, qy = w.uy[a] * k, qz = w.uz[a] * k;
      f.set(a, tex.footprint(static_cast<float>(qx - std::floor(qx)), static_cast<float>(qy - std::floor(qy)),
                             static_cast<float>(qz - std::floor(qz))));
    }
    // The bounds table (512 KiB per texture) lives in L3, not L2: its lines are requested
    // here and read after the other terms' footprints, so that the misses overlap
    // (docs/PERFORMANCE.md, design choices).
    if (early_out)
      for (std::size_t a = 0; a < nlive; ++a) tex.prefetch_bounds(f.block[a]);
  }
  if (!early_out) return;  // value() adds every term: no bounds needed
  for (std::size_t t = 0; t < nt; ++t) {
    const int i = terms[t];
    const double weight = p_.fractals[static_cast<std::size_t>(i)].weight;
    const noise::Texture3D& tex = (*tex_)[i];
    const Footprints& f = w.f[t];
    if constexpr (Filtered) {
      const double mean = weight * term_mips_[static_cast<std::size_t>(i)].mean;
      for (std::size_t a = 0; a < nlive; ++a) {
        const noise::Texture3D* lt = w.level_tex[t][a];
        if (!lt) {
          w.lo[t][a] = w.hi[t][a] = mean;
          continue;
        }
        const noise::Texture3D::Bounds b = lt->bounds(f[a]);
        w.lo[t][a] = std::min(weight * b.lo, weight * b.hi), w.hi[t][a] = std::max(weight * b.lo, weight * b.hi);
      }
      continue;
    }
    for (std::size_t a = 0; a < nlive; ++a) w.words[a] = tex.block_word(f.block[a]);
#pragma omp simd
    for (std::size_t a = 0; a < nlive; ++a) {
      const noise::Texture3D::Bounds b = noise::Texture3D::bounds_from(w.words[a]);
      const double wl = weight * b.lo, wh = weight * b.hi;
      w.lo[t][a] = std::min(wl, wh);
      w.hi[t][a] = std::max(wl, wh);
    }
  }
}

// The live points whose side the bounds do not decide, into w.sel; returns their count. The
// decided ones get a bound on their side as their value. Branch-free, since the bounds'
// verdicts are hard to predict: every point is written with its bound and stored as selected;
// only an undecided one advances the count (its value is written again later).
template <bool Filtered>
[[gnu::always_inline]] inline std::size_t CloudShell::select_stage(std::size_t c0, std::size_t nt, std::size_t nlive,
                                                                   bool early_out, double* out, EvalWork& w) const {
  std::size_t nsel = 0;
  if (!early_out) {
    for (std::size_t a = 0; a < nlive; ++a) w.sel[nsel++] = static_cast<std::uint32_t>(a);
    return nsel;
  }
  const double thr = p_.threshold;
  for (std::size_t a = 0; a < nlive; ++a) {
    double lo, hi;
    w.rest(a, 0, nt, lo, hi);
    const double v = w.v[a];
    bool below, above;  // the side decided by the local bounds
    w.template decide<Filtered>(a, v, lo, hi, thr, below, above);
    out[c0 + w.id[a]] = w.template decided<Filtered>(v, lo, hi, below);
    w.sel[nsel] = static_cast<std::uint32_t>(a);
    nsel += !(below | above);
  }
  return nsel;
}

// Stage 3: per term, in order, the sample of the selected points, which leave as soon as the
// bounds of the terms not yet added decide their side. The undecided points are compacted into
// a second array, not in place: in place, the loads of sel[b + 1] and on waited on the store to
// sel[kept], whose address depends on the previous verdict (docs/PERFORMANCE.md, design
// choices).
template <bool Filtered>
[[gnu::always_inline]] inline void CloudShell::sample_stage(const std::array<int, 3>& terms, std::size_t nt,
                                                            std::size_t c0, std::size_t nsel, bool early_out,
                                                            double* out, EvalWork& w) const {
  const double thr = p_.threshold;
  std::uint32_t* sel = w.sel.data();
  std::uint32_t* sel_next = w.sel_next.data();
  for (std::size_t t = 0; t < nt; ++t) {
    const int i = terms[t];
    const double weight = p_.fractals[static_cast<std::size_t>(i)].weight;
    const noise::Texture3D& tex = (*tex_)[i];
    // The fetches first, in a loop with no branch on their values, so that a mispredicted
    // decision cannot squash the younger fetches in flight (the misses overlap).
    const Footprints& f = w.f[t];
    if constexpr (Filtered) {
      const auto mean = static_cast<float>(term_mips_[static_cast<std::size_t>(i)].mean);
      for (std::size_t b = 0; b < nsel; ++b)
        if (const noise::Texture3D* lt = w.level_tex[t][sel[b]]) lt->prefetch(f[sel[b]]);
      for (std::size_t b = 0; b < nsel; ++b) {
        const noise::Texture3D* lt = w.level_tex[t][sel[b]];
        w.texel[b] = lt ? lt->sample(f[sel[b]]) : mean;
      }
    } else {
      for (std::size_t b = 0; b < nsel; ++b) tex.prefetch(f[sel[b]]);
      for (std::size_t b = 0; b < nsel; ++b) w.texel[b] = tex.sample(f[sel[b]]);
    }
    std::size_t kept = 0;
    if (t + 1 == nt) {  // every term added: exact
      for (std::size_t b = 0; b < nsel; ++b) {
        const std::uint32_t a = sel[b];
        out[c0 + w.id[a]] = w.template exact<Filtered>(a, w.v[a] += weight * w.texel[b], thr);
      }
    } else if (early_out) {  // branch-free, as select_stage
      for (std::size_t b = 0; b < nsel; ++b) {
        const std::uint32_t a = sel[b];
        const double v = w.v[a] += weight * w.texel[b];
        double lo, hi;
        w.rest(a, t + 1, nt, lo, hi);
        // Decided: out holds a bound on the same side of the threshold.
        bool below, above;
        w.template decide<Filtered>(a, v, lo, hi, thr, below, above);
        out[c0 + w.id[a]] = w.template decided<Filtered>(v, lo, hi, below);
        sel_next[kept] = a;
        kept += !(below | above);
      }
    } else {
      for (std::size_t b = 0; b < nsel; ++b) w.v[sel[b]] += weight * w.texel[b];
      kept = nsel;
    }
    if (early_out && t + 1 < nt) std::swap(sel, sel_next);
    nsel = kept;
  }
  for (std::size_t b = 0; b < nsel; ++b)  // no terms at all
    out[c0 + w.id[sel[b]]] = w.template exact<Filtered>(sel[b], w.v[sel[b]], thr);
}

void CloudShell::evaluate(const earth::Vec3* p, std::size_t n, double* out, bool early_out) const {
  // Staged over chunks of points; the geometric stages are branch-free loops over arrays that
  // the compiler vectorises (AVX-512: 8 points per instruction), and the texture fetches of a
  // chunk's points are independent, so out-of-order execution overlaps their cache misses
  // (and a prefetch pass ahead of them overlaps more). Each point sees exactly the arithmetic
  // of a one-point call, so results do not depend on n.
  std::array<int, 3> terms{};
  const std::size_t nt = active_terms(terms);
  EvalWork w;
  for (std::size_t c0 = 0; c0 < n; c0 += eval_chunk) {
    const std::size_t m = std::min(eval_chunk, n - c0);
    const std::size_t nlive = mask_stage<false>(p, c0, m, out, w);
    footprint_stage<false>(terms, nt, nlive, early_out, w);
    const std::size_t nsel = select_stage<false>(c0, nt, nlive, early_out, out, w);
    sample_stage<false>(terms, nt, c0, nsel, early_out, out, w);
  }
}

void CloudShell::evaluate_filtered(const earth::Vec3* p, const double* footprint_m, std::size_t n, double* out) const {
  // evaluate()'s stages with each point's pyramid levels and sigma (classify_filtered()).
  std::array<int, 3> terms{};
  const std::size_t nt = active_terms(terms);
  EvalWork w;
  w.u_min = u_min_, w.u_max = u_max_;
  for (std::size_t c0 = 0; c0 < n; c0 += eval_chunk) {
    const std::size_t m = std::min(eval_chunk, n - c0);
    const std::size_t nlive = level_stage(p, footprint_m, c0, mask_stage<true>(p, c0, m, out, w), out, w);
    footprint_stage<true>(terms, nt, nlive, true, w);
    const std::size_t nsel = select_stage<true>(c0, nt, nlive, true, out, w);
    sample_stage<true>(terms, nt, c0, nsel, true, out, w);
  }
}

void classify_filtered_in_windows(const CloudShell& s, const earth::Vec3* p, const double* footprint_m,
                                  const double* r2_lo, const double* r2_hi, std::size_t n, double* out) {
  thread_local std::vector<std::uint32_t> inside;
  thread_local std::vector<earth::Vec3> in_p;
  thread_local std::vector<double> in_fp, in_out;
  inside.resize(n), in_p.resize(n), in_fp.resize(n), in_out.resize(n);
  const double u_min = s.u_min();
  std::size_t na = 0;
  for (std::size_t j = 0; j < n; ++j) {  // compacted without branches: every point written, the kept advance
    const earth::Vec3& q = p[j];
    const double r2 = std::fma(q.z, q.z, std::fma(q.y, q.y, q.x * q.x));
    inside[na] = static_cast<std::uint32_t>(j), in_p[na] = q, in_fp[na] = footprint_m[j];
    na += (r2 >= r2_lo[j]) & (r2 <= r2_hi[j]);
    out[j] = u_min;
  }
  s.classify_filtered(in_p.data(), in_fp.data(), na, in_out.data());
  for (std::size_t a = 0; a < na; ++a) out[inside[a]] = in_out[a];
}

void CloudShell::value_and_gradient(const earth::Vec3* p, std::size_t n, double h, double* value, earth::Vec3* gradient,
                                    const double* footprint_m) const {
  // Per chunk, four positions per point (the point, then +h along x, y, z), as arrays:
  //  1. the mask term at all four, differenced, and the barriers' derivative;
  //  2. per fractal term, its unwrapped texture coordinates Q = (r / LS) upwind(x / r) at all
  //     four (differenced: the Jacobian dQ/dx), the footprint at the point, then the fetches
  //     in a loop of their own so that their cache misses overlap;
  //  3. value = b + w mask - barrier + sum m_i T_i, gradient = the same terms' derivatives,
  //     grad T_i chained as J_i^T grad_Q T_i.
  constexpr std::size_t chunk = 64;
  constexpr std::size_t m4 = 4 * chunk;
  alignas(64) double x[m4], y[m4], z[m4], r[m4], ux[m4], uy[m4], uz[m4], smooth[m4];
  alignas(64) double qx[m4], qy[m4], qz[m4];
  std::array<noise::Texture3D::Footprint, chunk> fp;
  std::array<noise::Texture3D::ValueGradient, chunk> tg;
  std::array<const noise::Texture3D*, chunk> level_tex;  // filtered: each point's level of the term
  std::array<int, 3> terms{};
  const std::size_t nt = active_terms(terms);
  const double inv_h = 1 / h;
  for (std::size_t c0 = 0; c0 < n; c0 += chunk) {
    const std::size_t m = std::min(chunk, n - c0);
    for (std::size_t a = 0; a < m; ++a) {
      const earth::Vec3& q = p[c0 + a];
      for (std::size_t k = 0; k < 4; ++k) {
        const std::size_t s = k * chunk + a;
        const double px = q.x + (k == 1 ? h : 0.0), py = q.y + (k == 2 ? h : 0.0), pz = q.z + (k == 3 ? h : 0.0);
        const double rr = std::sqrt(px * px + py * py + pz * pz), inv_r = 1 / rr;  // evaluate()'s arithmetic
        r[s] = rr, x[s] = px * inv_r, y[s] = py * inv_r, z[s] = pz * inv_r;
      }
    }
    // Stage 1: the mask term (as evaluate()'s first stage, without its early exits).
    for (std::size_t k = 0; k < 4; ++k) {
      const std::size_t o = k * chunk;
      maps_[0].upwind(x + o, y + o, z + o, m, ux + o, uy + o, uz + o);
      for (std::size_t a = 0; a < m; ++a) {
        const earth::Vec3 at{ux[o + a], uy[o + a], uz[o + a]};
        smooth[o + a] = mask_term(mask_->sample(at), lift_ ? squeeze_m(lift_->sample(at)) : 0.0);
      }
    }
    for (std::size_t a = 0; a < m; ++a) {
      // The barriers' derivative analytic (their length scales, 150 m and up, are not much
      // longer than h), along the vertical.
      const double alt = r[a] - earth::radius_m;
      const double lift = lift_ ? lift_->sample(earth::Vec3{ux[a], uy[a], uz[a]}) : 0.0;
      const double e_bottom = std::exp(-(alt - bottom_lift(lift) - p_.shell_bottom_m) / p_.altitude_length_bottom_m),
                   e_top = std::exp((alt - lift - p_.shell_top_m) / p_.altitude_length_top_m);
      const double dbarrier =
          p_.altitude_scale * (e_top / p_.altitude_length_top_m - e_bottom / p_.altitude_length_bottom_m);
      const double s0 = smooth[a];
      gradient[c0 + a] = earth::Vec3{(smooth[chunk + a] - s0) * inv_h, (smooth[2 * chunk + a] - s0) * inv_h,
                                     (smooth[3 * chunk + a] - s0) * inv_h} -
                         dbarrier * earth::Vec3{x[a], y[a], z[a]};
      if (value) value[c0 + a] = bias_ + s0 - barrier(alt, lift);
    }
    // Stage 2: the fractal terms, in evaluate()'s order.
    for (std::size_t t = 0; t < nt; ++t) {
      const int i = terms[t];
      const FractalTerm& term = p_.fractals[static_cast<std::size_t>(i)];
      const DisplacementMap& map = maps_[static_cast<std::size_t>(i + 1)];
      if (!shares_upwind(terms, t))
        for (std::size_t k = 0; k < 4; ++k) {
          const std::size_t o = k * chunk;
          map.upwind(x + o, y + o, z + o, m, ux + o, uy + o, uz + o);
        }
      const noise::Texture3D& tex = (*tex_)[i];
      const double inv_ls = 1 / term.length_scale_m;
      for (std::size_t k = 0; k < 4; ++k)
        for (std::size_t a = 0; a < m; ++a) {
          const std::size_t s = k * chunk + a;
          const double kk = r[s] * inv_ls;
          qx[s] = ux[s] * kk, qy[s] = uy[s] * kk, qz[s] = uz[s] * kk;
        }
      for (std::size_t a = 0; a < m; ++a) {
        level_tex[a] = &tex;
        if (footprint_m) {  // classify_filtered()'s level at this point
          double lost;
          const double u = static_cast<double>((point_hash(p[c0 + a]) >> (21 * i)) & 0x1fffff) * 0x1.0p-21;
          level_tex[a] = tex_->level(i, term_level(i, fast_log2(std::max(footprint_m[c0 + a], 1e-3)), u, lost));
        }
        if (!level_tex[a]) continue;
        fp[a] = level_tex[a]->footprint(static_cast<float>(qx[a] - std::floor(qx[a])),
                                        static_cast<float>(qy[a] - std::floor(qy[a])),
                                        static_cast<float>(qz[a] - std::floor(qz[a])));
      }
      for (std::size_t a = 0; a < m; ++a)
        if (level_tex[a]) level_tex[a]->prefetch(fp[a]);
      const auto mean = static_cast<float>(term_mips_[static_cast<std::size_t>(i)].mean);
      for (std::size_t a = 0; a < m; ++a)
        tg[a] = level_tex[a] ? level_tex[a]->sample_gradient(fp[a]) : noise::Texture3D::ValueGradient{mean, 0, 0, 0};
      const double weight = term.weight;
      for (std::size_t a = 0; a < m; ++a) {
        // grad_x T = J^T grad_Q T with J[j][k] = dQ_j / dx_k (forward differences).
        const earth::Vec3 gq{tg[a].du, tg[a].dv, tg[a].dw};
        earth::Vec3 g{};
        for (std::size_t k = 1; k < 4; ++k) {
          const std::size_t s = k * chunk + a;
          const earth::Vec3 dq{(qx[s] - qx[a]) * inv_h, (qy[s] - qy[a]) * inv_h, (qz[s] - qz[a]) * inv_h};
          g[static_cast<glm::length_t>(k - 1)] = glm::dot(gq, dq);
        }
        gradient[c0 + a] += weight * g;
        if (value) value[c0 + a] += weight * tg[a].value;
      }
    }
  }
}

double CloudShell::feature_size_m() const { return p_.fractals[1].length_scale_m / tex_->fine.size(); }

CloudScene build_scene(const weather::WeatherGrid& weather, const weather::WeatherMasks& masks,
                       const CloudModelParams& params, const std::vector<CloudType>& types, std::uint64_t seed,
                       std::shared_ptr<const FractalTextures> textures) {
  // At least one type, each once (a scene of no shell has nothing to render; a type twice would
  // be the same clouds composited over themselves).
  if (types.empty()) throw ValueError("no cloud type: a scene needs at least one", {.key = "types"});
  for (std::size_t i = 0; i < types.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (types[i] == types[j])
        throw ValueError(fmt::format("'{}' is listed twice", weather::name(types[i])), {.key = "types"});
  CloudScene scene;
  using clock = std::chrono::steady_clock;
  auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  auto t0 = clock::now();
  if (textures) {
    for (int i = 0; i < 3; ++i)
      if ((*textures)[i].size() != params.texture_size)
        throw ValueError(fmt::format("build_scene: the given fractal textures are {}^3, the parameters ask for {}^3",
                                     (*textures)[i].size(), params.texture_size),
                         {.key = "textures.size"});
    scene.textures = std::move(textures);
  } else {
    spdlog::info("baking fractal textures {}^3 (seed {})", params.texture_size, seed);
    scene.textures = std::make_shared<const FractalTextures>(FractalTextures::bake(params, seed));
  }
  const double bake_s = seconds_since(t0);
  t0 = clock::now();
  std::vector<CubeMap<float>> cubes = mask_cubes(masks, types, params.mask_cube_size);
  std::vector<CubeMap<float>> lifts = cloud_top_lifts(weather, params, types, params.mask_cube_size);
  double shells_s = seconds_since(t0);  // mask cubes, then the shells' skip maps
  // Wind fields (one per sampling altitude) and every displacement map they drive, the maps of
  // one wind built together (DisplacementMap::build_all shares the integration of durations).
  t0 = clock::now();
  weather::warn_if_winds_missing(weather, "the wind displacement maps");
  std::map<double, int> wind_index;
  std::vector<std::vector<double>> hours_of_wind;
  for (CloudType t : types) {
    const CloudTypeParams& p = params[t];
    auto [it, inserted] = wind_index.try_emplace(p.wind_altitude_m, static_cast<int>(scene.winds.size()));
    if (inserted) {
      spdlog::info("wind field at {:g} m", p.wind_altitude_m);
      scene.winds.push_back(make_wind_field(weather, p.wind_altitude_m, params.displacement_cube_size));
      hours_of_wind.emplace_back();
    }
    auto& hours = hours_of_wind[static_cast<std::size_t>(it->second)];
    for (double h : {p.mask_displace_hours, p.fractals[0].displace_hours, p.fractals[1].displace_hours,
                     p.fractals[2].displace_hours})
      if (std::find(hours.begin(), hours.end(), h) == hours.end()) hours.push_back(h);
  }
  std::map<std::pair<int, double>, DisplacementMap> map_cache;
  for (std::size_t w = 0; w < scene.winds.size(); ++w) {
    auto maps = DisplacementMap::build_all(scene.winds[w], hours_of_wind[w], params.displacement_cube_size,
                                           params.displacement_step_s);
    for (auto& m : maps) map_cache.emplace(std::pair{static_cast<int>(w), m.hours()}, std::move(m));
  }
  const double winds_s = seconds_since(t0);
  for (CloudType t : types) {
    const CloudTypeParams& p = params[t];
    const int w = wind_index.at(p.wind_altitude_m);
    auto map_for = [&](double hours) { return map_cache.at(std::pair{w, hours}); };
    std::vector<DisplacementMap> maps{map_for(p.mask_displace_hours)};
    for (const auto& f : p.fractals) maps.push_back(map_for(f.displace_hours));
    t0 = clock::now();
    const std::size_t k = scene.shells.size();
    auto cube = std::make_shared<const CubeMap<float>>(std::move(cubes[k]));
    scene.shells.emplace_back(
        t, p, scene.textures, std::move(cube), std::move(maps),
        params.follow_weather_tops ? std::make_shared<const CubeMap<float>>(std::move(lifts[k])) : nullptr);
    scene.condensate_layer_m.push_back(masks.condensate_layer_m[static_cast<std::size_t>(t)]);
    scene.wind_of_shell.push_back(w);
    shells_s += seconds_since(t0);
  }
  spdlog::info(
      "scene ready: textures {:.2f} s, wind fields and displacement maps {:.2f} s, mask cubes and skip "
      "maps {:.2f} s",
      bake_s, winds_s, shells_s);
  return scene;
}

void advance_scene(CloudScene& scene, double hours, const CloudModelParams& params) {
  for (std::size_t s = 0; s < scene.shells.size(); ++s) {
    const WindField& wind = scene.winds[static_cast<std::size_t>(scene.wind_of_shell[s])];
    std::vector<DisplacementMap> maps;
    for (std::size_t i = 0; i < scene.shells[s].maps().size(); ++i) {
      const DisplacementMap& m = scene.shells[s].maps()[i];
      // Reuse the map just advanced when two terms share the same displacement.
      if (i > 0 && m.hours() == scene.shells[s].maps()[i - 1].hours()) {
        maps.push_back(maps.back());
        continue;
      }
      maps.push_back(m.advanced(wind, hours, params.displacement_step_s, params.displacement_cube_size));
    }
    scene.shells[s].set_maps(std::move(maps));
  }
}

ModelConfig read_model_config(const std::filesystem::path& path) {
  ModelConfig c;
  if (path.empty()) return c;
  const ParamDict dict = ParamDict::from_file(path);
  c.cloud = CloudModelParams::from(dict);
  c.masks = weather::MaskParams::from(dict);
  dict.check_unused();
  return c;
}

}  // namespace nephos::clouds
