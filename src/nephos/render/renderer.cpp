#include "nephos/render/renderer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <tuple>
#include <utility>

#include "nephos/atmosphere/rayleigh.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/core/progress.hpp"
#include "nephos/core/simd_math.hpp"
#include "nephos/render/earth_view.hpp"
#include "nephos/render/radiometry.hpp"
#include "nephos/render/shadows.hpp"
#include "nephos/surface/surface.hpp"

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

// Band-mean Planck radiance as a table over temperature for a fast exact-enough inverse.
struct PlanckTable {
  static constexpr double t_lo = 100, t_hi = 400, dt = 0.01;
  static constexpr int size = static_cast<int>((t_hi - t_lo) / dt + 0.5) + 1;  // nodes: 30 001
  std::vector<double> radiance;
  // The inverse's first guess: the monochromatic brightness temperature at the band's centre
  // [um], corrected linearly to guess_offset_k + guess_slope T_mono (least squares over the nodes).
  double centre_um = 1, guess_offset_k = 0, guess_slope = 1;
  explicit PlanckTable(const optics::Band& band) : radiance(size), centre_um(band.centre_um) {
    // 30 001 band integrals of 32 Planck evaluations each: ~0.1 s on one core, so built in
    // parallel, and once per band for the process (planck_table()).
#pragma omp parallel for schedule(static)
    for (int i = 0; i < size; ++i) radiance[static_cast<std::size_t>(i)] = optics::band_planck(band, t_lo + i * dt);
    double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < radiance.size(); i += 10) {
      if (!(radiance[i] > 0)) continue;
      const double x = optics::brightness_temperature(centre_um, radiance[i]), y = t_lo + static_cast<double>(i) * dt;
      n += 1, sx += x, sy += y, sxx += x * x, sxy += x * y;
    }
    if (n >= 2 && n * sxx - sx * sx > 0) {
      guess_slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
      guess_offset_k = (sy - guess_slope * sx) / n;
    }
  }
  double forward(double t) const {
    const double x = std::clamp((t - t_lo) / dt, 0.0, static_cast<double>(radiance.size() - 2));
    const auto i = static_cast<std::size_t>(x);
    return radiance[i] + (x - static_cast<double>(i)) * (radiance[i + 1] - radiance[i]);
  }
  // Requests the nodes forward(t) reads: ten bands' tables (2.4 MiB) do not stay in L2, and a
  // pixel's temperature is known well before its radiances are. Always inlined: GCC 12 finds a
  // separate prefetch() free of side effects and drops its calls.
  [[gnu::always_inline]] void prefetch(double t) const {
    const double x = (t - t_lo) / dt;
    if (x >= 0 && x < static_cast<double>(radiance.size() - 1)) {
      __builtin_prefetch(radiance.data() + static_cast<std::size_t>(x));
      __builtin_prefetch(radiance.data() + static_cast<std::size_t>(x) + 1);
    }
  }
  // The inverse of n radiances, linear between 0.01 K nodes (error < 1e-5 K): each one's node
  // interval [radiance[i], radiance[i + 1]) stepped to from the first guess (within a few nodes),
  // the guesses' logarithms in a loop that vectorises (core/simd_math.hpp). The interval is
  // unique, so the result does not depend on the guess.
  void inverse(const float* l, std::size_t n, float* t) const {
    constexpr std::size_t chunk = 256;
    alignas(64) double guess[chunk];
    const double last = static_cast<double>(radiance.size() - 2);
    for (std::size_t c0 = 0; c0 < n; c0 += chunk) {
      const std::size_t m = std::min(chunk, n - c0);
      for (std::size_t k = 0; k < m; ++k) {
        const double t_mono = optics::brightness_temperature(centre_um, l[c0 + k]);
        const double x = (guess_offset_k + guess_slope * t_mono - t_lo) / dt;
        guess[k] = x < 0 ? 0.0 : x > last ? last : x;
      }
      for (std::size_t k = 0; k < m; ++k) t[c0 + k] = static_cast<float>(inverse_from(l[c0 + k], guess[k]));
    }
  }
  double inverse_from(double l, double guess) const {
    if (!(l > radiance.front())) return t_lo;
    if (l >= radiance.back()) return t_hi;
    // One secant step from the guess's interval lands in l's (the table is straight over a few
    // nodes) but where l lies within rounding of a node; the walk settles those.
    const auto g = static_cast<std::size_t>(guess);
    const double x = static_cast<double>(g) + (l - radiance[g]) / (radiance[g + 1] - radiance[g]);
    auto i = static_cast<std::size_t>(std::clamp(x, 0.0, static_cast<double>(radiance.size() - 2)));
    while (radiance[i] > l) --i;
    while (radiance[i + 1] <= l) ++i;
    return t_lo + dt * (static_cast<double>(i) + (l - radiance[i]) / (radiance[i + 1] - radiance[i]));
  }
};

struct Layer {  // one cloud type's contribution to one pixel; its per-band values apart (below)
  float t = std::numeric_limits<float>::infinity();
  float altitude = 0, tau_vis = 0;
  float coverage = 1;  // the share of the pixel it covers (ShellHit::coverage)
};
// A layer's radiance [W m^-2 sr^-1 um^-1], transmittance, the air's radiance between it and the
// sensor [W m^-2 sr^-1 um^-1] and reflectance in each of a render's nb bands: radiance[0..nb),
// then transmittance[0..nb), path[0..nb), reflectance[0..nb), 16 nb bytes per layer (as many
// bands as asked for, up to optics::max_band_count). Read only where the layer's t is finite,
// so never reset.
constexpr std::size_t layer_band_floats(std::size_t nb) { return 4 * nb; }

}  // namespace

ShellHit march_shell(const clouds::CloudShell& shell, const earth::Vec3& o, const earth::Vec3& d, double t_max,
                     int steps, int bisection_iterations, double spread) {
  ShellHit hit;
  march_shell(shell, o, &d, &t_max, 1, steps, bisection_iterations, &hit, spread);
  return hit;
}

namespace {

// std::min and std::max by value, with their results (b < a ? b : a; a < b ? b : a). In an
// `omp simd` loop GCC 12 turns the reference-returning std:: forms into a choice of address
// and a load, a masked gather it does not vectorise.
[[gnu::always_inline]] inline double min_v(double a, double b) { return b < a ? b : a; }
[[gnu::always_inline]] inline double max_v(double a, double b) { return a < b ? b : a; }

// The smaller root t0 of |o + t d|^2 = radius^2 and the larger one t1 (earth::ray_sphere's
// arithmetic, branch-free for vectorised loops); disc < 0 when the ray misses. Results through
// references, not a struct: under `omp simd` a struct local becomes an array of structs per
// vector lane, whose stores GCC 12 cannot vectorise.
[[gnu::always_inline]] inline void sphere_roots(double b, double c, double& t0, double& t1, double& disc) {
  disc = std::fma(b, b, -c);
  const double s = std::sqrt(max_v(disc, 0.0));
  const double q = b > 0 ? -b - s : -b + s;
  const double r0 = q, r1 = q != 0 ? c / q : -b;
  t0 = min_v(r0, r1), t1 = max_v(r0, r1);
}

// Per-thread scratch of march_shell(), structure of arrays (one row of rays at a time), kept
// between calls so that marching a row allocates nothing.
struct MarchScratch {
  // Every ray: its path through the shell, [a0, a0 + la] then [b0, b1] (see Path), and its
  // length.
  std::vector<double> a0, la, b0, b1, len;
  std::vector<std::uint8_t> in_shell;
  // The rays marched (possible cloud on their path), compacted; a subset of them (the rays
  // still refined, or a filtered step's rays that may meet cloud).
  std::vector<std::uint32_t> idx, act;
  std::vector<double> ma0, mla, mb0, ds, dx, dy, dz;
  std::vector<double> v_prev, lo, hi, depth_after;
  std::vector<int> k_hit;
  std::vector<std::uint8_t> lit;  // write_hits: the hits whose normal is found
  // Filtered marches: the footprint at each point [m], per ray the largest u met and its step,
  // and the expected length of cloud along the path (sum of ds coverage(u)).
  std::vector<double> footprint, u_max, soft_length;
  std::vector<clouds::PathCoverage> paths;  // filtered: each ray's chance of meeting cloud
  std::vector<double> coverage, shown;      // the cone's share in cloud, and the share a hit reports
  std::vector<int> k_max;
  std::vector<earth::Vec3> pts;
  std::vector<double> vals;
  // The crossings' points, footprints and gradients (write_hits).
  std::vector<earth::Vec3> cross_pts, cross_grads;
  std::vector<double> cross_footprint;
  // Each ray's altitude window as squared radii [m^2] (clouds::window_squared_radii).
  std::vector<double> r2_lo, r2_hi;
  void resize_rays(std::size_t n) {
    for (auto* v : {&a0, &la, &b0, &b1, &len}) v->resize(n);
    in_shell.resize(n);
  }
  // The ends of every ray's path (first n: start, next n: end), its count of skip lookups (one
  // per skip radius of arc, bounded) and its altitude window [m] (lo > hi: empty).
  std::vector<double> ex, ey, ez;
  std::vector<int> segments;
  std::vector<double> z_lo, z_hi;
  // The other skip lookups of the long paths, the ray each belongs to, and their windows.
  std::vector<double> ix, iy, iz, window_lo, window_hi;
  std::vector<std::uint32_t> owner;
  void resize_ends(std::size_t n) {
    for (auto* v : {&ex, &ey, &ez}) v->resize(2 * n);
    segments.resize(n);
  }
  void resize_marched(std::size_t n) {
    idx.resize(n);
    for (auto* v : {&ma0, &mla, &mb0, &ds, &dx, &dy, &dz, &v_prev, &lo, &hi, &depth_after, &footprint, &u_max,
                    &soft_length, &coverage, &shown, &r2_lo, &r2_hi})
      v->resize(n);
    k_hit.resize(n), k_max.resize(n);
    pts.resize(n);
    vals.resize(n);
  }
  // The ray parameter and the point at path length s of marched ray j (Path::t_at).
  double t_at(std::size_t j, double s) const { return s <= mla[j] ? ma0[j] + s : mb0[j] + (s - mla[j]); }
  earth::Vec3 point(const earth::Vec3& o, std::size_t j, double s) const {
    const double t = t_at(j, s);
    return earth::Vec3{std::fma(t, dx[j], o.x), std::fma(t, dy[j], o.y), std::fma(t, dz[j], o.z)};
  }
};

// Stage 1 of march_shell, for every ray: the part inside the shell, up to two intervals (in
// front of and behind the inner sphere when a ray grazes below the shell bottom without
// reaching the ground); the path's ends and the number of skip lookups it needs, one per skip
// radius of arc. The arc between the ends is bounded by its chord c without trigonometry (arc =
// 2 asin(c/2) <= c / sqrt(1 - c^2/4)). A ray that misses the shell (a GEO frame's space pixels)
// looks up a dummy direction and is dropped after.
// The loop vectorises (GCC 12, -fopt-info-vec) only as written: the origin and directions read
// as plain doubles (not through the reference or glm's union members), stores through raw
// pointers (through the vectors, every store could move their own data pointers), the booleans
// combined with & (no short-circuit branches), no struct locals and no std::min/max.
void shell_paths(const clouds::CloudShell& shell, const earth::Vec3& o, const earth::Vec3* d, const double* t_max,
                 std::size_t n, MarchScratch& w) {
  w.resize_rays(n);
  w.resize_ends(n);
  const double r_top = shell.radius_top_m(), r_bottom = shell.radius_bottom_m();
  const double oo = glm::dot(o, o), c_top = oo - r_top * r_top, c_bottom = oo - r_bottom * r_bottom;
  const double inv_radius = 1 / shell.skip_radius_rad();
  const double ox = o.x, oy = o.y, oz = o.z;
  static_assert(sizeof(earth::Vec3) == 3 * sizeof(double));
  const double* dxyz = &d[0].x;
  double *pa0 = w.a0.data(), *pla = w.la.data(), *pb0 = w.b0.data(), *pb1 = w.b1.data(), *plen = w.len.data();
  double *ex = w.ex.data(), *ey = w.ey.data(), *ez = w.ez.data();
  std::uint8_t* in_shell = w.in_shell.data();
  int* segments = w.segments.data();
#pragma omp simd
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = dxyz[3 * i], dy = dxyz[3 * i + 1], dz = dxyz[3 * i + 2];
    const double b = std::fma(oz, dz, std::fma(oy, dy, ox * dx));
    double out_t0, out_t1, out_disc, in_t0, in_t1, in_disc;
    sphere_roots(b, c_top, out_t0, out_t1, out_disc);
    sphere_roots(b, c_bottom, in_t0, in_t1, in_disc);
    const double t0 = max_v(out_t0, 0.0), t1 = min_v(out_t1, t_max[i]);
    // Enters the inner sphere ahead: cut there, resume where it leaves. Starts inside it
    // (camera below the shell): from its exit.
    const bool meets_inner = (in_disc >= 0) & (in_t1 > t0);
    const bool ahead = meets_inner & (in_t0 > t0), from_exit = meets_inner & !(in_t0 > t0);
    const double a0 = from_exit ? in_t1 : t0, a1 = ahead ? min_v(in_t0, t1) : t1;
    const double b0 = ahead ? in_t1 : 0.0, b1 = ahead ? t1 : 0.0;
    const double la = a1 - a0, len = la + max_v(0.0, b1 - b0);
    // (from_exit & (in_t1 >= t1)) is from_exit & (a0 >= t1), without a choice between booleans.
    const bool ok = (out_disc >= 0) & (out_t1 > 0) & (t1 > t0) & !(from_exit & (in_t1 >= t1)) & (len > 0);
    pa0[i] = a0, pla[i] = la, pb0[i] = b0, pb1[i] = b1, plen[i] = len, in_shell[i] = ok;
    // The path's ends, Path::t_at(0) and t_at(len).
    const double s1 = len <= la ? a0 + len : b0 + (len - la);
    const double x0 = ok ? std::fma(a0, dx, ox) : 1.0, y0 = ok ? std::fma(a0, dy, oy) : 0.0,
                 z0 = ok ? std::fma(a0, dz, oz) : 0.0;
    const double x1 = ok ? std::fma(s1, dx, ox) : 1.0, y1 = ok ? std::fma(s1, dy, oy) : 0.0,
                 z1 = ok ? std::fma(s1, dz, oz) : 0.0;
    // The squared chord between the ends' unit directions, c^2 = 2 - 2 cos(angle), from one
    // square root and one division (the divider is the loop's bottleneck). Its cancellation
    // at short paths (relative error ~1e-16 / angle^2) matters only where the count of lookups
    // changes, at an angle of one skip radius (~1e-3 rad): an error of ~1e-10.
    const double rr0 = std::fma(z0, z0, std::fma(y0, y0, x0 * x0)), rr1 = std::fma(z1, z1, std::fma(y1, y1, x1 * x1));
    const double cos_angle = std::fma(z0, z1, std::fma(y0, y1, x0 * x1)) / std::sqrt(rr0 * rr1);
    const double c2 = max_v(std::fma(-2.0, cos_angle, 2.0), 0.0);
    const double arc_bound = std::sqrt(c2 / max_v(std::fma(-0.25, c2, 1.0), 1e-12));
    segments[i] = 1 + static_cast<int>(min_v(arc_bound * inv_radius, 1e6));
    ex[i] = x0, ey[i] = y0, ez[i] = z0, ex[n + i] = x1, ey[n + i] = y1, ez[n + i] = z1;
  }
}

// Stage 2, empty-space skipping: each path's altitude window (CloudShell::altitude_window)
// looked up along it, batched: at its start and, for paths longer than one skip radius (most
// paths, in steep views, are not), at its far end and the interior points one skip radius
// apart; the path's window is the widest of them. A ray whose window is empty costs nothing
// more; the others keep theirs as squared radii, outside which a filtered step is not
// evaluated (march_steps_filtered). The rays to march go into w.idx and their paths into the
// compacted arrays; returns their count.
std::size_t rays_to_march(const clouds::CloudShell& shell, const earth::Vec3& o, const earth::Vec3* d, std::size_t n,
                          int steps, MarchScratch& w) {
  // Every path's start at once (a ray outside the shell looks up its dummy end, unused), then
  // the other lookups of the long paths.
  w.z_lo.resize(n), w.z_hi.resize(n);
  shell.altitude_window(w.ex.data(), w.ey.data(), w.ez.data(), n, w.z_lo.data(), w.z_hi.data());
  w.owner.clear();
  w.ix.clear(), w.iy.clear(), w.iz.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const int m = w.segments[i];
    if (!w.in_shell[i] || m == 1) continue;
    w.owner.push_back(static_cast<std::uint32_t>(i));  // the far end
    w.ix.push_back(w.ex[n + i]), w.iy.push_back(w.ey[n + i]), w.iz.push_back(w.ez[n + i]);
    const Path path{w.a0[i], w.a0[i] + w.la[i], w.b0[i], w.b1[i]};
    for (int j = 1; j < m; ++j) {
      const double t = path.t_at(path.length() * j / m);
      w.owner.push_back(static_cast<std::uint32_t>(i));
      w.ix.push_back(std::fma(t, d[i].x, o.x)), w.iy.push_back(std::fma(t, d[i].y, o.y));
      w.iz.push_back(std::fma(t, d[i].z, o.z));
    }
  }
  const std::size_t nl = w.owner.size();
  w.window_lo.resize(nl), w.window_hi.resize(nl);
  shell.altitude_window(w.ix.data(), w.iy.data(), w.iz.data(), nl, w.window_lo.data(), w.window_hi.data());
  for (std::size_t k = 0; k < nl; ++k) {
    const std::uint32_t i = w.owner[k];
    w.z_lo[i] = std::min(w.z_lo[i], w.window_lo[k]), w.z_hi[i] = std::max(w.z_hi[i], w.window_hi[k]);
  }
  std::size_t nr = 0;
  w.idx.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    if (w.in_shell[i] && w.z_lo[i] <= w.z_hi[i]) w.idx[nr++] = static_cast<std::uint32_t>(i);
  if (nr == 0) return 0;
  w.resize_marched(nr);
  for (std::size_t j = 0; j < nr; ++j) {
    const std::uint32_t i = w.idx[j];
    w.ma0[j] = w.a0[i], w.mla[j] = w.la[i], w.mb0[j] = w.b0[i];
    w.ds[j] = w.len[i] / steps;
    std::tie(w.r2_lo[j], w.r2_hi[j]) = clouds::window_squared_radii(w.z_lo[i], w.z_hi[i]);
    w.dx[j] = d[i].x, w.dy[j] = d[i].y, w.dz[j] = d[i].z;
    w.k_hit[j] = -1, w.v_prev[j] = 0, w.lo[j] = 0, w.hi[j] = 0, w.depth_after[j] = 0;
    w.u_max[j] = -std::numeric_limits<double>::infinity(), w.soft_length[j] = 0, w.k_max[j] = 0;
  }
  return nr;
}

// Stage 3, the march of the nr compacted rays in lockstep: per ray, the first step inside (its
// crossing bracketed in [lo, hi]) and the depth inside after it. The two per-step loops
// vectorise (GCC 12) only through raw pointers, with the points written as plain doubles and the
// booleans combined with &: through the thread-local vectors and Vec3 stores they run lane by
// lane.
void march_steps(const clouds::CloudShell& shell, const earth::Vec3& o, int steps, std::size_t nr, MarchScratch& w) {
  const double thr = shell.threshold();
  const double ox = o.x, oy = o.y, oz = o.z;
  const double *ma0 = w.ma0.data(), *mla = w.mla.data(), *mb0 = w.mb0.data(), *ds = w.ds.data();
  const double *rdx = w.dx.data(), *rdy = w.dy.data(), *rdz = w.dz.data(), *vals = w.vals.data();
  double *pts = &w.pts[0].x, *v_prev = w.v_prev.data(), *lo = w.lo.data(), *hi = w.hi.data();
  double* depth_after = w.depth_after.data();
  int* k_hit = w.k_hit.data();
  for (int k = 0; k <= steps; ++k) {
    const double kd = k, km1 = k > 0 ? k - 1 : 0;
#pragma omp simd
    for (std::size_t j = 0; j < nr; ++j) {
      const double s = kd * ds[j];
      const double t = s <= mla[j] ? ma0[j] + s : mb0[j] + (s - mla[j]);  // MarchScratch::t_at(j, s)
      pts[3 * j] = std::fma(t, rdx[j], ox), pts[3 * j + 1] = std::fma(t, rdy[j], oy);
      pts[3 * j + 2] = std::fma(t, rdz[j], oz);
    }
    shell.classify(w.pts.data(), nr, w.vals.data());
#pragma omp simd
    for (std::size_t j = 0; j < nr; ++j) {
      const double v = vals[j] - thr, vp = v_prev[j];
      const bool after = k_hit[j] >= 0;
      const bool first = !after & (v > 0);  // first sample inside: bracket the crossing
      // After the crossing step, depth by linear interpolation between samples (of CF, or of
      // the bounds classify() returns, which keep CF's side: accuracy of order one step): the
      // length of the step where the interpolant exceeds 0.
      const double x = vp / (vp - v);  // where the interpolant crosses 0 (used only on a sign change)
      const bool both_in = (vp > 0) & (v > 0), both_out = (vp <= 0) & (v <= 0);
      const double inside = !after ? 0.0 : both_in ? 1.0 : both_out ? 0.0 : vp > 0 ? x : 1 - x;
      depth_after[j] = std::fma(ds[j], inside, depth_after[j]);
      lo[j] = first ? km1 * ds[j] : lo[j];
      hi[j] = first ? kd * ds[j] : hi[j];
      k_hit[j] = first ? k : k_hit[j];
      v_prev[j] = v;
    }
  }
}

// Stage 3, filtered (anti-aliasing): the march of march_steps() through the shell as the pixel's
// cone sees it (CloudShell::classify_filtered, footprint spread t at distance t): per ray the
// first step inside (u > 0, the filtered cloud function above the threshold), the largest u and
// its step, the expected length of cloud along the path (the trapezoid rule over ds coverage(u))
// and the chance of meeting any (clouds::PathCoverage: the cone's cloud fraction).
void march_steps_filtered(const clouds::CloudShell& shell, const earth::Vec3& o, int steps, double spread,
                          std::size_t nr, MarchScratch& w) {
  const double ox = o.x, oy = o.y, oz = o.z;
  const double *ma0 = w.ma0.data(), *mla = w.mla.data(), *mb0 = w.mb0.data(), *ds = w.ds.data();
  const double *rdx = w.dx.data(), *rdy = w.dy.data(), *rdz = w.dz.data(), *vals = w.vals.data();
  double *pts = &w.pts[0].x, *fp = w.footprint.data(), *u_max = w.u_max.data(), *lo = w.lo.data(), *hi = w.hi.data();
  double* soft = w.soft_length.data();
  int *k_hit = w.k_hit.data(), *k_max = w.k_max.data();
  w.act.resize(nr);
  std::uint32_t* cloudy = w.act.data();
  w.paths.resize(nr);
  for (std::size_t j = 0; j < nr; ++j) {  // the footprint at the path's middle stands for the whole path
    const double length = ds[j] * steps;
    w.paths[j] = clouds::PathCoverage(spread * w.t_at(j, 0.5 * length), length);
  }
  for (int k = 0; k <= steps; ++k) {
    const double kd = k, km1 = k > 0 ? k - 1 : 0, end_weight = (k == 0 || k == steps) ? 0.5 : 1.0;
#pragma omp simd
    for (std::size_t j = 0; j < nr; ++j) {  // as march_steps()
      const double s = kd * ds[j];
      const double t = s <= mla[j] ? ma0[j] + s : mb0[j] + (s - mla[j]);
      pts[3 * j] = std::fma(t, rdx[j], ox), pts[3 * j + 1] = std::fma(t, rdy[j], oy);
      pts[3 * j + 2] = std::fma(t, rdz[j], oz);
      fp[j] = spread * t;
    }
    clouds::classify_filtered_in_windows(shell, w.pts.data(), w.footprint.data(), w.r2_lo.data(), w.r2_hi.data(), nr,
                                         w.vals.data());
#pragma omp simd
    for (std::size_t j = 0; j < nr; ++j) {
      const double u = vals[j];
      const bool more = u > u_max[j], first = (k_hit[j] < 0) & (u > 0);
      u_max[j] = more ? u : u_max[j];
      k_max[j] = more ? k : k_max[j];
      lo[j] = first ? km1 * ds[j] : lo[j];
      hi[j] = first ? kd * ds[j] : hi[j];
      k_hit[j] = first ? k : k_hit[j];
    }
    // The steps with any coverage added to their paths.
    const std::size_t nc = clouds::steps_with_cover(shell, vals, nr, cloudy);
    for (std::size_t c = 0; c < nc; ++c) {
      const std::uint32_t j = cloudy[c];
      const double dl = end_weight * ds[j];
      soft[j] = std::fma(dl, w.paths[j].add(shell, vals[j], dl), soft[j]);
    }
  }
  // Rays that met no crossing but some chance of cloud: a partial hit at their likeliest step,
  // not refined. Below roulette_coverage, kept with probability coverage / roulette_coverage
  // (a counter-based hash of the ray) at that coverage: the same mean, fewer faint hits to shade
  // (Russian roulette, Arvo & Kirk 1990).
  for (std::size_t j = 0; j < nr; ++j) {
    w.coverage[j] = w.shown[j] = w.paths[j].chance();
    if (w.k_hit[j] >= 0 || !(w.coverage[j] > 0)) continue;
    if (w.coverage[j] < roulette_coverage) {
      const std::uint64_t h =
          mix64(std::bit_cast<std::uint64_t>(w.dx[j]) ^
                mix64(std::bit_cast<std::uint64_t>(w.dy[j]) ^ std::bit_cast<std::uint64_t>(w.dz[j])));
      if (to_unit_double(h) * roulette_coverage >= w.coverage[j]) continue;
      w.shown[j] = roulette_coverage;
    }
    w.k_hit[j] = w.k_max[j], w.lo[j] = w.hi[j] = w.k_max[j] * w.ds[j];
  }
}

// Stage 4: the rays that found cloud compacted to the front; their first crossings refined
// together by bisection, each bracket halved until it is shorter than the finest texture voxel
// (the smallest feature the cloud function has), at most bisection_iterations times. Returns
// their count.
std::size_t refine_crossings(const clouds::CloudShell& shell, const earth::Vec3& o, int bisection_iterations,
                             double spread, std::size_t nr, MarchScratch& w) {
  std::size_t nh = 0;
  for (std::size_t j = 0; j < nr; ++j) {
    if (w.k_hit[j] < 0) continue;
    w.idx[nh] = w.idx[j], w.ma0[nh] = w.ma0[j], w.mla[nh] = w.mla[j], w.mb0[nh] = w.mb0[j], w.ds[nh] = w.ds[j];
    w.dx[nh] = w.dx[j], w.dy[nh] = w.dy[j], w.dz[nh] = w.dz[j];
    w.k_hit[nh] = w.k_hit[j], w.lo[nh] = w.lo[j], w.hi[nh] = w.hi[j], w.depth_after[nh] = w.depth_after[j];
    w.u_max[nh] = w.u_max[j], w.soft_length[nh] = w.soft_length[j];
    w.coverage[nh] = w.coverage[j], w.shown[nh] = w.shown[j];
    ++nh;
  }
  const double thr = shell.threshold(), tolerance = shell.feature_size_m();
  for (int it = 0; it < bisection_iterations; ++it) {
    std::size_t na = 0;  // rays still refined, compacted into act
    w.act.resize(nh);
    for (std::size_t j = 0; j < nh; ++j)
      if (w.k_hit[j] != 0 && w.hi[j] - w.lo[j] > tolerance) w.act[na++] = static_cast<std::uint32_t>(j);
    if (na == 0) break;
    for (std::size_t a = 0; a < na; ++a) {
      const std::uint32_t j = w.act[a];
      const double s_mid = 0.5 * (w.lo[j] + w.hi[j]);
      w.pts[a] = w.point(o, j, s_mid);
      w.footprint[a] = spread * w.t_at(j, s_mid);
    }
    if (spread > 0)
      shell.classify_filtered(w.pts.data(), w.footprint.data(), na, w.vals.data());  // u: threshold 0
    else
      shell.classify(w.pts.data(), na, w.vals.data());
    for (std::size_t a = 0; a < na; ++a) {
      const std::uint32_t j = w.act[a];
      (w.vals[a] - (spread > 0 ? 0.0 : thr) > 0 ? w.hi[j] : w.lo[j]) = 0.5 * (w.lo[j] + w.hi[j]);
    }
  }
  return nh;
}

// Stage 5: the nh hits with their surface normals from the CF gradient
// (CloudShell::value_and_gradient: the textures' own gradients, the smooth parts by forward
// differences with h ~ two fine voxels). A partial hit's normal is not the gradient's (below):
// only the crossings' gradients are found (those lit_by lights, where given), compacted (each
// point's gradient is its own).
void write_hits(const clouds::CloudShell& shell, const earth::Vec3& o, double spread, std::size_t nh,
                const std::optional<earth::Vec3>& lit_by, MarchScratch& w, ShellHit* hits) {
  const double h = std::max(2.0 * shell.feature_size_m(), 1.0);
  // A hit whose function crosses the threshold; else (filtered) a partial hit.
  auto crossing = [&](std::size_t j) { return !(spread > 0) || w.u_max[j] > 0; };
  w.lit.resize(nh);
  std::size_t nc = 0;  // the crossings whose normal is wanted, compacted into w.act
  w.act.resize(nh);
  for (std::size_t j = 0; j < nh; ++j) {
    const double s_hit = w.k_hit[j] == 0 ? 0.0 : w.hi[j];
    w.pts[j] = w.point(o, j, s_hit);
    w.footprint[j] = spread * w.t_at(j, s_hit);
    w.lit[j] = crossing(j) && (!lit_by || glm::dot(w.pts[j], *lit_by) > 0);
    w.act[nc] = static_cast<std::uint32_t>(j);
    nc += w.lit[j];
  }
  w.cross_pts.resize(nc), w.cross_footprint.resize(nc), w.cross_grads.resize(nc);
  for (std::size_t a = 0; a < nc; ++a) w.cross_pts[a] = w.pts[w.act[a]], w.cross_footprint[a] = w.footprint[w.act[a]];
  shell.value_and_gradient(w.cross_pts.data(), nc, h, nullptr, w.cross_grads.data(),
                           spread > 0 ? w.cross_footprint.data() : nullptr);
  for (std::size_t j = 0, a = 0; j < nh; ++j) {
    const earth::Vec3 dir{w.dx[j], w.dy[j], w.dz[j]};
    ShellHit& hit = hits[w.idx[j]];
    const double s_hit = w.k_hit[j] == 0 ? 0.0 : w.hi[j];
    hit.hit = true;
    hit.t = w.t_at(j, s_hit);
    hit.position = w.pts[j];
    // Depth: from the surface to the end of the crossing step, then the steps after it. Filtered:
    // the expected length of cloud along the path over the chance that the ray meets any.
    hit.depth_m = (w.k_hit[j] * w.ds[j] - s_hit) + w.depth_after[j];
    const earth::Vec3 g = w.lit[j] ? w.cross_grads[a++] : earth::Vec3{};  // the lit crossings in order
    const double gl = glm::length(g);
    hit.normal = gl > 0 ? -g / gl : -dir;
    if (spread > 0) {
      hit.coverage = w.shown[j];
      hit.depth_m = w.soft_length[j] / w.coverage[j];
      hit.coherence = gl * gl / (gl * gl + shell.detail_gradient_variance(w.footprint[j]));
    }
    // A partial hit (the filtered function never crosses: cloud smaller than the footprint) is
    // at the ray's largest u, where the gradient is across the ray. The sub-pixel clouds' visible
    // surface, area-weighted, faces the sensor (Cauchy: the visible normals of a closed surface
    // sum to its projected area along the view): their mean normal is -dir. An unlit crossing's
    // is left as theirs: nothing reads it.
    if (!w.lit[j]) hit.normal = -dir, hit.coherence = 0;
  }
}

}  // namespace

void march_shell(const clouds::CloudShell& shell, const earth::Vec3& o, const earth::Vec3* d, const double* t_max,
                 std::size_t n, int steps, int bisection_iterations, ShellHit* hits, double spread,
                 const std::optional<earth::Vec3>& lit_by) {
  // Rays advance in lockstep, one batched classify() per step over every ray still in the
  // shell, so the texture misses of different rays overlap (see CloudShell::classify). Every
  // per-ray stage is a branch-free loop over arrays that vectorises; a ray's result does not
  // depend on the other rays of the batch. Multiply-adds in these loops are explicit std::fma:
  // left to the compiler, the vector body and the scalar remainder contract differently.
  thread_local MarchScratch w;
  for (std::size_t i = 0; i < n; ++i) hits[i] = ShellHit{};
  shell_paths(shell, o, d, t_max, n, w);
  const std::size_t nr = rays_to_march(shell, o, d, n, steps, w);
  for (std::size_t j = 0; j < nr; ++j) hits[w.idx[j]].marched = true;
  if (nr == 0) return;
  if (spread > 0)
    march_steps_filtered(shell, o, steps, spread, nr, w);
  else
    march_steps(shell, o, steps, nr, w);
  const std::size_t nh = refine_crossings(shell, o, bisection_iterations, spread, nr, w);
  write_hits(shell, o, spread, nh, lit_by, w, hits);
}

double facets_facing_every_way(double cos_phase) {
  const double c = std::clamp(cos_phase, -1.0, 1.0), a = std::acos(c);
  return 2.0 / 3.0 * (std::sin(a) + (M_PI - a) * c) / M_PI;
}

std::pair<double, double> sub_pixel_offset(int x, int y, int i, int j, int k, bool stratified, std::uint64_t seed) {
  double u = 0.5, v = 0.5;
  if (stratified && !(k % 2 == 1 && i == k / 2 && j == k / 2)) {
    const auto px = static_cast<std::uint64_t>(y) << 32 | static_cast<std::uint32_t>(x);
    const auto sub = static_cast<std::uint64_t>(j * k + i);
    u = uniform01(seed, 0x5b9, px, sub, 0), v = uniform01(seed, 0x5b9, px, sub, 1);
  }
  return {(i + u) / k, (j + v) / k};
}

namespace {

// The Planck table of a built-in band, built on first use and kept for the process (renders
// of an animation, or the benchmark's, need not rebuild it).
const PlanckTable& planck_table(const optics::Band& b) {
  static std::mutex mutex;
  static std::map<std::string, std::unique_ptr<const PlanckTable>> tables;
  const std::lock_guard lock(mutex);
  auto& table = tables[b.name];
  if (!table) table = std::make_unique<const PlanckTable>(b);
  return *table;
}

// The bands of a render and their Planck tables.
struct BandTables {
  std::vector<const optics::Band*> bands;
  std::vector<const PlanckTable*> planck;
  explicit BandTables(const std::vector<std::string>& names) {
    if (names.size() > optics::max_band_count)
      throw ValueError(fmt::format("at most {} bands per render", optics::max_band_count), {.key = "bands"});
    for (const auto& name : names) {
      bands.push_back(&optics::band(name));
      planck.push_back(&planck_table(*bands.back()));
    }
  }
  /// Requests every thermal band's Planck nodes at temperature t_k (PlanckTable::prefetch).
  [[gnu::always_inline]] void prefetch_planck(double t_k) const {
    for (std::size_t b = 0; b < bands.size(); ++b)
      if (bands[b]->thermal) planck[b]->prefetch(t_k);
  }
};

// Where one pass of sub-pixel rays crosses each pixel: sub-pixel (i, j) of a k x k grid, at
// its centre or, stratified, at a point hashed from the seed, the pixel and the sub-pixel
// (uniform in the sub-pixel; the centre sub-pixel of an odd k stays at the pixel centre, the
// point sample that gives each pixel's latitude and longitude).
struct SubPixel {
  int i = 0, j = 0, k = 1;
  bool stratified = false;
  std::uint64_t seed = 0;
  std::pair<double, double> offset(int x, int y) const { return sub_pixel_offset(x, y, i, j, k, stratified, seed); }
  // The rays of image row y.
  void row_rays(const Sensor& sensor, int y, earth::Vec3* out) const {
    if (!stratified) return sensor.row_rays(y, out, (i + 0.5) / k, (j + 0.5) / k);
    const double t = std::tan(0.5 * sensor.fov_deg * earth::deg);
    for (int x = 0; x < sensor.width; ++x) {
      const auto [dx, dy] = offset(x, y);
      out[x] = sensor.ray(x + dx, y + dy, t);
    }
  }
};

// Droplet effective radius [um] from the liquid water content [g m^-3] over ground of a land
// share `land` (Martin, Johnson & Spice 1994: r_e = (3 W / (4 pi rho_w k N))^(1/3), N = 100 cm^-3
// and k = 0.8 over sea, 300 cm^-3 and 0.67 over land); 4-25 um.
double droplet_effective_radius_um(double lwc_g_m3, double land) {
  const double n_m3 = (100 + 200 * land) * 1e6, k = 0.8 - 0.13 * land;
  const double r_m = std::cbrt(3 * lwc_g_m3 * 1e-3 / (4 * M_PI * 1000 * k * n_m3));
  return std::clamp(r_m * 1e6, 4.0, 25.0);
}

// Ice effective radius [um] from the in-cloud ice water content [g m^-3] and temperature [K]:
// Heymsfield & McFarquhar (1996, J. Atmos. Sci. 53, eq. 5, p. 2434; the relation GFS's
// radiation uses for its own ice), r_e = (1250 / c) IWC^p with (c, p) = (9.917, 0.109) below
// -50 C, (9.337, 0.08) to -40 C, (9.208, 0.055) to -30 C, (9.387, 0.031) above; 10-150 um.
double ice_effective_radius_um(double iwc_g_m3, double t_k) {
  const double tc = t_k - 273.15, iwc = std::max(iwc_g_m3, 1e-6);
  const double r = tc < -50   ? 1250 / 9.917 * std::pow(iwc, 0.109)
                   : tc < -40 ? 1250 / 9.337 * std::pow(iwc, 0.08)
                   : tc < -30 ? 1250 / 9.208 * std::pow(iwc, 0.055)
                              : 1250 / 9.387 * std::pow(iwc, 0.031);
  return std::clamp(r, 10.0, 150.0);
}

// Where the weather gives a cloud's microphysics (microphysics(), RenderContext::shadow_tau):
// condensate paths above min_path_g_m2 over the cloud's share, in-cloud water contents clamped to
// [min, max]_water_g_m3, ice below ice_below_k (-15 C).
constexpr double min_path_g_m2 = 0.1, min_water_g_m3 = 0.01, max_water_g_m3 = 3.0, ice_below_k = 258.15;

// The phase and effective radius [um] of cloud of in-cloud water content wc [g m^-3] at t_k [K]
// over ground of land share `land`.
std::pair<optics::Phase, double> particles(double wc_g_m3, double t_k, double land) {
  return t_k < ice_below_k ? std::pair{optics::Phase::ice, ice_effective_radius_um(wc_g_m3, t_k)}
                           : std::pair{optics::Phase::water, droplet_effective_radius_um(wc_g_m3, land)};
}

// What every stage of render_at() reads: the scene, the sensor and the Sun, the parameters, the
// bands, the atmosphere and ground (EarthView) and each cloud type's default optics per band.
struct RenderContext {
  const clouds::CloudScene& scene;
  const Sensor& sensor;
  const RenderParams& params;
  const weather::WeatherGrid* weather;
  const BandTables& tables;
  const SubPixel& sub;
  const EarthView& earth;
  earth::Vec3 sun_dir;
  double sun_scale = 1;                              ///< (1 AU / Sun distance)^2
  const optics::Band& vis = optics::band("vis");     ///< the band of the reported optical depth
  std::vector<optics::OpticalProperties> vis_props;  ///< [type], the types' own, for the optical depth
  std::vector<double> asymmetry;                     ///< [type], the types' own
  /// [type][band] the single-scattering albedo of the type's own optics and its
  /// similarity-scaled extinction factor (1 - omega g), for the shadows it casts.
  std::vector<std::array<double, optics::max_band_count>> shadow_albedo, shadow_scale;
  /// [node * shells + shell] the vertical visible optical depth of each shell's clouds at each
  /// weather node (EarthView's) from the weather's condensate: the layer's path over the cloud's
  /// share (the weather's own masks, not carried), as microphysics() gives its elements; with no
  /// element's top to read below, the effective radius from the layer's mean where its
  /// condensate is and the phase from the temperature there. 0 where it has none. What the
  /// shadows a shell casts dim with, read where its cloud came from (weather_place()).
  std::vector<float> shadow_tau;
  bool shadows = false;  ///< shadows asked for and a solar band among the bands
  /// The bands that see sunlight (Band::sunlit()), in order: a hit's beam reflectances are found
  /// for these alone, packed into their own lanes (a thermal render has one of ten).
  std::vector<std::size_t> sunlit_bands;
  /// The pixel's cone for filtering (march_shell): its width per metre of distance, one pixel's
  /// (or sub-pixel's) angle at the image centre [rad]; 0 without filtering.
  double spread = 0;

  RenderContext(const clouds::CloudScene& scene_, const Sensor& sensor_, const earth::SunPosition& sun,
                const RenderParams& params_, const weather::WeatherGrid* weather_, const BandTables& tables_,
                const SubPixel& sub_, const EarthView& earth_)
      : scene(scene_), sensor(sensor_), params(params_), weather(weather_), tables(tables_), sub(sub_), earth(earth_) {
    sun_dir = sun.direction_ecef;
    sun_scale = 1.0 / (sun.distance_au * sun.distance_au);
    const std::size_t ns = scene.shells.size();
    vis_props.resize(ns), asymmetry.resize(ns), shadow_albedo.resize(ns), shadow_scale.resize(ns);
    for (std::size_t si = 0; si < ns; ++si) {
      const clouds::CloudTypeParams& cp = scene.shells[si].params();
      asymmetry[si] = cp.asymmetry;
      vis_props[si] = optics::cloud_optics(cp.phase, cp.water_content_g_m3, cp.effective_radius_um, vis);
      for (std::size_t b = 0; b < tables.bands.size(); ++b) {
        const double omega =
            optics::cloud_optics(cp.phase, cp.water_content_g_m3, cp.effective_radius_um, *tables.bands[b])
                .single_scattering_albedo;
        shadow_albedo[si][b] = omega, shadow_scale[si][b] = optics::similarity_scaled(1.0, omega, cp.asymmetry).tau;
      }
    }
    for (std::size_t b = 0; b < tables.bands.size(); ++b)
      if (tables.bands[b]->sunlit()) sunlit_bands.push_back(b);
    shadows = params.shadows && !sunlit_bands.empty();
    if (shadows) build_shadow_tau();
    if (params.filter)
      spread = 2 * std::tan(0.5 * sensor.fov_deg * earth::deg) / (sensor.width * params.samples_per_axis);
  }
  std::size_t band_count() const { return tables.bands.size(); }
  /// Whether shells a and b share a condensate layer (a shell shares its own).
  bool same_layer(std::size_t a, std::size_t b) const {
    const auto& layers = scene.condensate_layer_m;
    return a == b || (a < layers.size() && b < layers.size() && layers[a] == layers[b]);
  }
  /// The share of the cell a cloud of shell si covers: the masks (cloud fractions) of the shells
  /// whose condensate layer is its own, at least 0.1; as the wind carried them to p, or (carried
  /// false) as the weather puts them in unit direction p.
  double cloud_share(std::size_t si, const earth::Vec3& p, bool carried = true) const {
    double share = 0;
    for (std::size_t s = 0; s < scene.shells.size(); ++s)
      if (same_layer(s, si)) share += carried ? scene.shells[s].mask_at(p) : scene.shells[s].weather_mask(p);
    return std::max(share, 0.1);
  }
  /// The place whose weather (condensate, temperature) shell si's cloud at p carries: where the
  /// wind brought it from (CloudShell::carried_from), `here` while the shell is not carried.
  EarthView::Place weather_place(std::size_t si, const earth::Vec3& p, const EarthView::Place& here) const {
    const clouds::CloudShell& shell = scene.shells[si];
    if (!shell.carried()) return here;
    const earth::Geodetic g = earth::geodetic(shell.carried_from(p));
    return earth.place(g.lat_deg, g.lon_deg);
  }
  /// shadow_tau of shell si at a place, bilinear between the nodes.
  double shadow_tau_at(const EarthView::Place& at, std::size_t si) const {
    if (shadow_tau.empty()) return 0;
    const std::size_t ns = scene.shells.size();
    double tau = 0;
    for (std::size_t q = 0; q < 4; ++q) tau += at.w[q] * shadow_tau[at.node[q] * ns + si];
    return tau;
  }
  void build_shadow_tau() {
    if (!weather || !earth.has_condensate()) return;
    const std::size_t ns = scene.shells.size(), nn = earth.node_count();
    shadow_tau.assign(nn * ns, 0.0f);
#pragma omp parallel for schedule(static)
    for (std::size_t k = 0; k < nn; ++k) {
      const auto [lat, lon] = earth.node_lat_lon_deg(k);
      const EarthView::Place node{{k, k, k, k}, {1, 0, 0, 0}};
      const double land = earth.ground(node).share[1];
      for (std::size_t si = 0; si < ns; ++si) {
        const double share = cloud_share(si, earth::unit_from_latlon(lat, lon), false);
        const EarthView::LayerCondensate lc = earth.node_condensate_layer(k, si);
        const double path = lc.path_g_m2 / share;
        if (!(path > min_path_g_m2)) continue;
        const double wc = std::clamp(lc.mean_g_m3 / share, min_water_g_m3, max_water_g_m3);
        const auto [phase, r_e] = particles(wc, lc.temperature_k, land);
        // The path spread over 1 m: its extinction there is the optical depth.
        shadow_tau[k * ns + si] = static_cast<float>(optics::cloud_optics(phase, path, r_e, vis).extinction_per_m);
      }
    }
  }
  /// Sunlight in band b at 1 AU scaled to the Sun's distance [W m^-2 um^-1, normal to the beam].
  double solar_irradiance(std::size_t b) const { return tables.bands[b]->solar_irradiance * sun_scale; }
};

// A cloud element's microphysics: phase, in-cloud water content [g m^-3], effective radius [um]
// and, from the weather, the in-cloud condensate path [g m^-2] its optical depth carries (0: the
// water content over the element's own depth); and its temperature [K], with each weather
// node's level there (a hint for the air's lookup at the same altitude).
struct Microphysics {
  optics::Phase phase;
  double water_content_g_m3, effective_radius_um, path_g_m2 = 0, temperature_k = 0;
  EarthView::LevelHint levels{};
};

// From the weather where it has condensate, over the cloud's share of the cell (the masks of the
// shells sharing its layer, calibrated to cloud cover):
//  - the optical depth carries the path of the type's layer (CloudScene::condensate_layer_m;
//    EarthView::condensate_layer) where it exceeds min_path_g_m2, so that the clouds hold the
//    weather's water whatever their rendered depth;
//  - the in-cloud water content, for the effective radius, is the condensate's mean over the
//    element's vertical extent below its top (thickness_m);
//  - phase from the cloud's temperature at its top, effective radius from the water content
//    (particles()).
// Else the type's own.
Microphysics microphysics(const RenderContext& c, std::size_t si, const EarthView::Place& at, double alt,
                          double thickness_m, const earth::Vec3& p) {
  const clouds::CloudTypeParams& cp = c.scene.shells[si].params();
  Microphysics m{cp.phase, cp.water_content_g_m3, cp.effective_radius_um};
  // The condensate's mean over the cloud's vertical extent below its top (a top's own value
  // misses the water lower in the cloud: GFS's ice peaks at 300-400 hPa, under the anvil tops),
  // found with the top's temperature.
  const bool profile = c.weather && c.earth.has_condensate();
  std::array<double, 5> z, q_at;
  for (std::size_t k = 0; k < z.size(); ++k) z[k] = alt - thickness_m * (static_cast<double>(k) + 0.5) / 5;
  m.temperature_k = c.earth.temperature_k(at, alt, z.data(), profile ? z.size() : 0, q_at.data(), &m.levels);
  if (!c.weather) return m;
  if (profile) {
    const double share = c.cloud_share(si, p);
    double q = 0;
    for (const double qk : q_at) q += qk / 5;
    if (q > 1e-4) m.water_content_g_m3 = std::clamp(q / share, min_water_g_m3, max_water_g_m3);
    const double path = c.earth.condensate_layer(at, si).path_g_m2 / share;
    if (path > min_path_g_m2) m.path_g_m2 = path;
  }
  std::tie(m.phase, m.effective_radius_um) = particles(m.water_content_g_m3, m.temperature_k, c.earth.land_share(at));
  return m;
}

// Sunlight arriving at a point per band [W m^-2 um^-1]: the direct beam normal to itself and the
// diffuse skylight on a level surface, through the air above (gases, Rayleigh).
struct Sunlight {
  std::array<double, optics::max_band_count> direct{}, sky{};
};
// Cloud between a point and the Sun, per shell along the sunward ray: the expected length of
// cloud and the chance of meeting any (1 or 0 for a point sample; filtered, the sub-pixel
// clouds' share of the footprint).
struct CloudLengths {
  std::array<double, weather::cloud_type_count> length{}, chance{};
};

// The stages of render_stage_names(), and one thread's time in each: a lap ends the stage
// begun at the previous lap (or start()).
enum class Stage : std::size_t {
  rays,
  march,
  hit_shadows,
  hit_shading,
  layers,
  ground_shadows,
  ground_and_sky,
  brightness_temperatures,
  count
};
constexpr std::array<const char*, static_cast<std::size_t>(Stage::count)> stage_names = {
    "rays",   "march",          "hit_shadows",    "hit_shading",
    "layers", "ground_shadows", "ground_and_sky", "brightness_temperatures"};
static_assert(stage_names.back() != nullptr, "every Stage has its name");
struct StageClock {
  std::array<double, static_cast<std::size_t>(Stage::count)> seconds{};
  std::chrono::steady_clock::time_point last;
  void start() { last = std::chrono::steady_clock::now(); }
  void lap(Stage s) {
    const auto now = std::chrono::steady_clock::now();
    seconds[static_cast<std::size_t>(s)] += std::chrono::duration<double>(now - last).count();
    last = now;
  }
};

// One thread's work on one image row at a time: each pixel's ray and distance to the Earth, each
// cloud type's layer (16 + 16 nb B per pixel and type), and the scratch of the march's shadows and
// the compositing. A row is traced in every type and composited by the thread that began it, so
// the image holds only its outputs and the threads wait on each other once, at its end.
struct RowWork {
  std::size_t ns = 0, lbf = 0;     ///< types; floats per layer's band values
  std::vector<Layer> layers;       ///< [pixel][type]
  std::vector<float> layer_bands;  ///< [pixel][type][layer_band_floats]
  std::vector<float> t_earth;      ///< to the Earth's surface [m]; inf: space
  std::vector<earth::Vec3> dirs;   ///< the rays' directions
  // The march's: each ray's limit, its hit in the type, the hits (or ground points) in sunlight,
  // their positions and the cloud towards the Sun from them.
  std::vector<double> t_max;
  std::vector<ShellHit> hits;
  std::vector<int> lit;
  std::vector<earth::Vec3> lit_points;
  std::vector<CloudLengths> lengths;
  // The compositing's, per pixel and band (optics::max_band_count apart): radiance,
  // transmittance, the air's radiance above the last layer and the stack's reflectance seen from
  // below; whether some band sees what lies behind the clouds.
  std::vector<double> rad, trans, path_above, refl_above;
  std::vector<std::uint8_t> seen;
  StageClock clock;  ///< this thread's time by stage

  explicit RowWork(const RenderContext& c) : ns(c.scene.shells.size()), lbf(layer_band_floats(c.band_count())) {
    const auto w = static_cast<std::size_t>(c.sensor.width);
    layers.resize(w * ns), layer_bands.resize(w * ns * lbf), t_earth.resize(w), dirs.resize(w);
    t_max.resize(w), hits.resize(w), seen.resize(w);
    for (auto* v : {&rad, &trans, &path_above, &refl_above}) v->resize(w * optics::max_band_count);
  }
  Layer& layer(std::size_t x, std::size_t si) { return layers[x * ns + si]; }
  float* bands(std::size_t x, std::size_t si) { return &layer_bands[(x * ns + si) * lbf]; }
};

// Starts row y: layers cleared, each pixel's ray and distance to the Earth.
void begin_row(const RenderContext& c, int y, RowWork& rw) {
  rw.clock.start();
  std::fill(rw.layers.begin(), rw.layers.end(), Layer{});
  c.sub.row_rays(c.sensor, y, rw.dirs.data());
  for (int x = 0; x < c.sensor.width; ++x) {
    const auto e = earth::ray_sphere(c.sensor.position, rw.dirs[x], earth::radius_m);
    rw.t_earth[x] = e && e->t0 > 0 ? static_cast<float>(e->t0) : std::numeric_limits<float>::infinity();
  }
  rw.clock.lap(Stage::rays);
}

// Sunlight arriving at a point through the air above and the clouds towards the Sun
// (`lengths`, by shell; null: none). Per shell, the share `chance` of the beam that meets cloud
// is dimmed by exp(-tau') of the similarity-scaled optical depth of its length there (length /
// chance), the rest passes (the mean transmittance, not exp(-mean tau): broken cloud lets the
// gaps' light through); shells overlap at random. What the clouds scatter forwards joins the
// diffuse part: what the plane-parallel layer of their mean optical depth passes of a beam from
// the Sun's height, less the direct beam.
Sunlight sunlight(const RenderContext& c, const EarthView::Place& at, const earth::Vec3& point, const AirSample& air,
                  double mu_sun, const CloudLengths* lengths = nullptr) {
  Sunlight s;
  if (mu_sun <= 0) return s;
  // Per shell, the visible optical depth of its cloud along the beam where the beam meets it: the
  // weather's cloud as the plane-parallel layer it is in the view (shade_hit), crossed at the
  // Sun's slant; else the type's own along the path found in the shell.
  std::array<double, weather::cloud_type_count> tau_beam{};
  for (std::size_t si = 0; lengths && si < c.scene.shells.size(); ++si) {
    const double p = lengths->chance[si];
    if (!(p > 0)) continue;
    const double tau_v = c.shadow_tau_at(c.weather_place(si, point, at), si);
    tau_beam[si] =
        tau_v > 0 ? tau_v / std::max(mu_sun, 0.05) : c.vis_props[si].extinction_per_m * lengths->length[si] / p;
  }
  for (std::size_t b = 0; b < c.band_count(); ++b) {
    if (!c.tables.bands[b]->sunlit()) continue;
    const double e0 = c.solar_irradiance(b) * air.t_sun[b];
    const double direct = std::exp(-air.tau_rayleigh[b] / mu_sun);
    s.direct[b] = e0 * direct;
    s.sky[b] = e0 * mu_sun * (rayleigh_down(air.tau_rayleigh[b], mu_sun) - direct);
    if (!lengths) continue;
    // Chance-weighted sums over the shells: the scaled optical depth along the beam (tau), and
    // the unscaled one (tau_u) with its scattering (omega tau_u) and forward scattering (g omega
    // tau_u).
    double t_direct = 1, clear = 1, tau = 0, tau_u = 0, scattering = 0, forward = 0;
    for (std::size_t si = 0; si < c.scene.shells.size(); ++si) {
      const double p = lengths->chance[si];
      if (!(p > 0)) continue;
      const double t = c.shadow_scale[si][b] * tau_beam[si], w = p * tau_beam[si] * c.shadow_albedo[si][b];
      t_direct *= 1 - p + p * std::exp(-t), clear *= 1 - p;
      tau += p * t, tau_u += p * tau_beam[si], scattering += w, forward += w * c.asymmetry[si];
    }
    if (tau <= 0) continue;
    // Under the cloudy share, the layer of their mean optical depth passes the beam as a
    // plane-parallel cloud lit from the Sun's height does (delta-Eddington, as the clouds reflect
    // it: shade_hit), less what the direct beam above already carries.
    const double cloudy = 1 - clear;
    const optics::BeamSlab layer = optics::delta_eddington_beam(tau_u / cloudy * mu_sun, scattering / tau_u,
                                                                scattering > 0 ? forward / scattering : 0.0, mu_sun);
    const double t_diffuse =
        cloudy * std::max(0.0, layer.diffuse_transmittance + layer.direct_transmittance - std::exp(-tau / cloudy));
    s.sky[b] += s.direct[b] * mu_sun * t_diffuse;
    s.direct[b] *= t_direct;
  }
  return s;
}

// The cloud towards the Sun from n points, by shell: each shell but those of the condensate
// layer of `skip` (a cloud's own layer: its self-shading is the layer's reflectance; the two low
// types are one layer of cloud, split by the updraft); skip = the shell count: every shell.
void cloud_towards_sun(const RenderContext& c, const earth::Vec3* points, std::size_t n, std::size_t skip,
                       std::vector<CloudLengths>& out) {
  out.assign(n, CloudLengths{});
  thread_local std::vector<double> len, chance, footprint;
  len.resize(n), chance.resize(n), footprint.resize(n);
  // Filtered: the pixel's cone as wide as at the point along the whole sunward ray.
  for (std::size_t i = 0; i < n; ++i) footprint[i] = c.spread * glm::length(points[i] - c.sensor.position);
  // A quarter of the march's steps, at least 6, over the part of each path its altitude window
  // leaves (cloud_length_towards): 0.14 K RMS in band 7 against 48 steps on a 4 km ABI disc,
  // 0.16 K for twelve over the whole path (docs/render.md, cloud shadows).
  const int steps = std::max(6, c.params.steps / 4);
  for (std::size_t si = 0; si < c.scene.shells.size(); ++si) {
    if (skip < c.scene.shells.size() && c.same_layer(si, skip)) continue;
    cloud_length_towards(c.scene.shells[si], points, c.sun_dir, n, steps, len.data(),
                         c.spread > 0 ? footprint.data() : nullptr, chance.data());
    for (std::size_t i = 0; i < n; ++i) out[i].length[si] = len[i], out[i].chance[si] = chance[i];
  }
}

// The air's own radiance per band between a point at altitude z and the sensor [W m^-2 sr^-1
// um^-1]: its thermal emission and the sunlight it scatters (Rayleigh, single scattering).
void path_radiance(const RenderContext& c, const AirSample& air, double mu_view, double mu_sun, double cos_scatter,
                   std::array<double, optics::max_band_count>& out) {
  for (std::size_t b = 0; b < c.band_count(); ++b) {
    out[b] = air.path[b];
    if (c.tables.bands[b]->sunlit())
      out[b] += rayleigh_path(c.solar_irradiance(b), air.tau_rayleigh[b], mu_view, mu_sun, cos_scatter) *
                std::sqrt(air.t_view[b] * air.t_sun[b]);
  }
}

// The mean cosine between the sunward direction s and the facets of a hit's surface that the
// sensor sees along d: the filtered normal's share (hit.coherence) as the footprint's mean
// surface, max(0, n.s); the sub-pixel detail's as facets facing every way.
double sunlit_facets(const ShellHit& hit, const earth::Vec3& d, const earth::Vec3& s) {
  const double facing = std::max(0.0, glm::dot(hit.normal, s));
  if (!(hit.coherence < 1)) return facing;
  return hit.coherence * facing + (1 - hit.coherence) * facets_facing_every_way(-glm::dot(d, s));
}

// One cloud type's layer at a hit: distance, altitude, visible optical depth, and per band the
// radiance leaving it that reaches the sensor through the clear air above, and the transmittance
// of what lies behind (a plane-parallel slab of the same vertical optical depth).
void shade_hit(const RenderContext& c, std::size_t si, const ShellHit& hit, const earth::Vec3& dir,
               const CloudLengths* towards_sun, Layer& L, float* lb) {
  const std::size_t nb = c.band_count();
  const double f_ind = c.params.indirect_fraction;
  L.t = static_cast<float>(hit.t);
  const double r = glm::length(hit.position);
  const earth::Vec3 up = hit.position / r;
  L.altitude = static_cast<float>(r - earth::radius_m);
  const earth::Geodetic g = earth::geodetic(hit.position);
  const double mu_view = std::clamp(-glm::dot(up, dir), 0.05, 1.0);  // the plane-parallel layer's
  const double mu_air = std::max(0.02, -glm::dot(up, dir));          // the air's path to the sensor
  const double mu_sun = glm::dot(c.sun_dir, up);                     // sine of the Sun's elevation here
  const double lit = sunlit_facets(hit, dir, c.sun_dir);
  // The air and the Sun's path through it are here; the cloud's own temperature and condensate
  // are the weather's where the wind brought it from.
  const EarthView::Place at = c.earth.place(g.lat_deg, g.lon_deg), origin = c.weather_place(si, hit.position, at);
  const double depth_vertical_m = hit.depth_m * mu_view;
  const Microphysics m = microphysics(c, si, origin, L.altitude, depth_vertical_m, hit.position);
  const double t_cloud = m.temperature_k;
  c.tables.prefetch_planck(t_cloud);
  // The visible optical depth along the line of sight, of the element's own microphysics, its
  // mean over the pixel.
  const double cover = hit.coverage;
  L.coverage = static_cast<float>(cover);
  // Extinction in the geometric-optics limit: the same in every band. With the weather's
  // condensate path, the water content that spreads it over the element's vertical depth.
  const double w_path = m.path_g_m2 > 0 ? m.path_g_m2 / std::max(depth_vertical_m, 1.0) : m.water_content_g_m3;
  const double extinction_per_m = optics::cloud_optics(m.phase, w_path, m.effective_radius_um, c.vis).extinction_per_m;
  L.tau_vis = static_cast<float>(cover * extinction_per_m * hit.depth_m);
  // The type's asymmetry for its own phase; where the weather's temperature gives the other
  // phase, that phase's typical value (0.86 droplets, 0.77 ice).
  const double asym =
      m.phase == c.scene.shells[si].params().phase ? c.asymmetry[si] : (m.phase == optics::Phase::water ? 0.86 : 0.77);
  AirSample air;
  // Each node's levels walked from those of the temperature's lookup at the weather's origin:
  // the same altitude (the same nodes but where the wind carried the cloud), so a level or two.
  c.earth.air(at, L.altitude, mu_air, mu_sun, air, &m.levels);
  const Sunlight sun = sunlight(c, at, hit.position, air, mu_sun, towards_sun);
  std::array<double, optics::max_band_count> path;
  path_radiance(c, air, mu_air, mu_sun, glm::dot(c.sun_dir, dir), path);
  // The layer in every band at once (cloud_optics()'s albedo, cloud_layer()), over the bands
  // padded with inert lanes (w = 0) to optics::band_lanes().
  const std::size_t lanes = optics::band_lanes(nb);
  alignas(64) std::array<double, optics::max_band_count> w{}, omega, tau, refl, trans, emis, beam;
  for (std::size_t b = 0; b < nb; ++b) {
    const optics::Band& band = *c.tables.bands[b];
    w[b] =
        optics::anomalous_diffraction_w(optics::imaginary_index(m.phase, band), m.effective_radius_um, band.centre_um);
  }
  optics::anomalous_diffraction_albedos(w.data(), lanes, omega.data());
  tau.fill(extinction_per_m * hit.depth_m * mu_view);
  cloud_layers(tau.data(), omega.data(), asym, mu_view, lanes, refl.data(), trans.data(), emis.data());
  // The Sun's beam is reflected as the layer reflects a beam from the Sun's height (a thin layer
  // more of a low Sun); the skylight, diffuse, as the layer reflects diffuse light. Each lane's
  // arithmetic is its own, so the sunlit bands' lanes packed apart give the same values.
  const std::size_t ns_lit = c.sunlit_bands.size();
  if (mu_sun > 0 && ns_lit > 0) {
    alignas(64) std::array<double, optics::max_band_count> omega_lit, beam_lit;
    omega_lit.fill(omega[c.sunlit_bands[0]]);  // the padding lanes a real band's
    for (std::size_t j = 0; j < ns_lit; ++j) omega_lit[j] = omega[c.sunlit_bands[j]];
    optics::delta_eddington_beam_reflectances(tau.data(), omega_lit.data(), asym, mu_sun, optics::band_lanes(ns_lit),
                                              beam_lit.data());
    for (std::size_t j = 0; j < ns_lit; ++j) beam[c.sunlit_bands[j]] = beam_lit[j];
  }
  for (std::size_t b = 0; b < nb; ++b) {
    const optics::Band& band = *c.tables.bands[b];
    double rad = 0;
    if (band.sunlit() && mu_sun > 0)  // Lambertian facets lit by the beam, plus skylight
      rad += (beam[b] * sun.direct[b] * ((1 - f_ind) * lit + f_ind * mu_sun) + refl[b] * sun.sky[b]) / M_PI;
    if (band.thermal) rad += emis[b] * c.tables.planck[b]->forward(t_cloud);
    const double up_share = band.sunlit() ? rayleigh_up(air.tau_rayleigh[b], mu_air) : 1.0;
    // Over the pixel: the cloud's share of it, and the rest seen unobstructed.
    lb[b] = static_cast<float>(cover * rad * air.t_view[b] * up_share);
    lb[nb + b] = static_cast<float>(1 - cover * (1 - trans[b]));
    lb[2 * nb + b] = static_cast<float>(path[b]);
    lb[3 * nb + b] = static_cast<float>(cover * refl[b]);
  }
}

// Cloud type si along the row begun in rw: its rays marched together (in lockstep: see
// march_shell), the hits shaded into the row's layers. Returns the rays marched.
std::uint64_t trace_row(const RenderContext& c, std::size_t si, RowWork& rw) {
  const clouds::CloudShell& shell = c.scene.shells[si];
  const int w = c.sensor.width;
  rw.clock.start();
  for (int x = 0; x < w; ++x) rw.t_max[x] = rw.t_earth[x];
  // The normals only where the Sun is up and a band sees it (sunlit_facets(), their reader).
  march_shell(shell, c.sensor.position, rw.dirs.data(), rw.t_max.data(), static_cast<std::size_t>(w), c.params.steps,
              c.params.bisection_iterations, rw.hits.data(), c.spread,
              c.sunlit_bands.empty() ? earth::Vec3{0.0} : c.sun_dir);
  rw.clock.lap(Stage::march);
  // The clouds of the other shells towards the Sun from this row's hits.
  rw.lit.clear(), rw.lit_points.clear();
  for (int x = 0; x < w; ++x) {
    const ShellHit& hit = rw.hits[x];
    if (c.shadows && hit.hit && glm::dot(hit.position, c.sun_dir) > 0)
      rw.lit.push_back(x), rw.lit_points.push_back(hit.position);
  }
  if (!rw.lit.empty()) cloud_towards_sun(c, rw.lit_points.data(), rw.lit_points.size(), si, rw.lengths);
  rw.clock.lap(Stage::hit_shadows);
  std::uint64_t marched = 0;
  std::size_t next_lit = 0;
  for (int x = 0; x < w; ++x) {
    const ShellHit& hit = rw.hits[x];
    marched += hit.marched;
    if (!hit.hit) continue;
    const bool shadowed = next_lit < rw.lit.size() && rw.lit[next_lit] == x;
    shade_hit(c, si, hit, rw.dirs[x], shadowed ? &rw.lengths[next_lit] : nullptr, rw.layer(x, si), rw.bands(x, si));
    next_lit += shadowed;
  }
  rw.clock.lap(Stage::hit_shading);
  return marched;
}

// The ground where a ray meets it: reflected sunlight (Lambertian albedo, and sun glint on open
// water) and emission, as they reach the sensor, per band; the air's radiance above it; and its
// reflectance to diffuse light (the albedo, or 1 - emissivity in a thermal band).
void ground_radiance(const RenderContext& c, const earth::Geodetic& g, const earth::Vec3& up, const earth::Vec3& d,
                     const CloudLengths* towards_sun, std::array<double, optics::max_band_count>& out,
                     std::array<double, optics::max_band_count>& path,
                     std::array<double, optics::max_band_count>& reflectance) {
  const EarthView::Place at = c.earth.place(g.lat_deg, g.lon_deg);
  const double z = c.earth.ground_height_m(at);
  std::array<double, optics::max_band_count> sky_down{};
  const surface::State ground = c.earth.ground(at, &sky_down);
  c.tables.prefetch_planck(ground.skin_temperature_k);
  const double mu_view = std::max(0.02, -glm::dot(up, d)), mu_sun = glm::dot(c.sun_dir, up);
  AirSample air;
  c.earth.air(at, z, mu_view, mu_sun, air, &EarthView::ground_levels);
  const Sunlight sun = sunlight(c, at, up, air, mu_sun, towards_sun);
  path_radiance(c, air, mu_view, mu_sun, glm::dot(c.sun_dir, d), path);
  const double glint = surface::glint_reflectance(mu_sun, mu_view, -glm::dot(c.sun_dir, d), ground.wind_speed_m_s);
  for (std::size_t b = 0; b < c.band_count(); ++b) {
    const optics::Band& band = *c.tables.bands[b];
    double rad = 0;
    reflectance[b] = 0;
    if (band.sunlit() && mu_sun > 0) {
      const double albedo = surface::mixed_albedo(ground, band);
      rad += (sun.direct[b] * mu_sun * (albedo + ground.share[0] * glint) + sun.sky[b] * albedo) / M_PI;
      reflectance[b] = albedo;
    }
    if (band.thermal) {  // emission, and the sky's emission reflected (Kirchhoff: reflectance 1 - e)
      const double e = surface::mixed_emissivity(ground, band);
      rad += e * c.tables.planck[b]->forward(ground.skin_temperature_k) + (1 - e) * sky_down[b];
      reflectance[b] = std::max(reflectance[b], 1 - e);
    }
    const double up_share = band.sunlit() ? rayleigh_up(air.tau_rayleigh[b], mu_view) : 1.0;
    out[b] = rad * air.t_view[b] * up_share;
  }
}

// A ray that misses the Earth: the limb's haze and emission where it passes through the air
// (tangent height below 100 km), black space beyond. The air along the tangent path is the
// column at the tangent point's, in shells: the path's share of a shell above height h is its
// vertical amount above h times the Chapman grazing factor, so the emission is the sum over the
// shells of B(T) times the transmittance the shell adds (the limb's weighting function).
void sky_radiance(const RenderContext& c, const earth::Vec3& d, std::array<double, optics::max_band_count>& out) {
  out.fill(0.0);
  if (!c.earth.atmosphere()) return;
  const earth::Vec3& o = c.sensor.position;
  const double t_tangent = -glm::dot(o, d);
  const earth::Vec3 tangent = t_tangent > 0 ? o + t_tangent * d : o;
  const double h = glm::length(tangent) - earth::radius_m;
  if (h > 100e3) return;
  const earth::Vec3 up = glm::normalize(tangent);
  const earth::Geodetic g = earth::geodetic(tangent);
  const EarthView::Place at = c.earth.place(g.lat_deg, g.lon_deg);
  const double mu_sun = glm::dot(c.sun_dir, up);
  const double m = t_tangent > 0 ? 2 * grazing_air_mass(h) : atmosphere::air_mass(std::max(glm::dot(up, d), 0.0));
  const std::size_t nb = c.band_count(), mb = optics::max_band_count;
  // Shell boundaries above the tangent height [m]; the transmittance of the path's part above
  // each: the vertical column's (air mass air_mass(1)) to the power m. The shells from the top
  // down: their lower boundaries' altitudes and their middles' (the top one's, its boundary).
  constexpr std::array<double, 12> above = {0, 1e3, 2e3, 4e3, 7e3, 11e3, 16e3, 22e3, 30e3, 40e3, 55e3, 80e3};
  constexpr std::size_t ns = above.size();
  std::array<double, ns> z, z_mid, temperature;
  for (std::size_t j = 0; j < ns; ++j) {
    const std::size_t k = ns - 1 - j;
    z[j] = h + above[k];
    z_mid[j] = z[j] + 0.5 * (k + 1 < ns ? above[k + 1] - above[k] : 0);
  }
  const double m_path = m * atmosphere::air_mass(1.0), m_sun = atmosphere::air_mass(std::max(mu_sun, 0.02));
  alignas(64) std::array<float, ns * optics::max_band_count> t_view;
  c.earth.view_transmittances(at, z.data(), ns, m_path, t_view.data());
  c.earth.temperature_k(at, z_mid.data(), ns, temperature.data());
  std::array<double, optics::max_band_count> t_prev;
  t_prev.fill(1.0);
  for (std::size_t j = 0; j < ns; ++j)
    for (std::size_t b = 0; b < nb; ++b) {
      const double t = t_view[j * mb + b];
      if (c.tables.bands[b]->thermal)
        out[b] += c.tables.planck[b]->forward(temperature[j]) * std::max(0.0, t_prev[b] - t);
      t_prev[b] = t;
    }
  if (c.sunlit_bands.empty() || mu_sun <= -0.1) return;
  AirSample air;  // the Rayleigh optical depth above the tangent point
  c.earth.air_at_air_masses(at, h, m_path, m_sun, air);
  const double phase = atmosphere::rayleigh_phase(glm::dot(c.sun_dir, d));
  for (std::size_t b = 0; b < nb; ++b) {
    if (!c.tables.bands[b]->sunlit()) continue;
    const double e0 = c.solar_irradiance(b) * std::exp(-air.tau_rayleigh[b] * m_sun);
    out[b] += e0 * phase / (4 * M_PI) * (1 - std::exp(-air.tau_rayleigh[b] * m)) * t_prev[b];
  }
}

// One pixel's cloud layers seen from the sensor down: each layer's radiance and the air's
// between the layers, through the layers in front, with the light the layers reflect between
// each other (the adding method, diffusely: a layer of reflectance R_s and transmittance T_s
// under a stack reflecting R_a back down is seen 1 / (1 - R_a R_s) brighter, passes what lies
// below with T_s / (1 - R_a R_s), and the stack then reflects R_s + T_s^2 R_a / (1 - R_a R_s)).
// Returns the visible optical depth; rad, trans, path_above (the air's radiance above the last
// layer) and refl_above (the stack's reflectance seen from below) are per band.
float composite_layers(const RenderContext& c, const RowWork& rw, std::size_t x, std::size_t px, const earth::Vec3& d,
                       RenderImage& img, double* rad, double* trans, double* path_above, double* refl_above) {
  const std::size_t ns = rw.ns, nb = c.band_count();
  std::array<std::size_t, weather::cloud_type_count> order{};
  const Layer* pl = &rw.layers[x * ns];
  for (std::size_t s = 0; s < ns; ++s) {  // by distance: insertion into at most four
    std::size_t j = s;
    for (; j > 0 && pl[order[j - 1]].t > pl[s].t; --j) order[j] = order[j - 1];
    order[j] = s;
  }
  for (std::size_t b = 0; b < nb; ++b) rad[b] = 0, trans[b] = 1, path_above[b] = 0, refl_above[b] = 0;
  float tau = 0, clear = 1;  // the share of the pixel no layer covers
  for (std::size_t s = 0; s < ns; ++s) {
    const Layer& L = pl[order[s]];
    const float* const lb = &rw.layer_bands[(x * ns + order[s]) * rw.lbf];
    if (!std::isfinite(L.t)) break;
    clear *= 1 - L.coverage;
    if (c.params.cloud_fields) img.cloud_fraction[px] = 1 - clear;
    if (c.params.cloud_fields && s == 0) {
      const earth::Geodetic g = earth::geodetic(c.sensor.position + static_cast<double>(L.t) * d);
      img.cloud_top_altitude_m[px] = L.altitude;
      img.cloud_type[px] = static_cast<std::int8_t>(c.scene.shells[order[s]].type());
      img.latitude_deg[px] = static_cast<float>(g.lat_deg);
      img.longitude_deg[px] = static_cast<float>(g.lon_deg);
    }
    tau += L.tau_vis;
    for (std::size_t b = 0; b < nb; ++b) {  // the air between this layer and the one in front, then the layer
      const double path = lb[2 * nb + b], t_s = lb[nb + b], r_s = lb[3 * nb + b];
      const double between = 1 / (1 - refl_above[b] * r_s);
      rad[b] += trans[b] * (std::max(0.0, path - path_above[b]) + lb[b] * between);
      trans[b] *= t_s * between;
      refl_above[b] = r_s + t_s * t_s * refl_above[b] * between;
      path_above[b] = path;
    }
  }
  return tau;
}

// A band's transmittance of the clouds in front below which what lies behind them is left out
// (< 1e-4 of the ground's radiance); where every band's is, the ground or sky behind is not
// found, nor its shadows looked for: so that whether a band sees the ground does not depend on
// the others.
constexpr double ground_seen_min = 1e-4;

// Row y into the image: each pixel's cloud layers, then what lies behind them, the ground (its
// shadows found for the whole row together) or the sky; then the row's brightness temperatures
// where the image has them, while its radiances are in cache.
void composite_row(const RenderContext& c, int y, RowWork& rw, RenderImage& img) {
  const int w = c.sensor.width;
  const std::size_t nb = c.band_count(), mb = optics::max_band_count;
  auto behind_seen = [nb](const double* trans) {  // some band's clouds pass more than ground_seen_min
    double seen = 0;
    for (std::size_t b = 0; b < nb; ++b) seen = std::max(seen, trans[b]);
    return seen > ground_seen_min;
  };
  auto sunlit_seen = [&c](const double* trans) {
    return std::any_of(c.sunlit_bands.begin(), c.sunlit_bands.end(),
                       [trans](std::size_t b) { return trans[b] > ground_seen_min; });
  };
  rw.clock.start();
  rw.lit.clear(), rw.lit_points.clear();
  for (int x = 0; x < w; ++x) {
    const std::size_t px = static_cast<std::size_t>(y) * w + x;
    const auto xo = static_cast<std::size_t>(x) * mb;
    const float tau = composite_layers(c, rw, static_cast<std::size_t>(x), px, rw.dirs[x], img, &rw.rad[xo],
                                       &rw.trans[xo], &rw.path_above[xo], &rw.refl_above[xo]);
    if (c.params.cloud_fields) img.cloud_optical_depth[px] = tau;
    rw.seen[x] = behind_seen(&rw.trans[xo]);
    // The ground points the Sun lights and that show through the clouds in a band that sees
    // sunlight: their shadows (the other bands do not read them).
    if (!c.shadows || !rw.seen[x] || !std::isfinite(rw.t_earth[x])) continue;
    const earth::Vec3 q = c.sensor.position + static_cast<double>(rw.t_earth[x]) * rw.dirs[x];
    if (sunlit_seen(&rw.trans[xo]) && glm::dot(q, c.sun_dir) > 0) rw.lit.push_back(x), rw.lit_points.push_back(q);
  }
  rw.clock.lap(Stage::layers);
  if (!rw.lit.empty())
    cloud_towards_sun(c, rw.lit_points.data(), rw.lit_points.size(), c.scene.shells.size(), rw.lengths);
  rw.clock.lap(Stage::ground_shadows);
  std::size_t next_lit = 0;
  for (int x = 0; x < w; ++x) {
    const std::size_t px = static_cast<std::size_t>(y) * w + x;
    const auto xo = static_cast<std::size_t>(x) * mb;
    const earth::Vec3& d = rw.dirs[x];
    std::array<double, optics::max_band_count> bg{}, bg_path{}, bg_refl{};
    // What no band sees is left out (below): not found.
    const bool found = rw.seen[x] != 0;
    if (found && std::isfinite(rw.t_earth[x])) {
      const earth::Vec3 q = c.sensor.position + static_cast<double>(rw.t_earth[x]) * d;
      const earth::Geodetic g = earth::geodetic(q);
      if (c.params.cloud_fields && !(img.cloud_fraction[px] > 0)) {
        img.latitude_deg[px] = static_cast<float>(g.lat_deg);
        img.longitude_deg[px] = static_cast<float>(g.lon_deg);
      }
      const bool shadowed = next_lit < rw.lit.size() && rw.lit[next_lit] == x;
      ground_radiance(c, g, q / glm::length(q), d, shadowed ? &rw.lengths[next_lit] : nullptr, bg, bg_path, bg_refl);
      next_lit += shadowed;
    } else if (found) {
      sky_radiance(c, d, bg);
    }
    for (std::size_t b = 0; b < nb; ++b) {  // the ground, as a layer of T = 0 under the clouds
      const double behind =
          std::max(0.0, bg_path[b] - rw.path_above[xo + b]) + bg[b] / (1 - rw.refl_above[xo + b] * bg_refl[b]);
      img.radiance[b][px] =
          static_cast<float>(rw.rad[xo + b] + (rw.trans[xo + b] > ground_seen_min ? rw.trans[xo + b] * behind : 0.0));
    }
  }
  rw.clock.lap(Stage::ground_and_sky);
  const std::size_t row0 = static_cast<std::size_t>(y) * w;
  for (std::size_t b = 0; b < nb; ++b)
    if (!img.brightness_temperature[b].empty())
      c.tables.planck[b]->inverse(&img.radiance[b][row0], static_cast<std::size_t>(w),
                                  &img.brightness_temperature[b][row0]);
  rw.clock.lap(Stage::brightness_temperatures);
}

// An image of w x h pixels with its radiances allocated, the thermal bands' brightness
// temperatures where `temperatures` and the cloud fields (clear sky) where `cloud_fields`. Its
// arrays (3 GB for a 2 km ABI full disc in ten bands) are allocated and first touched one a
// thread at a time: the page faults of fresh memory, not the zeroing, set the pace (0.5-0.8 GB
// s^-1 a thread on the test VM, by the hour: docs/PERFORMANCE.md).
RenderImage blank_image(int w, int h, const BandTables& tables, const std::vector<std::string>& bands,
                        bool temperatures, bool cloud_fields) {
  const std::size_t npx = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  RenderImage img;
  img.width = w;
  img.height = h;
  img.bands = bands;
  img.radiance.resize(bands.size());
  img.brightness_temperature.assign(bands.size(), {});
  const std::array<std::vector<float>*, 5> fields = {&img.cloud_top_altitude_m, &img.cloud_optical_depth,
                                                     &img.cloud_fraction, &img.latitude_deg, &img.longitude_deg};
  const std::array<float, 5> clear = {nanf, 0.0f, 0.0f, nanf, nanf};
  const std::size_t nb = bands.size(), jobs = 2 * nb + fields.size() + 1;
#pragma omp parallel for schedule(dynamic, 1)
  for (std::size_t j = 0; j < jobs; ++j) {
    if (j < nb)
      img.radiance[j].assign(npx, 0.0f);
    else if (j < 2 * nb) {
      if (temperatures && tables.bands[j - nb]->thermal) img.brightness_temperature[j - nb].assign(npx, 0.0f);
    } else if (!cloud_fields)
      continue;
    else if (j < 2 * nb + fields.size())
      fields[j - 2 * nb]->assign(npx, clear[j - 2 * nb]);
    else
      img.cloud_type.assign(npx, -1);
  }
  return img;
}

// One ray per pixel, through the point sub.offset(x, y) of pixel (x, y); radiances, and the
// thermal bands' brightness temperatures where `temperatures` (a sub-pixel image has none:
// render() converts the mean radiances). Each row is traced in every cloud type, then
// composited, by one thread; rows are handed out one at a time.
RenderImage render_at(const clouds::CloudScene& scene, const Sensor& sensor, const earth::SunPosition& sun,
                      const RenderParams& params, const weather::WeatherGrid* weather, const BandTables& tables,
                      const SubPixel& sub, const EarthView& earth_view, bool temperatures, Progress& progress) {
  const RenderContext c(scene, sensor, sun, params, weather, tables, sub, earth_view);
  const auto t_outputs = std::chrono::steady_clock::now();
  RenderImage img = blank_image(sensor.width, sensor.height, tables, params.bands, temperatures, params.cloud_fields);
  img.seconds_outputs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_outputs).count();
  const std::size_t ns = scene.shells.size();
  std::vector<double> seconds(ns, 0.0);
  std::array<double, static_cast<std::size_t>(Stage::count)> stage_seconds{};
  std::vector<std::uint64_t> marched(ns, 0);  // integer sums: the same whatever the thread count
  int threads = 0;
#pragma omp parallel
  {
    RowWork rw(c);
    std::vector<double> my_seconds(ns, 0.0);
    std::vector<std::uint64_t> my_marched(ns, 0);
#pragma omp for schedule(dynamic, 1)
    for (int y = 0; y < sensor.height; ++y) {
      begin_row(c, y, rw);
      for (std::size_t si = 0; si < ns; ++si) {  // each type timed
        const auto t0 = std::chrono::steady_clock::now();
        my_marched[si] += trace_row(c, si, rw);
        my_seconds[si] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        progress.advance();
      }
      composite_row(c, y, rw, img);
    }
#pragma omp critical
    {
      ++threads;
      for (std::size_t si = 0; si < ns; ++si) seconds[si] += my_seconds[si], marched[si] += my_marched[si];
      for (std::size_t k = 0; k < stage_seconds.size(); ++k) stage_seconds[k] += rw.clock.seconds[k];
    }
  }
  for (std::size_t si = 0; si < ns; ++si) {  // a type's time: its threads' time over their count
    img.seconds_per_type.emplace_back(weather::name(scene.shells[si].type()), seconds[si] / threads);
    img.marched_rays_per_type.push_back(marched[si]);
  }
  for (std::size_t k = 0; k < stage_seconds.size(); ++k)
    img.seconds_per_stage.emplace_back(render_stage_names()[k], stage_seconds[k] / threads);
  return img;
}

// The brightness temperature of each thermal band's radiance (the inverse band-mean Planck), for
// the mean of sub-pixel images (a one-ray image's are found a row at a time: composite_row()).
void add_brightness_temperatures(RenderImage& img, const BandTables& tables) {
  // Allocated and first touched a band a thread at a time (blank_image()).
  const auto nb = static_cast<std::ptrdiff_t>(tables.bands.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t b = 0; b < nb; ++b)
    if (tables.bands[static_cast<std::size_t>(b)]->thermal)
      img.brightness_temperature[static_cast<std::size_t>(b)].resize(img.radiance[static_cast<std::size_t>(b)].size());
  for (std::size_t b = 0; b < tables.bands.size(); ++b) {
    if (!tables.bands[b]->thermal) continue;
    const std::vector<float>& radiance = img.radiance[b];
    std::vector<float>& bt = img.brightness_temperature[b];
    constexpr std::size_t piece = 4096;  // pixels per piece of work
    const std::size_t pieces = (radiance.size() + piece - 1) / piece;
#pragma omp parallel for schedule(static)
    for (std::size_t k = 0; k < pieces; ++k) {
      const std::size_t p0 = k * piece;
      tables.planck[b]->inverse(&radiance[p0], std::min(piece, radiance.size() - p0), &bt[p0]);
    }
  }
}

}  // namespace

void RenderParams::set_steps(int n, const std::string& key) {
  if (n < 1 || n > 10000) throw ValueError("must be 1..10000", {.key = key});
  steps = n;
}

void RenderParams::set_bands(const std::vector<std::string>& names, const std::string& key) {
  if (names.empty()) throw ValueError("no band: at least one of " + optics::band_names() + ", or all", {.key = key});
  if (names.size() == 1 && names[0] == "all") {
    bands.clear();
    for (const optics::Band& b : optics::bands()) bands.push_back(b.name);
    return;
  }
  std::vector<std::string> canonical;  // ABI channel names ("C13") as the band's own ("lwir")
  for (const std::string& name : names) {
    try {
      canonical.push_back(optics::band(name).name);
    } catch (const ValueError& e) {
      throw ValueError(e.message() + (name == "all" ? " ('all' stands alone)" : ""), {.key = key});
    }
    for (std::size_t j = 0; j + 1 < canonical.size(); ++j)
      if (canonical.back() == canonical[j])
        throw ValueError("'" + name + "' is listed twice (" + canonical[j] + ")", {.key = key});
  }
  bands = canonical;
}

void RenderParams::set_rays_per_pixel(int rays, const std::string& key) {
  const int k = static_cast<int>(std::lround(std::sqrt(std::max(rays, 0))));
  if (rays < 1 || rays > 256 || k * k != rays)
    throw ValueError(fmt::format("must be a square number of rays per pixel (1, 4, 9, ... 256), got {}", rays),
                     {.key = key});
  samples_per_axis = k;
}

void brightness_temperatures(const optics::Band& band, const float* radiance, std::size_t n, float* out) {
  if (!band.thermal) throw ValueError("'" + band.name + "' is not a thermal band", {.key = "bands"});
  planck_table(band).inverse(radiance, n, out);
}

const std::vector<std::string>& render_stage_names() {
  static const std::vector<std::string> names(stage_names.begin(), stage_names.end());
  return names;
}

double render_memory_bytes(int width, int height, const RenderParams& params) {
  double per_pixel = params.cloud_fields ? 4 + 4 + 1 + 4 + 8 : 0;  // cloud top, optical depth, type, fraction, lat/lon
  for (const auto& name : params.bands)
    per_pixel += optics::band(name).thermal && params.brightness_temperatures ? 8 : 4;
  if (params.samples_per_axis > 1) {
    const double nb = static_cast<double>(params.bands.size());
    // The sums (radiances; optical depth, cloud top, fraction, cloudy rays, types) and one sub-pixel image.
    const double fields = params.cloud_fields ? 1 : 0;
    per_pixel += 8 * nb + fields * (8 + 8 + 8 + 2 + 8) + 4 * nb + fields * 21;
  }
  // Each thread's row (RowWork): per pixel a layer per type, the ray, its hit and the compositing's sums.
  const double nbd = static_cast<double>(params.bands.size());
  const double row_per_pixel = weather::cloud_type_count * (sizeof(Layer) + 16 * nbd) + sizeof(ShellHit) +
                               sizeof(earth::Vec3) + 17 + 4 * sizeof(double) * optics::max_band_count;
  return per_pixel * width * height + thread_count() * row_per_pixel * width;
}

RenderImage render(const clouds::CloudScene& scene, const Sensor& sensor, const earth::SunPosition& sun,
                   const RenderParams& params, const weather::WeatherGrid* weather) {
  if (scene.shells.empty()) throw ValueError("the scene has no cloud shell to render", {.key = "types"});
  const int k = params.samples_per_axis;
  if (k < 1 || k > 16)
    throw ValueError(fmt::format("samples per pixel must be k^2 with k = 1..16, got k = {}", k), {.key = "samples"});
  Progress progress("render", static_cast<std::size_t>(sensor.height) * scene.shells.size() *
                                  static_cast<std::size_t>(k) * static_cast<std::size_t>(k));
  const BandTables tables(params.bands);
  const EarthView earth_view(weather, sensor, sun, tables.bands, params.atmosphere, params.surface_temperature_k,
                             scene.condensate_layer_m);
  if (k == 1) {
    RenderImage img = render_at(scene, sensor, sun, params, weather, tables, SubPixel{}, earth_view,
                                params.brightness_temperatures, progress);
    img.seconds_atmosphere = earth_view.seconds_to_build();
    return img;
  }
  // k x k sub-pixel rays per pixel, one whole image each, summed in a fixed order (the result
  // does not depend on the thread count).
  const std::size_t npx = static_cast<std::size_t>(sensor.width) * static_cast<std::size_t>(sensor.height);
  const std::size_t nb = params.bands.size();
  std::vector<std::vector<double>> radiance(nb, std::vector<double>(npx, 0.0));
  const bool fields = params.cloud_fields;
  const std::size_t nf = fields ? npx : 0;
  std::vector<double> tau(nf, 0.0), top(nf, 0.0), fraction(nf, 0.0);
  std::vector<std::uint16_t> cloudy(nf, 0);
  std::vector<std::array<std::uint16_t, weather::cloud_type_count>> type_count(nf);
  RenderImage img;
  const int centre = k / 2;  // the sub-pixel nearest the centre (the centre for odd k)
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      RenderImage sub =
          render_at(scene, sensor, sun, params, weather, tables,
                    SubPixel{i, j, k, params.stratified_samples, params.sample_seed}, earth_view, false, progress);
#pragma omp parallel for schedule(static)
      for (std::size_t px = 0; px < npx; ++px) {
        for (std::size_t b = 0; b < nb; ++b) radiance[b][px] += sub.radiance[b][px];
        if (!fields) continue;
        tau[px] += sub.cloud_optical_depth[px];
        fraction[px] += sub.cloud_fraction[px];
        const std::int8_t t = sub.cloud_type[px];
        if (t >= 0) {
          ++cloudy[px];
          top[px] += sub.cloud_top_altitude_m[px];
          ++type_count[px][static_cast<std::size_t>(t)];
        }
      }
      if (i == centre && j == centre) {
        img.latitude_deg = std::move(sub.latitude_deg);
        img.longitude_deg = std::move(sub.longitude_deg);
      }
      if (img.seconds_per_type.empty()) {
        img.seconds_per_type = sub.seconds_per_type;
        img.marched_rays_per_type = sub.marched_rays_per_type;
        img.seconds_per_stage = sub.seconds_per_stage;
      } else {
        for (std::size_t t = 0; t < img.seconds_per_type.size(); ++t) {
          img.seconds_per_type[t].second += sub.seconds_per_type[t].second;
          img.marched_rays_per_type[t] += sub.marched_rays_per_type[t];
        }
        for (std::size_t st = 0; st < img.seconds_per_stage.size(); ++st)
          img.seconds_per_stage[st].second += sub.seconds_per_stage[st].second;
      }
      img.seconds_outputs += sub.seconds_outputs;
    }
  const double inv_n = 1.0 / (k * k);
  img.seconds_atmosphere = earth_view.seconds_to_build();
  img.width = sensor.width;
  img.height = sensor.height;
  img.bands = params.bands;
  img.radiance.assign(nb, std::vector<float>(npx));
  img.brightness_temperature.assign(nb, {});
  img.cloud_top_altitude_m.assign(nf, nanf);
  img.cloud_optical_depth.resize(nf);
  img.cloud_type.assign(nf, -1);
  img.cloud_fraction.resize(nf);
  for (std::size_t b = 0; b < nb; ++b)
#pragma omp parallel for schedule(static)
    for (std::size_t px = 0; px < npx; ++px) img.radiance[b][px] = static_cast<float>(radiance[b][px] * inv_n);
  if (params.brightness_temperatures) add_brightness_temperatures(img, tables);
#pragma omp parallel for schedule(static)
  for (std::size_t px = 0; px < nf; ++px) {
    img.cloud_optical_depth[px] = static_cast<float>(tau[px] * inv_n);
    img.cloud_fraction[px] = static_cast<float>(fraction[px] * inv_n);
    if (cloudy[px] == 0) continue;
    img.cloud_top_altitude_m[px] = static_cast<float>(top[px] / cloudy[px]);
    const auto& c = type_count[px];
    img.cloud_type[px] = static_cast<std::int8_t>(std::max_element(c.begin(), c.end()) - c.begin());
  }
  return img;
}

}  // namespace nephos::render
