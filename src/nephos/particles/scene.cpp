#include "nephos/particles/scene.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "nephos/core/error.hpp"
#include "nephos/realtime/frame_logic.hpp"

namespace nephos::particles {

namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
// Grey values are relative radiances; the frame is an sRGB image, so encode them with the sRGB
// transfer curve (IEC 61966-2-1) as a display would expect.
float srgb_encode(float linear) {
  const float c = std::clamp(linear, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1 / 2.4f) - 0.055f;
}
Particles subset(const Particles& p, const std::vector<std::uint32_t>& idx) {
  Particles s;
  s.resize(idx.size());
  const auto count = static_cast<std::int64_t>(idx.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t kk = 0; kk < count; ++kk) {
    const auto k = static_cast<std::size_t>(kk);
    const std::uint32_t i = idx[k];
    s.x[k] = p.x[i], s.y[k] = p.y[i], s.z[k] = p.z[i];
    s.radius_m[k] = p.radius_m[i], s.opacity[k] = p.opacity[i], s.column[k] = p.column[i];
  }
  return s;
}
}  // namespace

std::vector<std::uint32_t> order_descending(const std::vector<float>& keys) {
  const std::size_t n = keys.size();
  std::vector<std::uint32_t> idx(n), tmp(n), k(n), ktmp(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t bits;
    std::memcpy(&bits, &keys[i], 4);
    k[i] = ~bits;  // non-negative floats order like their bits; invert for descending
    idx[i] = static_cast<std::uint32_t>(i);
  }
  for (int shift = 0; shift < 32; shift += 8) {
    std::size_t count[257] = {};
    for (std::size_t i = 0; i < n; ++i) ++count[((k[i] >> shift) & 0xff) + 1];
    for (int b = 0; b < 256; ++b) count[b + 1] += count[b];
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t dst = count[(k[i] >> shift) & 0xff]++;
      tmp[dst] = idx[i];
      ktmp[dst] = k[i];
    }
    idx.swap(tmp);
    k.swap(ktmp);
  }
  return idx;
}

ParticleScene::ParticleScene(ParticleWeather weather, SceneParams params)
    : weather_((weather.validate(), std::move(weather))),
      params_(params),
      initial_(generate(weather_.grid, weather_.frames.front().columns, params.generation)),
      current_(initial_),
      motion_(weather_, initial_) {}

UtcTime ParticleScene::time_at(double t_s) const { return weather_.frames.front().valid_time.plus_seconds(t_s); }

Light ParticleScene::light_at(double t_s) const {
  if (params_.light) return *params_.light;
  const realtime::SunLight sun =
      realtime::sun_light(time_at(t_s), weather_.grid.centre_lat_deg, weather_.grid.centre_lon_deg);
  Light l;
  l.directional = true;
  l.direction = sun.direction;
  l.intensity = 1;
  return l;
}

const WeatherFrame& ParticleScene::frame_at(double t_s) const {
  std::size_t f = 0;
  while (f + 1 < weather_.frames.size() && weather_.frames[f + 1].time_s <= t_s) ++f;
  return weather_.frames[f];
}

void ParticleScene::move_to(double t_s) { motion_.positions_at(t_s, current_); }

std::vector<float> ParticleScene::shade_all(double t_s) const {
  return illuminate(weather_.grid, frame_at(t_s).columns, current_, light_at(t_s), params_.illumination);
}

realtime::PointSprites ParticleScene::sprites(double t_s, const glm::dvec3& camera, FrameTimings* timings) const {
  FrameTimings tm;
  auto t0 = std::chrono::steady_clock::now();
  LodSelection sel;
  if (params_.lod) {
    LodParams lod = params_.lod_params;
    if (lod.l0_m <= 0) lod.l0_m = default_l0_m(camera);
    sel = select_lod(current_, camera, lod, params_.generation.seed);
  } else {
    sel.kept.resize(current_.size());
    for (std::size_t i = 0; i < current_.size(); ++i) sel.kept[i] = static_cast<std::uint32_t>(i);
    sel.size_factor.assign(current_.size(), 1.0f);
  }
  const Particles shown = subset(current_, sel.kept);
  tm.lod_ms = ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  const std::vector<float> grey =
      illuminate(weather_.grid, frame_at(t_s).columns, shown, light_at(t_s), params_.illumination);
  tm.light_ms = ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  std::vector<float> d2(shown.size());
  const auto count = static_cast<std::int64_t>(shown.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t ii = 0; ii < count; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    const double dx = shown.x[i] - camera.x, dy = shown.y[i] - camera.y, dz = shown.z[i] - camera.z;
    d2[i] = static_cast<float>(dx * dx + dy * dy + dz * dz);
  }
  const std::vector<std::uint32_t> order = order_descending(d2);
  realtime::PointSprites s;
  const std::size_t n = shown.size();
  for (auto* v : {&s.x, &s.y, &s.z, &s.size_m, &s.grey, &s.alpha}) v->resize(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t kk = 0; kk < count; ++kk) {
    const auto k = static_cast<std::size_t>(kk);
    const std::uint32_t i = order[k];
    s.x[k] = shown.x[i], s.y[k] = shown.y[i], s.z[k] = shown.z[i];
    s.size_m[k] = 2 * shown.radius_m[i] * sel.size_factor[i];
    s.grey[k] = srgb_encode(grey[i]);
    // A sprite enlarged by f stands for f^3 particles: keep its opacity that of the column of
    // particles it replaces along the view, 1 - (1 - alpha)^f.
    const float f = sel.size_factor[i];
    s.alpha[k] =
        f == 1.0f ? shown.opacity[i] : static_cast<float>(1 - std::pow(1 - static_cast<double>(shown.opacity[i]), f));
  }
  tm.sort_ms = ms_since(t0);
  tm.drawn = n;
  if (timings) *timings = tm;
  return s;
}

double ParticleScene::default_l0_m(const glm::dvec3& camera) const {
  const PlanarGrid& g = weather_.grid;
  const glm::dvec3 centre{g.x0_m + 0.5 * (g.cols - 1) * g.dx_m, g.y0_m + 0.5 * (g.rows - 1) * g.dy_m, 3000.0};
  return 0.6 * glm::length(camera - centre);
}

realtime::Camera ParticleScene::default_camera() const {
  const PlanarGrid& g = weather_.grid;
  const double w = g.cols * g.dx_m, h = g.rows * g.dy_m, extent = std::max(w, h);
  realtime::Camera cam;
  cam.position = {0.0, g.y0_m - 0.5 * g.dy_m - 0.3 * h, 0.22 * extent};
  const glm::dvec3 target{0.0, g.y0_m + 0.4 * h, 2000.0};
  cam.forward = glm::normalize(target - cam.position);
  cam.up = {0, 0, 1};
  cam.fov_deg = 60;
  cam.far_m = 4 * extent + 1e5;
  return cam;
}

}  // namespace nephos::particles
