#include "nephos/render/renderer.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "nephos/core/error.hpp"
#include "nephos/core/progress.hpp"

namespace nephos::render {
namespace {
constexpr float nanf = std::numeric_limits<float>::quiet_NaN();

// The part of a ray inside a shell: up to two intervals (in front of and behind the inner
// sphere when a ray grazes below the shell bottom without reaching the ground).
struct Path {
  double a0 = 0, a1 = 0, b0 = 0, b1 = 0;  // [a0, a1] then [b0, b1] (b empty if b1 <= b0)
  double length() const { return (a1 - a0) + std::max(0.0, b1 - b0); }
  double t_at(double s) const { return s <= a1 - a0 ? a0 + s : b0 + (s - (a1 - a0)); }
};

bool shell_path(double r_bottom, double r_top, const earth::Vec3& o, const earth::Vec3& d, double t_max, Path& p) {
  const auto outer = earth::ray_sphere(o, d, r_top);
  if (!outer || outer->t1 <= 0) return false;
  const double t0 = std::max(outer->t0, 0.0), t1 = std::min(outer->t1, t_max);
  if (t1 <= t0) return false;
  p = {t0, t1, 0, 0};
  if (const auto inner = earth::ray_sphere(o, d, r_bottom); inner && inner->t1 > t0) {
    if (inner->t0 > t0) {  // enters the inner sphere ahead: cut there, resume where it leaves
      p.a1 = std::min(inner->t0, t1);
      p.b0 = inner->t1;
      p.b1 = t1;
    } else {  // starts inside the inner sphere (camera below the shell): from its exit
      p.a0 = inner->t1;
      if (p.a0 >= t1) return false;
    }
  }
  return p.length() > 0;
}

// Length of [0, 1] where the linear interpolant of (va, vb) exceeds 0.
double inside_fraction(double va, double vb) {
  if (va > 0 && vb > 0) return 1;
  if (va <= 0 && vb <= 0) return 0;
  const double x = va / (va - vb);  // crossing
  return va > 0 ? x : 1 - x;
}

// Band-mean Planck radiance as a table over temperature for a fast exact-enough inverse.
struct PlanckTable {
  static constexpr double t_lo = 100, t_hi = 400, dt = 0.01;
  std::vector<double> radiance;
  explicit PlanckTable(const optics::Band& b) {
    for (double t = t_lo; t <= t_hi + 1e-9; t += dt) radiance.push_back(optics::band_planck(b, t));
  }
  double forward(double t) const {
    const double x = std::clamp((t - t_lo) / dt, 0.0, static_cast<double>(radiance.size() - 2));
    const auto i = static_cast<std::size_t>(x);
    return radiance[i] + (x - static_cast<double>(i)) * (radiance[i + 1] - radiance[i]);
  }
  double inverse(double l) const {  // linear between 0.01 K nodes: error < 1e-5 K
    if (!(l > radiance.front())) return t_lo;
    if (l >= radiance.back()) return t_hi;
    const auto it = std::upper_bound(radiance.begin(), radiance.end(), l);
    const auto i = static_cast<std::size_t>(it - radiance.begin()) - 1;
    return t_lo + dt * (static_cast<double>(i) + (l - radiance[i]) / (radiance[i + 1] - radiance[i]));
  }
};

struct Layer {  // one cloud type's contribution to one pixel
  float t = std::numeric_limits<float>::infinity();
  float altitude = 0, tau_vis = 0;
  std::array<float, 3> radiance{}, transmittance{1, 1, 1};
};

}  // namespace

ShellHit march_shell(const clouds::CloudShell& shell, const earth::Vec3& o, const earth::Vec3& d, double t_max,
                     int steps, int bisection_iterations) {
  ShellHit hit;
  march_shell(shell, o, &d, &t_max, 1, steps, bisection_iterations, &hit);
  return hit;
}

void march_shell(const clouds::CloudShell& shell, const earth::Vec3& o, const earth::Vec3* d, const double* t_max,
                 std::size_t n, int steps, int bisection_iterations, ShellHit* hits) {
  // Rays advance in lockstep, one batched classify() per step over every ray still in the
  // shell, so the texture misses of different rays overlap (see CloudShell::classify).
  struct Ray {
    std::size_t i;           // index into d / hits
    Path path;               // the ray's part inside the shell
    double ds;               // step length [m]
    double v_prev;           // CF - threshold at the previous sample
    int k_hit = -1;          // step of the first sample inside (0: the path starts inside)
    double lo = 0, hi = 0;   // crossing bracket [path length]
    double depth_after = 0;  // depth accumulated after the crossing step [m]
  };
  std::vector<Ray> rays;
  rays.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    hits[i] = ShellHit{};
    Path path;
    if (!shell_path(shell.radius_bottom_m(), shell.radius_top_m(), o, d[i], t_max[i], path)) continue;
    // Empty-space skipping: look up the mask's neighbourhood maximum along the path, one
    // lookup per skip radius of arc; a ray whose whole path sees no possible cloud costs
    // nothing more.
    const earth::Vec3 a = glm::normalize(o + path.t_at(0) * d[i]);
    const earth::Vec3 b = glm::normalize(o + path.t_at(path.length()) * d[i]);
    // Arc between the path's ends: most paths (steep views) are shorter than one skip radius,
    // which the chord c bounds without trigonometry (arc = 2 asin(c/2) <= c / sqrt(1 - c^2/4)).
    const double radius = shell.skip_radius_rad(), c2 = glm::dot(a - b, a - b);
    const bool short_arc = c2 < 1 && c2 < radius * radius * (1 - 0.25 * c2);
    const double arc = short_arc ? 0.0 : std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
    const int m = 1 + static_cast<int>(arc / radius);
    bool possible = false;
    for (int j = 0; j <= m && !possible; ++j)
      possible = shell.may_have_cloud(o + path.t_at(path.length() * j / m) * d[i]);
    if (possible) rays.push_back({i, path, path.length() / steps, 0});
  }
  if (rays.empty()) return;
  const double thr = shell.threshold();
  std::vector<earth::Vec3> pts(rays.size() * 4);
  std::vector<double> vals(pts.size());
  // The rays' paths and directions as arrays, so that the sample points of a step come from
  // one vectorised loop (Path::t_at, same arithmetic).
  const std::size_t nr = rays.size();
  std::vector<double> a0(nr), la(nr), b0(nr), ds(nr), dx(nr), dy(nr), dz(nr);
  for (std::size_t j = 0; j < nr; ++j) {
    const Ray& r = rays[j];
    a0[j] = r.path.a0, la[j] = r.path.a1 - r.path.a0, b0[j] = r.path.b0, ds[j] = r.ds;
    dx[j] = d[r.i].x, dy[j] = d[r.i].y, dz[j] = d[r.i].z;
  }
  for (int k = 0; k <= steps; ++k) {
#pragma omp simd
    for (std::size_t j = 0; j < nr; ++j) {
      const double s = k * ds[j];
      const double t = s <= la[j] ? a0[j] + s : b0[j] + (s - la[j]);
      pts[j] = earth::Vec3{o.x + t * dx[j], o.y + t * dy[j], o.z + t * dz[j]};
    }
    shell.classify(pts.data(), rays.size(), vals.data());
    for (std::size_t j = 0; j < rays.size(); ++j) {
      Ray& r = rays[j];
      const double v = vals[j] - thr;
      if (r.k_hit < 0 && v > 0) {  // first sample inside: bracket the crossing
        r.k_hit = k;
        r.lo = k > 0 ? (k - 1) * r.ds : 0;
        r.hi = k * r.ds;
      } else if (r.k_hit >= 0) {
        // Depth after the crossing step: linear interpolation between samples (of CF, or of
        // the bounds classify() returns, which keep CF's side: accuracy of order one step).
        r.depth_after += r.ds * inside_fraction(r.v_prev, v);
      }
      r.v_prev = v;
    }
  }
  // Keep the rays that found cloud; refine their first crossing by bisection, all together.
  std::erase_if(rays, [](const Ray& r) { return r.k_hit < 0; });
  for (int it = 0; it < bisection_iterations; ++it) {
    for (std::size_t j = 0; j < rays.size(); ++j)
      pts[j] = o + rays[j].path.t_at(0.5 * (rays[j].lo + rays[j].hi)) * d[rays[j].i];
    shell.classify(pts.data(), rays.size(), vals.data());
    for (std::size_t j = 0; j < rays.size(); ++j) {
      Ray& r = rays[j];
      if (r.k_hit == 0) continue;  // starts inside: the surface is the path's start
      (vals[j] - thr > 0 ? r.hi : r.lo) = 0.5 * (r.lo + r.hi);
    }
  }
  // Surface normals from the CF gradient by forward differences (O(h) error with h ~ two fine
  // voxels, far below what shading needs): four batched exact evaluations per ray.
  const double h = std::max(2.0 * shell.feature_size_m(), 1.0);
  const std::size_t nh = rays.size();
  for (std::size_t j = 0; j < nh; ++j) {
    const Ray& r = rays[j];
    const double s_hit = r.k_hit == 0 ? 0.0 : r.hi;
    const earth::Vec3 p = o + r.path.t_at(s_hit) * d[r.i];
    pts[j] = p;
    pts[nh + j] = p + earth::Vec3{h, 0, 0};
    pts[2 * nh + j] = p + earth::Vec3{0, h, 0};
    pts[3 * nh + j] = p + earth::Vec3{0, 0, h};
  }
  shell.value(pts.data(), 4 * nh, vals.data());
  for (std::size_t j = 0; j < nh; ++j) {
    const Ray& r = rays[j];
    ShellHit& hit = hits[r.i];
    const double s_hit = r.k_hit == 0 ? 0.0 : r.hi;
    hit.hit = true;
    hit.t = r.path.t_at(s_hit);
    hit.position = pts[j];
    // Depth: from the surface to the end of the crossing step, then the steps after it.
    hit.depth_m = (r.k_hit * r.ds - s_hit) + r.depth_after;
    const double v0 = vals[j];
    const earth::Vec3 g{(vals[nh + j] - v0) / h, (vals[2 * nh + j] - v0) / h, (vals[3 * nh + j] - v0) / h};
    const double gl = glm::length(g);
    hit.normal = gl > 0 ? -g / gl : -d[r.i];
  }
}

RenderImage render(const clouds::CloudScene& scene, const Sensor& sensor, const earth::SunPosition& sun,
                   const RenderParams& params, const weather::WeatherGrid* weather) {
  const int w = sensor.width, h = sensor.height;
  const std::size_t npx = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  const std::size_t nb = params.bands.size();
  if (nb > 3) throw ValueError("at most 3 bands per render", {.key = "--bands"});
  std::vector<const optics::Band*> bands;
  std::vector<PlanckTable> planck;
  for (const auto& name : params.bands) {
    bands.push_back(&optics::band(name));
    planck.emplace_back(*bands.back());
  }
  const earth::Vec3 sun_dir = sun.direction_ecef;
  const double sun_scale = 1.0 / (sun.distance_au * sun.distance_au);
  const double f_ind = params.indirect_fraction;

  RenderImage img;
  img.width = w;
  img.height = h;
  img.bands = params.bands;
  img.radiance.assign(nb, std::vector<float>(npx, 0.0f));
  img.brightness_temperature.assign(nb, {});
  img.cloud_top_altitude_m.assign(npx, nanf);
  img.cloud_optical_depth.assign(npx, 0.0f);
  img.cloud_type.assign(npx, -1);
  img.latitude_deg.assign(npx, nanf);
  img.longitude_deg.assign(npx, nanf);

  // Distance to the Earth's surface per pixel (infinity for space).
  std::vector<float> t_earth(npx);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    std::vector<earth::Vec3> dirs(static_cast<std::size_t>(w));
    sensor.row_rays(y, dirs.data());
    for (int x = 0; x < w; ++x) {
      const earth::Vec3& d = dirs[static_cast<std::size_t>(x)];
      const auto e = earth::ray_sphere(sensor.position, d, earth::radius_m);
      t_earth[static_cast<std::size_t>(y) * w + x] =
          e && e->t0 > 0 ? static_cast<float>(e->t0) : std::numeric_limits<float>::infinity();
    }
  }

  // One pass per cloud type, each timed; layers kept for compositing.
  const std::size_t ns = scene.shells.size();
  std::vector<Layer> layers(npx * ns);
  Progress progress("render", static_cast<std::size_t>(h) * ns);
  for (std::size_t si = 0; si < ns; ++si) {
    const clouds::CloudShell& shell = scene.shells[si];
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<optics::OpticalProperties> props;
    for (const auto* b : bands)
      props.push_back(optics::cloud_optics(shell.params().phase, shell.params().water_content_g_m3,
                                           shell.params().effective_radius_um, *b));
    const optics::OpticalProperties vis_props =
        optics::cloud_optics(shell.params().phase, shell.params().water_content_g_m3,
                             shell.params().effective_radius_um, optics::band("vis"));
#pragma omp parallel for schedule(dynamic, 4)
    for (int y = 0; y < h; ++y) {
      // A whole row marched together (rays in lockstep: see march_shell).
      std::vector<earth::Vec3> dirs(static_cast<std::size_t>(w));
      std::vector<double> t_max(static_cast<std::size_t>(w));
      std::vector<ShellHit> row_hits(static_cast<std::size_t>(w));
      sensor.row_rays(y, dirs.data());
      for (int x = 0; x < w; ++x) t_max[static_cast<std::size_t>(x)] = t_earth[static_cast<std::size_t>(y) * w + x];
      march_shell(shell, sensor.position, dirs.data(), t_max.data(), dirs.size(), params.steps,
                  params.bisection_iterations, row_hits.data());
      for (int x = 0; x < w; ++x) {
        const std::size_t px = static_cast<std::size_t>(y) * w + x;
        const ShellHit& hit = row_hits[static_cast<std::size_t>(x)];
        if (!hit.hit) continue;
        Layer& L = layers[px * ns + si];
        L.t = static_cast<float>(hit.t);
        const double r = glm::length(hit.position);
        const earth::Vec3 up = hit.position / r;
        L.altitude = static_cast<float>(r - earth::radius_m);
        L.tau_vis = static_cast<float>(vis_props.extinction_per_m * hit.depth_m);
        const double mu_sun_local = glm::dot(sun_dir, up);  // sine of the Sun's elevation here
        const double mu0 = glm::dot(hit.normal, sun_dir);
        const double t_cloud = optics::standard_atmosphere_temperature_k(L.altitude);
        for (std::size_t b = 0; b < nb; ++b) {
          const double tau = props[b].extinction_per_m * hit.depth_m;
          const optics::SlabResult slab = optics::two_stream_slab(tau, props[b].single_scattering_albedo);
          const double e_sun = bands[b]->solar_irradiance * sun_scale;
          double rad = 0;
          if (mu_sun_local > 0) {
            rad += (1 - f_ind) * slab.reflectance * e_sun * std::max(0.0, mu0) / M_PI;  // Lambertian reflector
            rad += f_ind * slab.reflectance * e_sun * mu_sun_local / M_PI;              // diffuse emitter
          }
          const double emissivity = std::max(0.0, 1.0 - slab.reflectance - slab.transmittance);
          rad += emissivity * planck[b].forward(t_cloud);  // thermal emission
          L.radiance[b] = static_cast<float>(rad);
          L.transmittance[b] = static_cast<float>(optics::beer_transmittance(tau));
        }
      }
      progress.advance();
    }
    img.seconds_per_type.emplace_back(weather::name(shell.type()),
                                      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }

  // Background and front-to-back compositing.
  // Thermal background: the temperature of the weather's lowest level (1000 hPa for GFS).
  std::vector<float> surface_t;
  if (weather && weather->has(weather::Field::temperature, 0))
    surface_t.assign(weather->level_data(weather::Field::temperature, 0),
                     weather->level_data(weather::Field::temperature, 0) + weather->grid().size());
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    std::vector<std::size_t> order(ns);
    for (int x = 0; x < w; ++x) {
      const std::size_t px = static_cast<std::size_t>(y) * w + x;
      const earth::Vec3 d = sensor.ray(x + 0.5, y + 0.5);
      std::array<double, 3> bg{0, 0, 0};
      if (std::isfinite(t_earth[px])) {
        const earth::Vec3 q = sensor.position + static_cast<double>(t_earth[px]) * d;
        const earth::Geodetic g = earth::geodetic(q);
        img.latitude_deg[px] = static_cast<float>(g.lat_deg);
        img.longitude_deg[px] = static_cast<float>(g.lon_deg);
        const double mu_s = std::max(0.0, glm::dot(sun_dir, q / glm::length(q)));
        double t_surf = params.surface_temperature_k;
        if (!surface_t.empty()) {
          const float v = weather::sample_bilinear(weather->grid(), surface_t, g.lat_deg, g.lon_deg);
          if (!std::isnan(v)) t_surf = v;
        }
        for (std::size_t b = 0; b < nb; ++b)
          bg[b] =
              params.surface_albedo * bands[b]->solar_irradiance * sun_scale * mu_s / M_PI + planck[b].forward(t_surf);
      }
      const Layer* pl = &layers[px * ns];
      for (std::size_t s = 0; s < ns; ++s) order[s] = s;
      std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return pl[a].t < pl[b].t; });
      std::array<double, 3> rad{0, 0, 0}, trans{1, 1, 1};
      float tau = 0;
      for (std::size_t s = 0; s < ns; ++s) {
        const Layer& L = pl[order[s]];
        if (!std::isfinite(L.t)) break;
        if (s == 0) {
          img.cloud_top_altitude_m[px] = L.altitude;
          img.cloud_type[px] = static_cast<std::int8_t>(scene.shells[order[s]].type());
          const earth::Geodetic g = earth::geodetic(sensor.position + static_cast<double>(L.t) * d);
          img.latitude_deg[px] = static_cast<float>(g.lat_deg);
          img.longitude_deg[px] = static_cast<float>(g.lon_deg);
        }
        tau += L.tau_vis;
        for (std::size_t b = 0; b < nb; ++b) {
          rad[b] += trans[b] * L.radiance[b];
          trans[b] *= L.transmittance[b];
        }
      }
      img.cloud_optical_depth[px] = tau;
      for (std::size_t b = 0; b < nb; ++b) img.radiance[b][px] = static_cast<float>(rad[b] + trans[b] * bg[b]);
    }
  }
  for (std::size_t b = 0; b < nb; ++b) {
    if (!bands[b]->thermal) continue;
    img.brightness_temperature[b].resize(npx);
#pragma omp parallel for schedule(static)
    for (std::size_t px = 0; px < npx; ++px)
      img.brightness_temperature[b][px] = static_cast<float>(planck[b].inverse(img.radiance[b][px]));
  }
  return img;
}

}  // namespace nephos::render
