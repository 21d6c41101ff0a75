#include "nephos/particles/particle_system.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"
#include "nephos/optics/optics.hpp"

namespace nephos::particles {

namespace {
// Hash streams: distinct constants keep the draws of different purposes independent.
constexpr std::uint64_t stream_index = 0x1d3c'0001, stream_tau = 0x1d3c'0002, stream_cell = 0x1d3c'0003,
                        stream_lod = 0x1d3c'0004;
// A draw is accepted with probability >= 1/columns * min(1, K); beyond this many attempts the
// input must be degenerate (or the hash broken): fail loudly rather than hang.
constexpr std::uint64_t max_attempts = 100'000'000;
constexpr double inf = std::numeric_limits<double>::infinity();
}  // namespace

void Particles::resize(std::size_t n) {
  for (auto* v : {&x, &y, &z, &radius_m, &opacity}) v->resize(n);
  column.resize(n);
}

double selection_probability(const CloudColumns& columns, std::size_t c, double k) {
  const double lmax = columns.max_tau();
  return lmax > 0 ? std::clamp(columns.tau[c] * k / lmax, 0.0, 1.0) : 0.0;
}

Particles generate(const PlanarGrid& grid, const CloudColumns& columns, const GenerationParams& p) {
  if (!(p.k > 0)) throw ValueError(fmt::format("eq. 5's K must be > 0, got {:g}", p.k), {.key = "k"});
  if (columns.tau.size() != grid.size()) throw ValueError("columns do not match the grid");
  const double lmax = columns.max_tau();
  if (!(lmax > 0)) throw ValueError("no cloudy column (optical thickness > 0) in the region", {.key = "region"});
  double volume_m3 = 0;
  for (std::size_t c = 0; c < grid.size(); ++c)
    if (columns.tau[c] > 0)
      volume_m3 += static_cast<double>(columns.top_m[c] - columns.base_m[c]) * grid.dx_m * grid.dy_m;
  const double radius = p.radius_scale * std::cbrt(volume_m3 / static_cast<double>(std::max<std::size_t>(p.count, 1)));
  const std::uint64_t n_cols = grid.size();
  const double k_over_lmax = p.k / lmax;

  Particles out;
  out.resize(p.count);
  bool degenerate = false;
  const auto count = static_cast<std::int64_t>(p.count);
#pragma omp parallel for schedule(static)
  for (std::int64_t ii = 0; ii < count; ++ii) {
    const auto i = static_cast<std::uint64_t>(ii);
    std::uint64_t r = 0;
    std::uint64_t a = 0;
    for (; a < max_attempts; ++a) {
      r = hash(p.seed, i, a, stream_index) % n_cols;                                        // eq. 3-4's random index R
      const double m = columns.tau[r] * k_over_lmax - uniform01(p.seed, i, a, stream_tau);  // eq. 5
      if (m > 0) break;
    }
    if (a == max_attempts) degenerate = true;
    const auto col = static_cast<int>(r % static_cast<std::uint64_t>(grid.cols));  // eq. 3
    const auto row = static_cast<int>(r / static_cast<std::uint64_t>(grid.cols));  // eq. 4
    const double u = uniform01(p.seed, i, 0, stream_cell), v = uniform01(p.seed, i, 1, stream_cell),
                 w = uniform01(p.seed, i, 2, stream_cell);
    const std::size_t c = r;
    const double base = columns.base_m[c], top = columns.top_m[c];
    out.x[i] = static_cast<float>(grid.x(col + u - 0.5));
    out.y[i] = static_cast<float>(grid.y(row + v - 0.5));
    out.z[i] = static_cast<float>(base + w * (top - base));
    out.radius_m[i] = static_cast<float>(radius);
    out.opacity[i] = static_cast<float>(std::clamp(1.0 - std::exp(-columns.sigma_per_m(c) * 2 * radius), 0.02, 0.95));
    out.column[i] = static_cast<std::uint32_t>(c);
  }
  if (degenerate) throw NumericError("particle selection did not converge (eq. 5 rejected every draw)");
  return out;
}

// ---- Motion ---------------------------------------------------------------------------------

Motion::Motion(const ParticleWeather& weather, const Particles& initial) : w_(weather) {
  weather.validate();
  sx_ = initial.x, sy_ = initial.y, sz_ = initial.z;
  x0_ = initial.x, y0_ = initial.y, z0_ = initial.z;
  start_interval(0);
}

void Motion::start_interval(std::size_t n) {
  interval_ = n;
  t_start_ = w_.frames[n].time_s;
  const std::size_t np = sx_.size();
  for (auto* v : {&vx_, &vy_, &vz_, &ax_, &ay_, &az_}) v->resize(np);
  const bool last = n + 1 >= w_.frames.size();
  const double dt = last ? 1.0 : w_.frames[n + 1].time_s - t_start_;
  const auto count = static_cast<std::int64_t>(np);
#pragma omp parallel for schedule(static)
  for (std::int64_t ii = 0; ii < count; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    const glm::dvec3 v0 = w_.frames[n].wind.sample(w_.grid, sx_[i], sy_[i], sz_[i]);
    const glm::dvec3 a =
        last ? glm::dvec3(0.0) : (w_.frames[n + 1].wind.sample(w_.grid, sx_[i], sy_[i], sz_[i]) - v0) / dt;
    vx_[i] = static_cast<float>(v0.x), vy_[i] = static_cast<float>(v0.y), vz_[i] = static_cast<float>(v0.z);
    ax_[i] = static_cast<float>(a.x), ay_[i] = static_cast<float>(a.y), az_[i] = static_cast<float>(a.z);
  }
}

void Motion::positions_at(double t_s, Particles& p) {
  if (!(t_s >= 0)) throw ValueError("time must be >= 0 s, got " + std::to_string(t_s));
  if (p.size() != sx_.size()) throw ValueError("particle count differs from the motion's");
  const auto count = static_cast<std::int64_t>(sx_.size());
  if (t_s < t_start_) {  // earlier than the current interval: restart from the initial positions
    sx_ = x0_, sy_ = y0_, sz_ = z0_;
    start_interval(0);
  }
  // Eq. (6): S = S0 + V0 T + a T^2 / 2, evaluated in double, interval by interval.
  auto step = [&](double dt, std::vector<float>& ox, std::vector<float>& oy, std::vector<float>& oz) {
#pragma omp parallel for schedule(static)
    for (std::int64_t ii = 0; ii < count; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      ox[i] = static_cast<float>(sx_[i] + (static_cast<double>(vx_[i]) + 0.5 * ax_[i] * dt) * dt);
      oy[i] = static_cast<float>(sy_[i] + (static_cast<double>(vy_[i]) + 0.5 * ay_[i] * dt) * dt);
      oz[i] = static_cast<float>(sz_[i] + (static_cast<double>(vz_[i]) + 0.5 * az_[i] * dt) * dt);
    }
  };
  while (interval_ + 1 < w_.frames.size() && t_s >= w_.frames[interval_ + 1].time_s) {
    step(w_.frames[interval_ + 1].time_s - t_start_, sx_, sy_, sz_);
    start_interval(interval_ + 1);
  }
  step(t_s - t_start_, p.x, p.y, p.z);
}

// ---- Level of detail ------------------------------------------------------------------------

int lod_band(double distance_m, const LodParams& lod) {
  if (distance_m <= lod.l0_m) return 0;
  return std::max(1, static_cast<int>(std::ceil(std::log(distance_m / lod.l0_m) / std::log(lod.band_ratio) - 1e-12)));
}

double lod_band_distance(int m, const LodParams& lod) { return lod.l0_m * std::pow(lod.band_ratio, m - 0.5); }

LodSelection select_lod(const Particles& p, const glm::dvec3& camera, const LodParams& lod, std::uint64_t seed) {
  if (!(lod.l0_m > 0) || !(lod.band_ratio > 1))
    throw ValueError("LOD needs L0 > 0 and a band ratio > 1", {.key = "lod_l0_km"});
  const std::size_t n = p.size();
  std::vector<int> band(n);
  std::vector<std::uint64_t> key(n);
  const auto count = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t ii = 0; ii < count; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    const glm::dvec3 d{p.x[i] - camera.x, p.y[i] - camera.y, p.z[i] - camera.z};
    band[i] = lod_band(glm::length(d), lod);
    key[i] = hash(seed, i, stream_lod);
  }
  const int bands = n ? *std::max_element(band.begin(), band.end()) + 1 : 0;
  LodSelection s;
  s.band_counts.assign(static_cast<std::size_t>(bands), 0);
  for (int b : band) ++s.band_counts[static_cast<std::size_t>(b)];
  // Bucket the particles by band (counting sort keeps index order within a band).
  std::vector<std::size_t> start(static_cast<std::size_t>(bands) + 1, 0);
  for (int b = 0; b < bands; ++b)
    start[static_cast<std::size_t>(b) + 1] =
        start[static_cast<std::size_t>(b)] + s.band_counts[static_cast<std::size_t>(b)];
  // (survival key, particle) pairs bucketed by band; the key is a hash of the particle alone.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> bucket(n);
  {
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      bucket[fill[static_cast<std::size_t>(band[i])]++] = {key[i], static_cast<std::uint32_t>(i)};
  }
  s.band_kept.assign(static_cast<std::size_t>(bands), 0);
  for (int b = 0; b < bands; ++b) {
    const std::size_t nb = s.band_counts[static_cast<std::size_t>(b)];
    if (nb == 0) continue;
    const double keep = b == 0 ? 1.0 : std::pow(lod.l0_m / lod_band_distance(b, lod), 3);  // eq. 13
    const std::size_t nk =
        std::min(nb, std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(static_cast<double>(nb) * keep))));
    s.band_kept[static_cast<std::size_t>(b)] = nk;
    auto first = bucket.begin() + static_cast<std::ptrdiff_t>(start[static_cast<std::size_t>(b)]);
    if (nk < nb)
      std::nth_element(first, first + static_cast<std::ptrdiff_t>(nk), first + static_cast<std::ptrdiff_t>(nb));
    const float factor = static_cast<float>(std::cbrt(static_cast<double>(nb) / static_cast<double>(nk)));
    for (auto it = first; it != first + static_cast<std::ptrdiff_t>(nk); ++it) {
      s.kept.push_back(it->second);
      s.size_factor.push_back(factor);
    }
  }
  return s;
}

// ---- Illumination ---------------------------------------------------------------------------

double inverse_square_line_integral(const glm::dvec3& r_c, const glm::dvec3& r_d, const glm::dvec3& s, double d,
                                    double intensity) {
  const glm::dvec3 rel = r_c - s;
  const double b = glm::dot(r_d, rel), c = glm::dot(rel, rel);
  const double v2 = c - b * b;
  if (v2 <= 1e-12 * c) {
    // Collinear: |x(t) - s|^2 = (t + b)^2; finite only if the segment does not reach the source.
    if ((b < 0) == (b + d < 0) && b != 0 && b + d != 0) return intensity * (1 / b - 1 / (b + d));
    return inf;
  }
  const double v = std::sqrt(v2);
  return intensity / v * (std::atan((b + d) / v) - std::atan(b / v));
}

namespace {
struct HeightRange {
  double lowest_base = inf, highest_top = 0;
};
HeightRange height_range(const CloudColumns& c) {
  HeightRange h;
  h.highest_top = c.max_top_m();
  for (float b : c.base_m)
    if (!std::isnan(b)) h.lowest_base = std::min(h.lowest_base, static_cast<double>(b));
  return h;
}
double optical_depth(const PlanarGrid& g, const CloudColumns& c, const HeightRange& range, const glm::dvec3& from,
                     const glm::dvec3& dir, double max_distance_m) {
  // Grid box edges and the ray's extent inside it (2D slab test).
  const double xmin = g.x0_m - 0.5 * g.dx_m, ymin = g.y0_m - 0.5 * g.dy_m;
  const double xmax = xmin + g.cols * g.dx_m, ymax = ymin + g.rows * g.dy_m;
  double t0 = 0, t1 = max_distance_m;
  for (int axis = 0; axis < 2; ++axis) {
    const double o = axis ? from.y : from.x, d = axis ? dir.y : dir.x;
    const double lo = axis ? ymin : xmin, hi = axis ? ymax : xmax;
    if (std::abs(d) < 1e-300) {
      if (o < lo || o > hi) return 0;
      continue;
    }
    double ta = (lo - o) / d, tb = (hi - o) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
  }
  if (dir.z > 0) t1 = std::min(t1, (range.highest_top - from.z) / dir.z);
  if (dir.z < 0) t1 = std::min(t1, (range.lowest_base - from.z) / dir.z);
  if (!(t1 > t0)) return 0;

  // Amanatides-Woo walk through the cells from t0 to t1.
  const glm::dvec3 p = from + t0 * dir;
  int i = std::clamp(static_cast<int>(std::floor((p.x - xmin) / g.dx_m)), 0, g.cols - 1);
  int j = std::clamp(static_cast<int>(std::floor((p.y - ymin) / g.dy_m)), 0, g.rows - 1);
  const int step_i = dir.x > 0 ? 1 : -1, step_j = dir.y > 0 ? 1 : -1;
  const double delta_x = dir.x != 0 ? g.dx_m / std::abs(dir.x) : inf;
  const double delta_y = dir.y != 0 ? g.dy_m / std::abs(dir.y) : inf;
  double next_x = dir.x != 0 ? t0 + ((xmin + (i + (step_i > 0)) * g.dx_m) - p.x) / dir.x : inf;
  double next_y = dir.y != 0 ? t0 + ((ymin + (j + (step_j > 0)) * g.dy_m) - p.y) / dir.y : inf;
  double tau = 0, t = t0;
  while (t < t1) {
    const double t_exit = std::min({next_x, next_y, t1});
    const std::size_t cell = static_cast<std::size_t>(j) * g.cols + static_cast<std::size_t>(i);
    const double sigma = c.sigma_per_m(cell);
    if (sigma > 0) {
      // Overlap of [t, t_exit] with the part of the ray between the column's base and top.
      double lo = t, hi = t_exit;
      const double zb = c.base_m[cell], zt = c.top_m[cell];
      if (dir.z != 0) {
        double ta = (zb - from.z) / dir.z, tb = (zt - from.z) / dir.z;
        if (ta > tb) std::swap(ta, tb);
        lo = std::max(lo, ta), hi = std::min(hi, tb);
      } else if (from.z < zb || from.z > zt) {
        hi = lo;
      }
      if (hi > lo) tau += sigma * (hi - lo);
    }
    if (t_exit >= t1) break;
    if (next_x <= next_y) {
      i += step_i;
      next_x += delta_x;
    } else {
      j += step_j;
      next_y += delta_y;
    }
    if (i < 0 || j < 0 || i >= g.cols || j >= g.rows) break;
    t = t_exit;
  }
  return tau;
}
}  // namespace

double optical_depth_towards(const PlanarGrid& g, const CloudColumns& c, const glm::dvec3& from, const glm::dvec3& dir,
                             double max_distance_m) {
  return optical_depth(g, c, height_range(c), from, dir, max_distance_m);
}

std::vector<float> illuminate(const PlanarGrid& g, const CloudColumns& c, const Particles& p, const Light& light,
                              const IlluminationParams& params) {
  const std::size_t n = p.size();
  std::vector<double> e(n);
  const auto count = static_cast<std::int64_t>(n);
  const bool night = light.directional && light.direction.z <= 0;
  const HeightRange range = height_range(c);
#pragma omp parallel for schedule(dynamic, 1024)
  for (std::int64_t ii = 0; ii < count; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    const glm::dvec3 pos{p.x[i], p.y[i], p.z[i]};
    glm::dvec3 dir = light.direction;
    double irradiance = light.intensity, reach = inf;
    if (!light.directional) {
      const glm::dvec3 to = light.position - pos;
      reach = glm::length(to);
      dir = to / reach;
      // Eq. (14) averaged over the particle's diameter along the light direction with eq. (17).
      const double d = std::min(2.0 * p.radius_m[i], 0.5 * reach);
      irradiance = d > 0
                       ? inverse_square_line_integral(pos - 0.5 * d * dir, dir, light.position, d, light.intensity) / d
                       : light.intensity / (reach * reach);
    }
    if (night) {
      e[i] = 0;
      continue;
    }
    const double tau = optical_depth(g, c, range, pos, dir, reach);
    const double transmission = params.transmission == Transmission::beer
                                    ? optics::beer_transmittance(tau)
                                    : optics::two_stream_slab((1 - params.asymmetry) * tau, 1.0).transmittance;
    e[i] = irradiance * transmission;
  }
  // Reference: the unshadowed light at the particle nearest the light (the sun's irradiance).
  double e_ref = light.intensity;
  if (!light.directional) {
    double nearest = inf;
    for (std::size_t i = 0; i < n; ++i)
      nearest = std::min(nearest, glm::length(light.position - glm::dvec3{p.x[i], p.y[i], p.z[i]}));
    e_ref = light.intensity / (nearest * nearest);
  }
  std::vector<float> grey(n);
  for (std::size_t i = 0; i < n; ++i)
    grey[i] = static_cast<float>(params.ambient + (1 - params.ambient) * std::clamp(e[i] / e_ref, 0.0, 1.0));
  return grey;
}

}  // namespace nephos::particles
