#include "nephos/render/shadows.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace nephos::render {

void cloud_length_towards(const clouds::CloudShell& shell, const earth::Vec3* o, const earth::Vec3& d, std::size_t n,
                          int steps, double* out, const double* footprint_m, double* chance) {
  thread_local std::vector<double> t0, t1, s0, s1, px, py, pz, vals, fp, lo, hi, r2_lo, r2_hi;
  thread_local std::vector<clouds::PathCoverage> paths;
  thread_local std::vector<std::uint32_t> live, first, cloudy;
  thread_local std::vector<earth::Vec3> pts;
  t0.resize(n), t1.resize(n);
  const double r_top = shell.radius_top_m(), r_bottom = shell.radius_bottom_m();
  // Each ray's path inside the shell: from where it leaves the inner sphere (or its origin) to
  // where it leaves the outer one. Rays from above the shell see none of it.
  for (std::size_t i = 0; i < n; ++i) {
    const double b = glm::dot(o[i], d), oo = glm::dot(o[i], o[i]);
    t0[i] = t1[i] = 0;
    if (oo >= r_top * r_top) continue;
    t1[i] = -b + std::sqrt(std::max(0.0, b * b - (oo - r_top * r_top)));
    const double c = oo - r_bottom * r_bottom;
    t0[i] = c < 0 ? -b + std::sqrt(std::max(0.0, b * b - c)) : 0.0;
    if (t0[i] >= t1[i]) t0[i] = t1[i] = 0;
  }
  // Empty-space skip: the altitude window (CloudShell::altitude_window) at the path's two ends
  // and between them, one lookup per skip radius of arc (the points as they are: a cube map's
  // lookup needs no unit vector); the path's window is the widest of them. First each path's
  // count m of segments and where its m + 1 points go, then the points.
  live.clear(), first.resize(n + 1);
  std::size_t np = 0;
  for (std::size_t i = 0; i < n; ++i) {
    first[i] = static_cast<std::uint32_t>(np);
    if (t1[i] <= t0[i]) continue;
    const earth::Vec3 a = o[i] + t0[i] * d, e = o[i] + t1[i] * d;
    const double arc = glm::length(glm::normalize(e) - glm::normalize(a));
    np += 2 + static_cast<std::size_t>(std::min(arc / shell.skip_radius_rad(), 64.0));
  }
  first[n] = static_cast<std::uint32_t>(np);
  px.resize(np), py.resize(np), pz.resize(np), lo.resize(np), hi.resize(np);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t k0 = first[i], count = first[i + 1] - k0;  // m + 1 points, or none
    if (count == 0) continue;
    const double step = (t1[i] - t0[i]) / static_cast<double>(count - 1);
    for (std::uint32_t k = 0; k < count; ++k) {
      const double t = t0[i] + step * k;
      px[k0 + k] = o[i].x + t * d.x, py[k0 + k] = o[i].y + t * d.y, pz[k0 + k] = o[i].z + t * d.z;
    }
  }
  shell.altitude_window(px.data(), py.data(), pz.data(), np, lo.data(), hi.data());
  r2_lo.clear(), r2_hi.clear(), s0.clear(), s1.clear();
  for (std::size_t i = 0; i < n; ++i) {
    out[i] = 0;
    if (chance) chance[i] = 0;
    if (first[i + 1] == first[i]) continue;
    const double z_lo = *std::min_element(lo.data() + first[i], lo.data() + first[i + 1]);
    const double z_hi = *std::max_element(hi.data() + first[i], hi.data() + first[i + 1]);
    if (!(z_lo <= z_hi)) continue;
    const auto [lo2, hi2] = clouds::window_squared_radii(z_lo, z_hi);
    // The steps go where the window lets cloud be: on a ray that climbs (o.d >= 0, every ray
    // towards the Sun from a lit point), the part of its path between the window's radii. A
    // path that never enters it meets no cloud.
    double ta = t0[i], tb = t1[i];
    const double b = glm::dot(o[i], d), oo = glm::dot(o[i], o[i]);
    if (b >= 0) {
      auto t_at_r2 = [&](double r2) { return oo >= r2 ? 0.0 : -b + std::sqrt(b * b + (r2 - oo)); };
      ta = std::max(ta, t_at_r2(lo2)), tb = std::min(tb, t_at_r2(hi2));
      if (!(ta < tb)) continue;
    }
    live.push_back(static_cast<std::uint32_t>(i));
    r2_lo.push_back(lo2), r2_hi.push_back(hi2), s0.push_back(ta), s1.push_back(tb);
  }
  // The march: every live ray's step midpoints, classified together, step by step. Filtered,
  // only those in their ray's window: outside it they are u_min.
  const std::size_t nl = live.size();
  pts.resize(nl), vals.resize(nl);
  if (footprint_m) {
    fp.resize(nl), paths.resize(nl);
    for (std::size_t j = 0; j < nl; ++j) {
      fp[j] = footprint_m[live[j]];
      paths[j] = clouds::PathCoverage(fp[j], t1[live[j]] - t0[live[j]]);
    }
  }
  const double thr = shell.threshold();
  cloudy.resize(nl);
  for (int k = 0; k < steps; ++k) {
    const double mid = (k + 0.5) / steps;  // the step's midpoint, as a share of the path
    for (std::size_t j = 0; j < nl; ++j) pts[j] = o[live[j]] + (s0[j] + (s1[j] - s0[j]) * mid) * d;
    if (footprint_m) {  // the expected length: each step's share of cloud, coverage(u)
      clouds::classify_filtered_in_windows(shell, pts.data(), fp.data(), r2_lo.data(), r2_hi.data(), nl, vals.data());
      const std::size_t nc = clouds::steps_with_cover(shell, vals.data(), nl, cloudy.data());
      for (std::size_t c = 0; c < nc; ++c) {
        const std::uint32_t j = cloudy[c];
        const double ds = (s1[j] - s0[j]) / steps;
        out[live[j]] += ds * paths[j].add(shell, vals[j], ds);
      }
      continue;
    }
    shell.classify(pts.data(), nl, vals.data());
    for (std::size_t j = 0; j < nl; ++j)
      if (vals[j] > thr) out[live[j]] += (s1[j] - s0[j]) / steps;
  }
  if (!chance) return;
  // The chance of meeting cloud: 0 or 1 for a point sample; filtered, as the view rays' (the
  // likeliest step's coverage, or more where the detail decorrelates along the path).
  for (std::size_t j = 0; j < nl; ++j) {
    const std::uint32_t i = live[j];
    chance[i] = footprint_m ? paths[j].chance() : (out[i] > 0 ? 1.0 : 0.0);
  }
}

}  // namespace nephos::render
