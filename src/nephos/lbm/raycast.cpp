#include "nephos/lbm/raycast.hpp"

#include <algorithm>
#include <cmath>

namespace nephos::lbm {
namespace {

struct V {
  double x, y, z;
};
V operator+(V a, V b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V operator-(V a, V b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V operator*(double s, V a) { return {s * a.x, s * a.y, s * a.z}; }
double dot(V a, V b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V cross(V a, V b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
V norm(V a) { return (1.0 / std::sqrt(dot(a, a))) * a; }

// Trilinear sample of a cell-centred field at point p (cell i spans [i, i+1]); 0 outside.
double sample(const Grid3& g, const std::vector<float>& f, V p) {
  const double x = p.x - 0.5, y = p.y - 0.5, z = p.z - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y)),
            z0 = static_cast<int>(std::floor(z));
  const double tx = x - x0, ty = y - y0, tz = z - z0;
  double v = 0;
  for (int c = 0; c < 8; ++c) {
    const int xi = x0 + (c & 1), yi = y0 + ((c >> 1) & 1), zi = z0 + ((c >> 2) & 1);
    if (xi < 0 || yi < 0 || zi < 0 || xi >= g.nx || yi >= g.ny || zi >= g.nz) continue;
    const double w = ((c & 1) ? tx : 1 - tx) * (((c >> 1) & 1) ? ty : 1 - ty) * (((c >> 2) & 1) ? tz : 1 - tz);
    v += w * f[g.index(xi, yi, zi)];
  }
  return v;
}

// Ray-box [0, n] intersection; false if missed.
bool box(const Grid3& g, V o, V d, double& t0, double& t1) {
  t0 = 0;
  t1 = 1e30;
  const double lo[3] = {0, 0, 0}, hi[3] = {double(g.nx), double(g.ny), double(g.nz)};
  const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  for (int a = 0; a < 3; ++a) {
    if (std::abs(dd[a]) < 1e-12) {
      if (oo[a] < lo[a] || oo[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - oo[a]) / dd[a], tb = (hi[a] - oo[a]) / dd[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t1 > t0;
}

// Optical depth from p towards the sun through the volume.
double depth_to_sun(const Grid3& g, const std::vector<float>& density, V p, V sun, double kappa, double step) {
  double t0, t1;
  if (!box(g, p, sun, t0, t1)) return 0;
  double tau = 0;
  for (double t = t0 + 0.5 * step; t < t1; t += step) tau += kappa * sample(g, density, p + t * sun) * step;
  return tau;
}

// The image's light scale: the 99th percentile of the light inside cloud (density > 0.05).
double light_scale(const std::vector<float>& density, const std::vector<float>& light) {
  std::vector<float> lit;
  for (std::size_t c = 0; c < density.size(); ++c)
    if (density[c] > 0.05f) lit.push_back(light[c]);
  if (lit.empty()) return 1;
  std::nth_element(lit.begin(), lit.begin() + static_cast<std::ptrdiff_t>(lit.size() * 99 / 100), lit.end());
  return std::max(1e-12, static_cast<double>(lit[lit.size() * 99 / 100]));
}

// The ground's transmittance towards the Sun: an orthographic projection of the density along
// `sun` onto z = 0, one sample per lattice unit over the box's shadow, bilinear between them;
// 1 where the Sun is down or off the map.
class ShadowMap {
 public:
  ShadowMap(const Grid3& g, const std::vector<float>& density, V sun, double kappa) : lit_(sun.z > 0) {
    const double reach_x = -g.nz * sun.x / std::max(sun.z, 1e-3), reach_y = -g.nz * sun.y / std::max(sun.z, 1e-3);
    x0_ = std::min(0.0, reach_x) - 1, y0_ = std::min(0.0, reach_y) - 1;
    const double x1 = g.nx + std::max(0.0, reach_x) + 1, y1 = g.ny + std::max(0.0, reach_y) + 1;
    w_ = static_cast<int>(std::ceil(x1 - x0_)) + 1, h_ = static_cast<int>(std::ceil(y1 - y0_)) + 1;
    t_.assign(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_), 1.0f);
    if (!lit_) return;
#pragma omp parallel for schedule(dynamic, 8)
    for (int j = 0; j < h_; ++j)
      for (int i = 0; i < w_; ++i)
        t_[static_cast<std::size_t>(j) * w_ + i] =
            static_cast<float>(std::exp(-depth_to_sun(g, density, V{x0_ + i, y0_ + j, 0}, sun, kappa, 1.0)));
  }
  double at(double x, double y) const {
    const double fx = x - x0_, fy = y - y0_;
    if (!lit_ || fx < 0 || fy < 0 || fx >= w_ - 1 || fy >= h_ - 1) return 1.0;
    const int i = static_cast<int>(fx), j = static_cast<int>(fy);
    const double tx = fx - i, ty = fy - j;
    auto t = [&](int a, int b) { return static_cast<double>(t_[static_cast<std::size_t>(b) * w_ + a]); };
    return (1 - ty) * ((1 - tx) * t(i, j) + tx * t(i + 1, j)) + ty * ((1 - tx) * t(i, j + 1) + tx * t(i + 1, j + 1));
  }

 private:
  bool lit_;
  double x0_, y0_;  // the map's corner [lattice units]
  int w_, h_;
  std::vector<float> t_;
};

// Empty-space skipping: the maximum density of each 8^3 brick grown by one voxel (the
// trilinear footprint); rays jump over bricks that hold no cloud.
class BrickMaxima {
 public:
  static constexpr int brick = 8;
  BrickMaxima(const Grid3& g, const std::vector<float>& density)
      : bx_((g.nx + brick - 1) / brick),
        by_((g.ny + brick - 1) / brick),
        bz_((g.nz + brick - 1) / brick),
        max_(static_cast<std::size_t>(bx_) * by_ * bz_, 0.0f) {
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x)
          if (const float v = density[g.index(x, y, z)]; v > 0) grow(x, y, z, v);
  }
  // Whether q's brick (or outside the box) holds no cloud.
  bool empty(V q) const {
    const int cx = static_cast<int>(std::floor(q.x / brick)), cy = static_cast<int>(std::floor(q.y / brick)),
              cz = static_cast<int>(std::floor(q.z / brick));
    if (cx < 0 || cy < 0 || cz < 0 || cx >= bx_ || cy >= by_ || cz >= bz_) return true;
    return max_[(static_cast<std::size_t>(cz) * by_ + cy) * bx_ + cx] <= 1e-4f;
  }
  // Distance along d from q to the exit of q's brick.
  static double exit(V q, V d) {
    const double b[3] = {std::floor(q.x / brick) * brick, std::floor(q.y / brick) * brick,
                         std::floor(q.z / brick) * brick};
    const double qq[3] = {q.x, q.y, q.z}, dd[3] = {d.x, d.y, d.z};
    double t = 1e30;
    for (int a = 0; a < 3; ++a) {
      if (dd[a] > 1e-12) t = std::min(t, (b[a] + brick - qq[a]) / dd[a]);
      if (dd[a] < -1e-12) t = std::min(t, (b[a] - qq[a]) / dd[a]);
    }
    return t;
  }

 private:
  // Voxel (x, y, z) of density v raises the bricks its footprint reaches.
  void grow(int x, int y, int z, float v) {
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int cx = (x + dx) / brick, cy = (y + dy) / brick, cz = (z + dz) / brick;
          if (x + dx < 0 || y + dy < 0 || z + dz < 0 || cx >= bx_ || cy >= by_ || cz >= bz_) continue;
          float& m = max_[(static_cast<std::size_t>(cz) * by_ + cy) * bx_ + cx];
          m = std::max(m, v);
        }
  }
  int bx_, by_, bz_;
  std::vector<float> max_;
};

// What one pixel's ray needs besides its direction.
struct View {
  const Grid3& g;
  const std::vector<float>& density;
  const std::vector<float>& light;
  const RaycastParams& p;
  V eye, sun;
  double light_norm;
  const ShadowMap& shadow;
  const BrickMaxima& bricks;
};

// What lies behind the cloud along d: the ground plane z = 0 with the cloud's shadow, or a sky
// gradient.
void background(const View& s, V d, double bg[3]) {
  if (d.z < 0) {
    const V q = s.eye + (-s.eye.z / d.z) * d;
    const double lambert = std::max(0.0, s.sun.z);
    const double shade = 0.25 + 0.75 * s.shadow.at(q.x, q.y) * lambert;
    bg[0] = 0.32 * shade, bg[1] = 0.38 * shade, bg[2] = 0.22 * shade;  // grassland
  } else {
    const double h = std::min(1.0, d.z * 2);
    bg[0] = 0.55 - 0.30 * h, bg[1] = 0.70 - 0.25 * h, bg[2] = 0.95 - 0.10 * h;  // sky
  }
}

// The ray's colour, composited front to back over the background into rgb (gamma 2.2).
void shade_ray(const View& s, V d, std::uint8_t* rgb) {
  double bg[3];
  background(s, d, bg);
  double col[3] = {0, 0, 0}, trans = 1;
  double t0, t1;
  const double kappa = s.p.extinction_per_density, step = s.p.step;
  if (box(s.g, s.eye, d, t0, t1)) {
    for (double t = t0 + 0.5 * step; t < t1 && trans > 0.005; t += step) {
      const V q = s.eye + t * d;
      if (s.bricks.empty(q)) {  // jump to the brick's exit, keeping the sample lattice of the ray
        t += std::max(0.0, std::floor(BrickMaxima::exit(q, d) / step) * step);
        continue;
      }
      const double rho = sample(s.g, s.density, q);
      if (rho <= 1e-4) continue;
      const double a = 1 - std::exp(-kappa * rho * step);
      const double l = std::min(1.5, sample(s.g, s.light, q) / s.light_norm);
      const double shade = 0.25 + 0.85 * l;  // ambient sky light + lattice-Boltzmann sunlight
      col[0] += trans * a * shade * 1.00, col[1] += trans * a * shade * 0.98, col[2] += trans * a * shade * 0.95;
      trans *= 1 - a;
    }
  }
  for (int c = 0; c < 3; ++c)
    rgb[c] =
        static_cast<std::uint8_t>(std::lround(255 * std::pow(std::clamp(col[c] + trans * bg[c], 0.0, 1.0), 1 / 2.2)));
}

}  // namespace

std::vector<std::uint8_t> raycast(const Grid3& g, const std::vector<float>& density, const std::vector<float>& light,
                                  const RaycastParams& p) {
  const double ea = p.sun_elevation_deg * M_PI / 180, az = p.sun_azimuth_deg * M_PI / 180;
  const V sun{std::cos(ea) * std::cos(az), std::cos(ea) * std::sin(az), std::sin(ea)};  // towards the sun
  V eye{p.eye[0], p.eye[1], p.eye[2]}, target{p.target[0], p.target[1], p.target[2]};
  if (dot(eye - target, eye - target) < 1e-9) {  // default: a low side view across the box
    target = {0.5 * g.nx, 0.5 * g.ny, 0.3 * g.nz};
    eye = {0.5 * g.nx, -1.3 * g.ny, 0.35 * g.nz};
  }
  const V fwd = norm(target - eye);
  const V right = norm(cross(fwd, V{0, 0, 1}));
  const V up = cross(right, fwd);
  const double th = std::tan(0.5 * p.fov_deg * M_PI / 180);
  const ShadowMap shadow(g, density, sun, p.extinction_per_density);
  const BrickMaxima bricks(g, density);
  const View s{g, density, light, p, eye, sun, light_scale(density, light), shadow, bricks};
  std::vector<std::uint8_t> img(static_cast<std::size_t>(p.width) * p.height * 3);
#pragma omp parallel for schedule(dynamic, 4)
  for (int py = 0; py < p.height; ++py)
    for (int px = 0; px < p.width; ++px) {
      const double sx = (2.0 * (px + 0.5) / p.width - 1) * th,
                   sy = (1 - 2.0 * (py + 0.5) / p.height) * th * p.height / p.width;
      shade_ray(s, norm(fwd + sx * right + sy * up), &img[(static_cast<std::size_t>(py) * p.width + px) * 3]);
    }
  return img;
}

}  // namespace nephos::lbm
