#include "nephos/clouds/displacement.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "nephos/weather/sampler.hpp"

namespace nephos::clouds {

earth::Vec3 WindField::at(const earth::Vec3& p) const {
  const earth::Vec3 v(velocity_m_s.sample(p));
  return v - glm::dot(v, p) * p;  // keep it tangent (interpolation leaves a tiny radial part)
}

namespace {
// The bilinear blends of a vec3 cube map's texels (t: its components, flat; row: floats per
// texel row) at the locations (idx[i], tx[i], ty[i]), i < m. The loads are scalar on purpose
// (see CubeMap::locate_many): left to itself GCC 12 vectorises this loop with gathers, and
// the lookup took ~3-6 % more of a GEO frame (the displacement maps, ~1 MiB, are read
// coherently along image rows). noinline keeps the attribute in force.
[[gnu::noinline, gnu::optimize("no-tree-vectorize")]] void blend_vec3(const float* t, std::size_t row,
                                                                      const std::uint32_t* idx, const float* tx,
                                                                      const float* ty, std::size_t m, float* bx,
                                                                      float* by, float* bz) {
  using Cube = CubeMap<float>;
  for (std::size_t i = 0; i < m; ++i) {
    const Cube::Location l{idx[i], tx[i], ty[i]};
    const std::size_t k = 3 * static_cast<std::size_t>(l.index);
    bx[i] = Cube::blend_at(l, t, k, 3, row), by[i] = Cube::blend_at(l, t, k + 1, 3, row);
    bz[i] = Cube::blend_at(l, t, k + 2, 3, row);
  }
}
}  // namespace

void DisplacementMap::upwind(const double* x, const double* y, const double* z, std::size_t n, double* ux, double* uy,
                             double* uz) const {
  if (is_identity()) {
    std::copy(x, x + n, ux), std::copy(y, y + n, uy), std::copy(z, z + n, uz);
    return;
  }
  using Cube = CubeMap<float>;
  static_assert(sizeof(glm::vec3) == 3 * sizeof(float));
  const float* t = &upwind_.data()[0].x;  // the texels' components, flat
  const int size = upwind_.size();
  const std::size_t row = 3 * static_cast<std::size_t>(size);
  constexpr std::size_t block = 128;  // directions per pass (scratch on the stack: 3.5 KiB)
  alignas(64) std::uint32_t idx[block];
  alignas(64) float tx[block], ty[block], bx[block], by[block], bz[block];
  for (std::size_t b0 = 0; b0 < n; b0 += block) {
    const std::size_t m = std::min(block, n - b0);
    Cube::locate_many(size, x + b0, y + b0, z + b0, m, idx, tx, ty);
    blend_vec3(t, row, idx, tx, ty, m, bx, by, bz);
#pragma omp simd
    for (std::size_t i = 0; i < m; ++i) {
      const double vx = bx[i], vy = by[i], vz = bz[i];
      const double inv_len = 1.0 / std::sqrt(vx * vx + vy * vy + vz * vz);
      ux[b0 + i] = vx * inv_len, uy[b0 + i] = vy * inv_len, uz[b0 + i] = vz * inv_len;
    }
  }
}

WindField make_wind_field(const weather::WeatherGrid& weather, double altitude_m, int n) {
  WindField w;
  w.altitude_m = altitude_m;
  w.velocity_m_s = CubeMap<glm::vec3>(n);
  const weather::WeatherSampler sampler(weather);
  w.velocity_m_s.fill([&](const earth::Vec3& d) {
    const earth::Geodetic g = earth::geodetic(d * earth::radius_m);
    const weather::WeatherSample s = sampler.sample(g.lat_deg, g.lon_deg, altitude_m);
    const double u = std::isnan(s.u_m_s) ? 0.0 : s.u_m_s, v = std::isnan(s.v_m_s) ? 0.0 : s.v_m_s;
    return glm::vec3(u * earth::local_east(d) + v * earth::local_north(d));
  });
  return w;
}

namespace {
// The steps of trace_upwind() for a duration (negative: forwards in time, as long), and their
// length h (backwards in time, per unit radius).
struct Steps {
  int count;
  double h;
};
Steps steps_for(const WindField& wind, double seconds, double step_s) {
  const double r = earth::radius_m + wind.altitude_m;
  const int steps = std::max(1, static_cast<int>(std::ceil(std::abs(seconds) / step_s)));
  return {steps, -seconds / steps / r};
}
// One RK4 step on the unit sphere.
earth::Vec3 rk4_step(const WindField& wind, const earth::Vec3& p, double h) {
  auto f = [&](const earth::Vec3& q) { return wind.at(q); };
  const earth::Vec3 k1 = f(p);
  const earth::Vec3 k2 = f(glm::normalize(p + 0.5 * h * k1));
  const earth::Vec3 k3 = f(glm::normalize(p + 0.5 * h * k2));
  const earth::Vec3 k4 = f(glm::normalize(p + h * k3));
  return glm::normalize(p + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4));
}
}  // namespace

earth::Vec3 trace_upwind(const WindField& wind, earth::Vec3 p, double seconds, double step_s) {
  const Steps st = steps_for(wind, seconds, step_s);
  for (int s = 0; s < st.count; ++s) p = rk4_step(wind, p, st.h);
  return p;
}

DisplacementMap DisplacementMap::build(const WindField& wind, double hours, int n, double step_s) {
  return build_all(wind, {hours}, n, step_s).front();
}

std::vector<DisplacementMap> DisplacementMap::build_all(const WindField& wind, const std::vector<double>& hours, int n,
                                                        double step_s) {
  // Durations whose steps have the same length (6, 8, 10, 12 h in 30-minute steps) share
  // one integration: each texel is traced to the longest, and the shorter ones are the points
  // it passes on the way, after exactly the steps trace_upwind() would take, so the same bits.
  std::vector<DisplacementMap> maps(hours.size());
  std::vector<std::size_t> group;  // the maps traced together
  std::vector<int> counts;         // their step counts
  double h = 0;
  for (std::size_t k = 0; k < hours.size(); ++k) {
    maps[k].hours_ = hours[k];
    if (hours[k] == 0) continue;  // the identity
    const Steps st = steps_for(wind, hours[k] * 3600.0, step_s);
    if (group.empty() || st.h == h) {
      h = st.h;
      group.push_back(k);
      counts.push_back(st.count);
      maps[k].upwind_ = CubeMap<glm::vec3>(n);
    } else {  // a different step length: traced on its own
      maps[k] = build_all(wind, {hours[k]}, n, step_s).front();
    }
  }
  if (group.empty()) return maps;
  const int last = *std::max_element(counts.begin(), counts.end());
#pragma omp parallel for collapse(2) schedule(static)
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        earth::Vec3 p = maps[group.front()].upwind_.texel_direction(f, i, j);
        for (int s = 1; s <= last; ++s) {
          p = rk4_step(wind, p, h);
          for (std::size_t g = 0; g < group.size(); ++g)
            if (counts[g] == s) maps[group[g]].upwind_.texel(f, i, j) = glm::vec3(p);
        }
      }
  return maps;
}

DisplacementMap DisplacementMap::advanced(const WindField& wind, double hours, double step_s, int n) const {
  if (is_identity()) return build(wind, hours_ + hours, n, step_s);
  DisplacementMap m;
  m.hours_ = hours_ + hours;
  m.upwind_ = CubeMap<glm::vec3>(upwind_.size());
  m.upwind_.fill(
      [&](const earth::Vec3& d) { return glm::vec3(upwind(trace_upwind(wind, d, hours * 3600.0, step_s))); });
  return m;
}

}  // namespace nephos::clouds
