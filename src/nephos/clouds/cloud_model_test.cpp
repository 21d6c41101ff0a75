#include "nephos/clouds/cloud_model.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"

namespace nephos::clouds {
namespace {

std::shared_ptr<const FractalTextures> small_textures() {
  static auto t = std::make_shared<const FractalTextures>(
      FractalTextures::from(noise::bake({noise::FractalKind::perlin, 4, 3, 0.5, false}, 1, 32),
                            noise::bake({noise::FractalKind::perlin, 4, 3, 0.5, false}, 2, 32),
                            noise::bake({noise::FractalKind::worley, 4, 2, 0.5, true}, 3, 32)));
  return t;
}

CloudShell shell_with_mask(float mask, CloudTypeParams p = CloudModelParams()[CloudType::low_stratus]) {
  auto cube = std::make_shared<CubeMap<float>>(4);
  for (auto& v : cube->data()) v = mask;
  return CloudShell(CloudType::low_stratus, p, small_textures(), cube, std::vector<DisplacementMap>(4));
}

// Fraction of cloudy points (CF > threshold) on the mid-shell sphere.
double cloudy_fraction(const CloudShell& s) {
  const double r = earth::radius_m + 0.5 * (s.params().shell_bottom_m + s.params().shell_top_m);
  int cloudy = 0;
  constexpr int n = 20000;
  for (int i = 0; i < n; ++i) {
    const double z = 2 * uniform01(5, static_cast<std::uint64_t>(i), 0) - 1,
                 phi = 2 * M_PI * uniform01(5, static_cast<std::uint64_t>(i), 1);
    const earth::Vec3 d{std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z};
    cloudy += s.value(d * r) > s.threshold();
  }
  return static_cast<double>(cloudy) / n;
}

}  // namespace

// Share of vertical columns (radial lines at hashed directions) in which CF exceeds the
// threshold somewhere: the cloud cover seen from above. Sampled every 25 m from two bottom
// length scales below the (lifted) shell to two top ones above it.
double column_cover(const CloudShell& s, double lift = 0, int n = 4000) {
  const CloudTypeParams& p = s.params();
  const double z0 = p.shell_bottom_m + std::max(lift, -p.shell_bottom_m) - 2 * p.altitude_length_bottom_m;
  const double z1 = p.shell_top_m + lift + 2 * p.altitude_length_top_m;
  const int levels = static_cast<int>((z1 - z0) / 25) + 1;
  std::vector<earth::Vec3> pts(static_cast<std::size_t>(levels));
  std::vector<double> v(pts.size());
  int cloudy = 0;
  for (int i = 0; i < n; ++i) {
    const double z = 2 * uniform01(6, static_cast<std::uint64_t>(i), 0) - 1,
                 phi = 2 * M_PI * uniform01(6, static_cast<std::uint64_t>(i), 1);
    const earth::Vec3 d{std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z};
    for (int k = 0; k < levels; ++k) pts[static_cast<std::size_t>(k)] = d * (earth::radius_m + z0 + 25.0 * k);
    s.classify(pts.data(), pts.size(), v.data());
    cloudy += std::any_of(v.begin(), v.end(), [&](double x) { return x > s.threshold(); });
  }
  return static_cast<double>(cloudy) / n;
}

TEST(CloudShell, CalibratedMaskIsTheCoverSeenFromAbove) {
  // A mask is a cloud fraction, the projected cover of the column (the weather masks' maximum-
  // random overlap over the type's band, GFS's cloud cover), so a uniform mask m must give a
  // share m of vertical columns with cloud somewhere in them, for every m, barriers included.
  // 4000 columns: binomial standard error <= 0.008; the calibration's 16 384-column quantiles
  // add <= 0.004; its columns are sampled at 48 heights, these at 25 m, which finds a few more
  // cloudy columns (measured -0.01 to +0.02): bound 0.035. Fault caught: the calibration on the
  // mid-shell sphere's points, as before (0.5 gave 0.56, 0.75 gave 0.81).
  for (float m : {0.05f, 0.1f, 0.25f, 0.5f, 0.75f, 0.9f, 0.95f}) {
    const double f = column_cover(shell_with_mask(m));
    std::printf("mask %.2f: cover %.4f\n", m, f);
    EXPECT_NEAR(f, m, 0.035) << "mask " << m;
  }
  EXPECT_EQ(column_cover(shell_with_mask(0.0f), 0, 200), 0.0);  // below min_mask: clear sky
}

TEST(CloudShell, AShellTheWeatherThinsOnTheGroundKeepsItsCover) {
  // Lowered by the weather below its own base (cloud_top_lifts(): up to half its depth), a shell
  // on the ground only thins from the top, and its calibration (per squeeze class, linear
  // between them) keeps the cover its mask gives: low cumulus (0-6000 m) lowered by 1000 m (between
  // classes) and 2800 m, same bound as above. Fault caught: one calibration for every lift
  // (0.5 gave 0.35 at 1000 m, 0.03 at 2800 m).
  CloudTypeParams p = CloudModelParams()[CloudType::low_cumulus];
  for (double lift : {-1000.0, -2800.0})
    for (float m : {0.25f, 0.5f, 0.9f}) {
      auto cube = std::make_shared<CubeMap<float>>(4), lifts = std::make_shared<CubeMap<float>>(4);
      for (auto& v : cube->data()) v = m;
      for (auto& v : lifts->data()) v = static_cast<float>(lift);
      CloudShell s(CloudType::low_cumulus, p, small_textures(), cube, std::vector<DisplacementMap>(4));
      s.set_lift(lifts);
      const double f = column_cover(s, lift);
      std::printf("lift %.0f m, mask %.2f: cover %.4f\n", lift, m, f);
      EXPECT_NEAR(f, m, 0.035) << "lift " << lift << " mask " << m;
    }
}

namespace {

// Of n points of shell s at random directions, altitudes from 500 m below its bottom to 500 m
// above its top and footprints from 1 m to 50 km: how many lie outside their altitude window,
// and how many of those are cloud, filtered (u > u_min) or point-sampled (CF > threshold).
struct WindowCount {
  std::size_t outside = 0, filtered = 0, point = 0;
};
WindowCount count_outside_windows(const CloudShell& s, std::size_t n) {
  std::vector<earth::Vec3> pts(n);
  std::vector<double> fp(n), u(n), cf(n), lo(n), hi(n), x(n), y(n), z(n);
  const double r0 = s.radius_bottom_m() - 500, r1 = s.radius_top_m() + 500;
  for (std::size_t i = 0; i < n; ++i) {
    const double zz = 2 * uniform01(22, i, 0) - 1, phi = 2 * M_PI * uniform01(22, i, 1);
    const earth::Vec3 d{std::sqrt(1 - zz * zz) * std::cos(phi), std::sqrt(1 - zz * zz) * std::sin(phi), zz};
    pts[i] = d * (r0 + (r1 - r0) * uniform01(22, i, 2));
    fp[i] = std::pow(5e4, uniform01(22, i, 3));
    x[i] = pts[i].x, y[i] = pts[i].y, z[i] = pts[i].z;
  }
  s.classify_filtered(pts.data(), fp.data(), n, u.data());
  s.value(pts.data(), n, cf.data());
  s.altitude_window(x.data(), y.data(), z.data(), n, lo.data(), hi.data());
  WindowCount c;
  for (std::size_t i = 0; i < n; ++i) {
    const double alt = glm::length(pts[i]) - earth::radius_m;
    if (alt >= lo[i] && alt <= hi[i]) continue;
    ++c.outside;
    c.filtered += u[i] > s.u_min();
    c.point += cf[i] > s.threshold();
  }
  return c;
}

}  // namespace

TEST(CloudShell, NoCloudLiesOutsideItsAltitudeWindow) {
  // The empty-space skip leaves out every point outside altitude_window(): it must hold every
  // point where the filtered function is above u_min() or CF above the threshold. Exact: no
  // tolerance (the window's 10 m margin is for float rounding). 200 000 points each
  // (count_outside_windows) of a low-cumulus shell:
  //  - under a uniform mask and lift, where each point's window is its own and the cloud
  //    reaches close to its edges (fault caught: the budget with half the largest fractal sum,
  //    126 points of filtered cloud outside);
  //  - under a mask and a lift that change from texel to texel (random values on a 64^2 cube
  //    map, ~150 km texels, -1500 to 3500 m: the skip map's 20 km texels see them vary).
  // The windows must also leave out much of the shell's height (> 20 % of the points; 27 and
  // 36 % measured), or they would skip nothing.
  const CloudTypeParams p = CloudModelParams()[CloudType::low_cumulus];
  auto uniform = std::make_shared<CubeMap<float>>(4), uniform_lift = std::make_shared<CubeMap<float>>(4);
  for (auto& v : uniform->data()) v = 0.95f;
  for (auto& v : uniform_lift->data()) v = 1000.0f;
  auto varied = std::make_shared<CubeMap<float>>(64), varied_lift = std::make_shared<CubeMap<float>>(64);
  for (std::size_t i = 0; i < varied->data().size(); ++i) {
    varied->data()[i] = static_cast<float>(uniform01(21, i, 0));
    varied_lift->data()[i] = static_cast<float>(-1500 + 5000 * uniform01(21, i, 1));
  }
  for (const auto& [mask, lift] : {std::pair{uniform, uniform_lift}, std::pair{varied, varied_lift}}) {
    const CloudShell s(CloudType::low_cumulus, p, small_textures(), mask, std::vector<DisplacementMap>(4), lift);
    constexpr std::size_t n = 200000;
    const WindowCount c = count_outside_windows(s, n);
    std::printf("mask texels %d: outside their window %zu of %zu points; of them cloud: %zu filtered, %zu point\n",
                mask->size(), c.outside, n, c.filtered, c.point);
    EXPECT_EQ(c.filtered, 0u);
    EXPECT_EQ(c.point, 0u);
    EXPECT_GT(c.outside, n / 5);
  }
}

// A point on the mid-shell sphere, hashed from i.
earth::Vec3 mid_shell_point(const CloudShell& s, std::uint64_t i) {
  const double r = earth::radius_m + 0.5 * (s.params().shell_bottom_m + s.params().shell_top_m);
  const double z = 2 * uniform01(11, i, 0) - 1, phi = 2 * M_PI * uniform01(11, i, 1);
  return earth::Vec3{std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z} * r;
}

TEST(CloudShell, AFootprintWiderThanEveryTileCoversTheShareOfCloudyPoints) {
  // Filtered over a footprint far wider than every texture tile, the cloud function keeps only
  // its mask term and the fractal sum's mean, and the share of the footprint in cloud must be
  // the share of point samples in cloud on the same sphere (counted at 20 000 points, barriers
  // off). At every point alike (no fractal detail left): within 0.015, the count's binomial
  // error (<= 0.0035) and the coverage table's sampling error (32 768 samples: <= 0.003) with
  // margin. Fault caught: the exceedance read the wrong way round, P(Z < u) for P(Z > -u)
  // (mask 0.1 fails). A normal distribution in place of the table passes here: these small
  // textures' sum is near normal.
  CloudTypeParams p = CloudModelParams()[CloudType::low_stratus];
  p.altitude_scale = 0;
  const std::vector<double> wide(64, 1e9);
  for (float m : {0.1f, 0.25f, 0.5f, 0.75f, 0.95f}) {
    const CloudShell s = shell_with_mask(m, p);
    const double share = cloudy_fraction(s);
    std::vector<earth::Vec3> pts(64);
    for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = mid_shell_point(s, i);
    std::vector<double> u(pts.size());
    s.classify_filtered(pts.data(), wide.data(), pts.size(), u.data());
    for (std::size_t i = 0; i < pts.size(); ++i)
      ASSERT_NEAR(s.coverage(u[i]), share, 0.015) << "mask " << m << " point " << i;
  }
}

TEST(CloudShell, FilteredCoverageIsTheFootprintsShareOfCloudyPoints) {
  // What anti-aliasing must give: at a point seen with a footprint of width w, the share of the
  // w^3 cube around it that is cloud, here counted from 256 point samples (classify(), the
  // unfiltered function) at hashed positions in the cube. Over 300 points of the mid-shell
  // sphere and widths from 16 fine voxels to half a coarse tile: the RMS difference of
  // coverage() from that share must be under 0.6 of the point sample's own (its 0/1 against the
  // share: the aliasing; measured 0.41, 0.46, 0.15 of it), and their means within 0.05 (the
  // sub-pixel detail's distribution is the whole fractal sum's shape scaled, an approximation
  // where part of the detail is resolved; the shares' own standard error is <= 0.03 per point,
  // 0.002 over 300). Faults caught: sigma from var(level) instead of var(0) - var(level); the
  // levels one coarser than the footprint.
  auto cube = std::make_shared<CubeMap<float>>(16);
  cube->fill([](const earth::Vec3& d) { return static_cast<float>(0.5 + 0.45 * d.z); });
  CloudTypeParams p = CloudModelParams()[CloudType::low_stratus];
  p.altitude_scale = 0;
  const CloudShell s(CloudType::low_stratus, p, small_textures(), cube, std::vector<DisplacementMap>(4));
  const double coarse_tile = p.fractals[0].length_scale_m, fine_voxel = p.fractals[1].length_scale_m / 32;
  for (double width : {16 * fine_voxel, coarse_tile / 8, coarse_tile / 2}) {
    constexpr int n = 300, m = 256;
    std::vector<earth::Vec3> pts(n), cloud_pts(static_cast<std::size_t>(n) * m);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      pts[i] = mid_shell_point(s, i);
      for (std::size_t k = 0; k < m; ++k)
        cloud_pts[i * m + k] = pts[i] + width * earth::Vec3{uniform01(12, i, k, 0) - 0.5, uniform01(12, i, k, 1) - 0.5,
                                                            uniform01(12, i, k, 2) - 0.5};
    }
    std::vector<double> u(n), c(cloud_pts.size()), at(n);
    const std::vector<double> footprint(n, width);
    s.classify_filtered(pts.data(), footprint.data(), n, u.data());
    s.classify(cloud_pts.data(), cloud_pts.size(), c.data());
    s.classify(pts.data(), n, at.data());
    double se_filtered = 0, se_point = 0, mean_filtered = 0, mean_share = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      double share = 0;
      for (std::size_t k = 0; k < m; ++k) share += (c[i * m + k] > s.threshold()) / static_cast<double>(m);
      const double cover = s.coverage(u[i]), point = at[i] > s.threshold() ? 1.0 : 0.0;
      se_filtered += (cover - share) * (cover - share), se_point += (point - share) * (point - share);
      mean_filtered += cover / n, mean_share += share / n;
    }
    const double rms_filtered = std::sqrt(se_filtered / n), rms_point = std::sqrt(se_point / n);
    std::printf("footprint %8.0f m: RMS against the share, filtered %.3f, point %.3f; means %.3f, %.3f\n", width,
                rms_filtered, rms_point, mean_filtered, mean_share);
    EXPECT_LT(rms_filtered, 0.6 * rms_point) << width;
    EXPECT_NEAR(mean_filtered, mean_share, 0.05) << width;
  }
}

TEST(CloudShell, TheDetailAFootprintAveragesAwayHoldsTheGradientItLoses) {
  // What a filtered normal leaves out: the mean squared gradient of the full cloud function
  // (point samples: the textures' finest voxels) less that of the filtered one, over 2000 points
  // of the mid-shell sphere (a uniform mask, no altitude barriers: only the fractals vary),
  // against detail_gradient_variance(). The table sums squared differences of neighbouring
  // voxels; inside a voxel the interpolant's gradient is a bilinear mean of four of them, whose
  // square is smaller: from (2/3)^2 of theirs (independent differences) to all of it (equal). So
  // the table may exceed the measurement up to 2.25x; below it only by the sampling error (~5 %
  // over 2000 points): bounds 0.9 and 2.25. Measured 1.15, 1.15, 1.16; fault caught: every
  // level's gradient taken per level-0 voxel (ratio -0.69 at 3 km).
  auto cube = std::make_shared<CubeMap<float>>(4);
  for (auto& v : cube->data()) v = 0.6f;
  CloudTypeParams p = CloudModelParams()[CloudType::low_stratus];
  p.altitude_scale = 0;
  const CloudShell s(CloudType::low_stratus, p, small_textures(), cube, std::vector<DisplacementMap>(4));
  const double coarse_tile = p.fractals[0].length_scale_m, fine_voxel = p.fractals[1].length_scale_m / 32;
  constexpr std::size_t n = 2000;
  std::vector<earth::Vec3> pts(n), g(n);
  for (std::size_t i = 0; i < n; ++i) pts[i] = mid_shell_point(s, i);
  const double h = 0.25 * fine_voxel;
  auto mean_square = [&](const double* footprint) {
    s.value_and_gradient(pts.data(), n, h, nullptr, g.data(), footprint);
    double sum = 0;
    for (const auto& v : g) sum += glm::dot(v, v) / n;
    return sum;
  };
  const double full = mean_square(nullptr);
  for (double width : {16 * fine_voxel, coarse_tile / 8, coarse_tile / 2}) {
    const std::vector<double> footprint(n, width);
    const double lost = full - mean_square(footprint.data()), table = s.detail_gradient_variance(width);
    std::printf("[ measured ] footprint %8.0f m: squared gradient lost %.4g, table %.4g (ratio %.2f) [1/m^2]\n", width,
                lost, table, table / lost);
    EXPECT_GT(table / lost, 0.9) << width;
    EXPECT_LT(table / lost, 2.25) << width;
  }
}

TEST(CloudShell, AFilteredPathMeetsCloudAsOftenAsItsRaysDo) {
  // What a pixel's cloud fraction must be: the share of the rays through its footprint that meet
  // cloud anywhere along their path, here counted by brute force (200 parallel rays in a w x w
  // bundle, each point-sampled at 300 points with classify()), against PathCoverage of the central
  // ray's 25 filtered steps. Low cumulus (6 km shell, barriers on) at 128^3, masks
  // 0.1/0.3/0.6, footprints 2/8/30 km, vertical and 60 deg slant, 60 places each. The chance
  // is far above any one step's coverage: fine detail renews along the path (mask 0.3: 0.32-0.36
  // vertically, the cover the calibration gives a column; 0.51-0.53 at 60 deg slant). Measured mean |error| 0.045,
  // largest 0.115 (the model's independent tries ignore that the coarse detail is shared along the path: high at mask
  // 0.6). Bounds: mean 0.07, each 0.15. Faults caught: the likeliest step's coverage alone (mean error 0.30, the
  // renderer's first version: pixels 10-15 % short of cloud); the bands' lengths averaged instead of their rates
  // (detail lengths of kilometres: mean error 0.21).
  const auto& defaults = CloudModelParams();
  auto tex = std::make_shared<const FractalTextures>(FractalTextures::from(
      noise::bake(defaults.coarse, 1, 128), noise::bake(defaults.fine, 2, 128), noise::bake(defaults.worley, 3, 128)));
  double sum_error = 0, max_error = 0;
  int configs = 0;
  for (double slant_deg : {0.0, 60.0})
    for (float mask : {0.1f, 0.3f, 0.6f}) {
      auto cube = std::make_shared<CubeMap<float>>(4);
      for (auto& v : cube->data()) v = mask;
      const CloudShell s(CloudType::low_cumulus, CloudModelParams()[CloudType::low_cumulus], tex, cube,
                         std::vector<DisplacementMap>(4));
      const double length = (s.radius_top_m() - s.radius_bottom_m()) / std::cos(slant_deg * earth::deg);
      for (double w : {2000.0, 8000.0, 30000.0}) {
        constexpr int places = 60, rays = 200, fine = 300, coarse = 25;
        double truth = 0, model = 0;
        std::vector<earth::Vec3> pts(fine), q(coarse + 1);
        std::vector<double> v(fine), u(coarse + 1);
        const std::vector<double> footprint(coarse + 1, w);
        for (int li = 0; li < places; ++li) {
          const earth::Vec3 up =
              earth::unit_from_latlon(-60 + 120 * uniform01(5, li, 0), -180 + 360 * uniform01(5, li, 1));
          const earth::Vec3 e1 = glm::normalize(glm::cross(up, earth::Vec3{0, 0, 1})), e2 = glm::cross(up, e1);
          const earth::Vec3 dir = -(std::cos(slant_deg * earth::deg) * up + std::sin(slant_deg * earth::deg) * e1);
          const earth::Vec3 top = up * s.radius_top_m();
          int hits = 0;
          for (int k = 0; k < rays; ++k) {
            const earth::Vec3 o = top + w * ((uniform01(7, li, k, 0) - 0.5) * e1 + (uniform01(7, li, k, 1) - 0.5) * e2);
            for (int t = 0; t < fine; ++t) pts[t] = o + dir * (length * (t + 0.5) / fine);
            s.classify(pts.data(), fine, v.data());
            hits += std::any_of(v.begin(), v.end(), [&](double x) { return x > s.threshold(); });
          }
          truth += hits / static_cast<double>(rays) / places;
          for (int t = 0; t <= coarse; ++t) q[t] = top + dir * (length * t / coarse);
          s.classify_filtered(q.data(), footprint.data(), q.size(), u.data());
          PathCoverage path(w, length);
          for (int t = 0; t <= coarse; ++t) path.add(s, u[t], length / coarse * (t == 0 || t == coarse ? 0.5 : 1.0));
          model += path.chance() / places;
        }
        std::printf("[ measured ] slant %2.0f deg, mask %.1f, footprint %5.0f m: rays %.3f, filtered %.3f\n", slant_deg,
                    mask, w, truth, model);
        sum_error += std::abs(model - truth), max_error = std::max(max_error, std::abs(model - truth)), ++configs;
      }
    }
  std::printf("[ measured ] mean |error| %.3f, largest %.3f\n", sum_error / configs, max_error);
  EXPECT_LT(sum_error / configs, 0.07);
  EXPECT_LT(max_error, 0.15);
}

TEST(CloudShell, AFootprintFinerThanEveryVoxelIsThePointSample) {
  // Below every texture's voxel nothing is averaged (sigma 0): u is an end of its range on CF's
  // own side of the threshold, coverage 0 or 1, as classify() decides.
  auto cube = std::make_shared<CubeMap<float>>(16);
  cube->fill([](const earth::Vec3& d) { return static_cast<float>(0.5 + 0.5 * d.x); });
  const CloudShell s(CloudType::low_cumulus, CloudModelParams()[CloudType::low_cumulus], small_textures(), cube,
                     std::vector<DisplacementMap>(4));
  std::vector<earth::Vec3> p(1000);
  for (std::size_t i = 0; i < p.size(); ++i)
    p[i] = earth::unit_from_latlon(-80 + 160 * uniform01(6, i, 0), -180 + 360 * uniform01(6, i, 1)) *
           (earth::radius_m + 7000 * uniform01(6, i, 2));
  std::vector<double> u(p.size()), c(p.size());
  const std::vector<double> tiny(p.size(), 0.01);
  s.classify_filtered(p.data(), tiny.data(), p.size(), u.data());
  s.classify(p.data(), p.size(), c.data());
  for (std::size_t i = 0; i < p.size(); ++i) {
    ASSERT_EQ(s.coverage(u[i]), c[i] > s.threshold() ? 1.0 : 0.0) << i;
  }
}

TEST(CloudShell, BatchedEvaluationIsBitIdenticalToSinglePoints) {
  // Ray marching evaluates many points per call; every point must get exactly what a
  // one-point call gives (thread- and batch-independent output). Points through the whole
  // shell and beyond, with a varying mask so every early exit is exercised.
  auto cube = std::make_shared<CubeMap<float>>(16);
  cube->fill([](const earth::Vec3& d) { return static_cast<float>(0.5 + 0.5 * d.x); });
  const CloudTypeParams params = CloudModelParams()[CloudType::low_cumulus];
  const CloudShell s(CloudType::low_cumulus, params, small_textures(), cube, std::vector<DisplacementMap>(4));
  std::vector<earth::Vec3> p(1000);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const earth::Vec3 d = earth::unit_from_latlon(-80 + 160 * uniform01(6, i, 0), -180 + 360 * uniform01(6, i, 1));
    p[i] = d * (earth::radius_m - 500 + 7000 * uniform01(6, i, 2));
  }
  std::vector<double> c(p.size()), v(p.size());
  s.classify(p.data(), p.size(), c.data());
  s.value(p.data(), p.size(), v.data());
  int inside = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    ASSERT_EQ(c[i], s.classify(p[i])) << i;
    ASSERT_EQ(v[i], s.value(p[i])) << i;
    // classify() returns a bound with CF's side of the threshold.
    ASSERT_EQ(c[i] > s.threshold(), v[i] > s.threshold()) << i;
    inside += v[i] > s.threshold();
  }
  EXPECT_GT(inside, 20);  // both sides are represented
  EXPECT_LT(inside, 980);
}

TEST(CloudShell, AltitudeBarriersSuppressCloudAtTheShellEdges) {
  const CloudShell s = shell_with_mask(1.0f);
  const earth::Vec3 d = earth::unit_from_latlon(12, 34);
  const double bottom = s.params().shell_bottom_m, top = s.params().shell_top_m;
  // At the shell bottom the barrier subtracts A (= 1) plus a negligible top term: CF drops by
  // about 1 relative to mid-shell. The fractal part differs between the two points, by at most
  // the sum of weights (1.0); so the bottom value is below the mid value + fractal range - A.
  EXPECT_LT(s.value(d * (earth::radius_m + bottom)), s.threshold());
  EXPECT_LT(s.value(d * (earth::radius_m + top)), s.threshold());
  EXPECT_LT(s.value(d * (earth::radius_m + bottom - 500)), s.threshold());
}

TEST(CloudShell, DeterministicPureFunctionOfPosition) {
  const CloudShell a = shell_with_mask(0.6f), b = shell_with_mask(0.6f);
  const earth::Vec3 p = earth::unit_from_latlon(-33, 151) * (earth::radius_m + 2000);
  EXPECT_EQ(a.value(p), b.value(p));
}

TEST(CloudModelParams, TomlOverridesAndRejectsUnknownKeys) {
  const auto d = ParamDict::from_string(
      "[clouds.cirrus]\nshell_top_m = 12000.0\n[clouds.cirrus.fine]\nweight = 0.4\n[clouds.low_cumulus]\ntypo = 1\n",
      "c.toml");
  const CloudModelParams p = CloudModelParams::from(d);
  EXPECT_EQ(p[CloudType::cirrus].shell_top_m, 12000);
  EXPECT_EQ(p[CloudType::cirrus].fractals[1].weight, 0.4);
  EXPECT_THROW(d.check_unused(), ConfigError);
  EXPECT_THROW(CloudModelParams::from(ParamDict::from_string("[clouds.cirrus]\nphase = 'plasma'\n")), ConfigError);
  // Table 1 shells are the defaults.
  const CloudModelParams def;
  EXPECT_EQ(def[CloudType::low_stratus].shell_bottom_m, 500);
  EXPECT_EQ(def[CloudType::low_cumulus].shell_top_m, 6000);
  EXPECT_EQ(def[CloudType::altostratus].shell_bottom_m, 6000);
  EXPECT_EQ(def[CloudType::cirrus].shell_bottom_m, 6500);
}

TEST(CloudModelParams, ValuesOutsideWhatTheModelCanUseAreErrorsNamingTheKey) {
  // Each would hang (a displacement integrated for 1e9 h), divide by zero, or allocate more
  // than any machine has; the message names the full key.
  for (const auto& [toml, key] : std::vector<std::pair<std::string, std::string>>{
           {"[clouds.cirrus.fine]\ndisplace_hours = 1e9\n", "clouds.cirrus.fine.displace_hours"},
           {"[clouds.low_cumulus]\nmask_displace_hours = -1\n", "clouds.low_cumulus.mask_displace_hours"},
           {"[clouds.altostratus]\naltitude_length_top_m = 0\n", "clouds.altostratus.altitude_length_top_m"},
           {"[clouds.low_stratus.coarse]\nlength_scale_m = 0\n", "clouds.low_stratus.coarse.length_scale_m"},
           {"[clouds.cirrus]\nmin_mask = 1.5\n", "clouds.cirrus.min_mask"},
           {"[clouds.low_stratus]\nasymmetry = 1.0\n", "clouds.low_stratus.asymmetry"},
           {"[displacement]\nstep_s = 0\n", "displacement.step_s"},
           {"[textures]\nsize = 65536\n", "textures.size"},
           {"[clouds.cirrus]\nthreshold = nan\n", "clouds.cirrus.threshold"}}) {
    try {
      CloudModelParams::from(ParamDict::from_string(toml, "c.toml"));
      ADD_FAILURE() << toml;
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.context().key, key);
      EXPECT_EQ(e.context().file, "c.toml");
    }
  }
}

}  // namespace nephos::clouds

namespace nephos::clouds {
TEST(CloudModelParams, ShippedParameterFileEqualsTheDefaults) {
  const auto d = ParamDict::from_file(std::filesystem::path(NEPHOS_SOURCE_DIR) / "configs/clouds.toml");
  const CloudModelParams p = CloudModelParams::from(d);
  EXPECT_NO_THROW(d.check_unused());
  const CloudModelParams def;
  EXPECT_EQ(p.texture_size, def.texture_size);
  EXPECT_EQ(p.displacement_cube_size, def.displacement_cube_size);
  EXPECT_EQ(p.mask_cube_size, def.mask_cube_size);
  for (std::size_t k = 0; k < p.types.size(); ++k) {
    const auto &a = p.types[k], &b = def.types[k];
    EXPECT_EQ(a.shell_bottom_m, b.shell_bottom_m);
    EXPECT_EQ(a.shell_top_m, b.shell_top_m);
    EXPECT_EQ(a.wind_altitude_m, b.wind_altitude_m);
    EXPECT_EQ(a.threshold, b.threshold);
    EXPECT_EQ(a.altitude_length_bottom_m, b.altitude_length_bottom_m);
    EXPECT_EQ(a.altitude_length_top_m, b.altitude_length_top_m);
    EXPECT_EQ(a.phase, b.phase);
    EXPECT_EQ(a.water_content_g_m3, b.water_content_g_m3);
    EXPECT_EQ(a.effective_radius_um, b.effective_radius_um);
    EXPECT_EQ(a.asymmetry, b.asymmetry);
    for (std::size_t i = 0; i < 3; ++i) {
      EXPECT_EQ(a.fractals[i].weight, b.fractals[i].weight) << k << " " << i;
      EXPECT_EQ(a.fractals[i].length_scale_m, b.fractals[i].length_scale_m);
      EXPECT_EQ(a.fractals[i].displace_hours, b.fractals[i].displace_hours);
    }
  }
}
}  // namespace nephos::clouds

namespace nephos::clouds {
namespace {
// Fraction of n points of the mid-shell (1-3 km, where value() is the exact CF: no barrier or
// mask exit) where value_and_gradient(h) lies within `tolerance` (relative) of the central
// differences of value() with step d; also the largest difference of the two values.
std::pair<double, double> gradient_agreement(const CloudShell& s, double h, double d, double tolerance) {
  constexpr int n = 400;
  std::vector<earth::Vec3> pts(n), grad(n);
  std::vector<double> val(n);
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::uint64_t>(i);
    const double z = 1.6 * uniform01(11, u, 0) - 0.8, phi = 2 * M_PI * uniform01(11, u, 1);
    const double alt = 1000 + 2000 * uniform01(11, u, 2);
    pts[static_cast<std::size_t>(i)] = (earth::radius_m + alt) * earth::Vec3{std::sqrt(1 - z * z) * std::cos(phi),
                                                                             std::sqrt(1 - z * z) * std::sin(phi), z};
  }
  s.value_and_gradient(pts.data(), n, h, val.data(), grad.data());
  int agree = 0;
  double max_value_error = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const earth::Vec3& p = pts[i];
    max_value_error = std::max(max_value_error, std::abs(val[i] - s.value(p)));
    const earth::Vec3 fd{(s.value(p + earth::Vec3{d, 0, 0}) - s.value(p - earth::Vec3{d, 0, 0})) / (2 * d),
                         (s.value(p + earth::Vec3{0, d, 0}) - s.value(p - earth::Vec3{0, d, 0})) / (2 * d),
                         (s.value(p + earth::Vec3{0, 0, d}) - s.value(p - earth::Vec3{0, 0, d})) / (2 * d)};
    agree += glm::length(grad[i] - fd) <= tolerance * glm::length(fd);
  }
  return {static_cast<double>(agree) / n, max_value_error};
}

std::shared_ptr<CubeMap<float>> varying_mask() {
  auto cube = std::make_shared<CubeMap<float>>(16);
  cube->fill([](const earth::Vec3& d) { return static_cast<float>(0.6 + 0.3 * d.x * d.y); });
  return cube;
}
}  // namespace

TEST(CloudShell, GradientOfTheTexturesMatchesCentralDifferences) {
  // No displacement: the gradient is the trilinear interpolants' own, chained with the radial
  // scaling of the texture coordinates, plus the mask and barrier terms. Central differences
  // with step 0.5 m (the voxels here are 94 m and more, so a difference straddles a voxel
  // face, where the trilinear gradient jumps, at a few % of the points; float texture
  // coordinates carry ~1e-6 of a voxel, a relative error ~1e-3 in such a difference).
  const CloudShell s(CloudType::low_cumulus, CloudModelParams()[CloudType::low_cumulus], small_textures(),
                     varying_mask(), std::vector<DisplacementMap>(4));
  const auto [agree, value_error] = gradient_agreement(s, 0.5, 0.5, 0.01);
  EXPECT_GE(agree, 0.9) << agree;
  // The value is value()'s arithmetic up to the contraction of multiply-adds (float texels).
  EXPECT_LT(value_error, 1e-6);
}

TEST(CloudShell, GradientThroughAShearedDisplacementMatchesCentralDifferences) {
  // A sheared wind (zonal, its angular speed growing with latitude) stretches and turns the
  // texture coordinates; their Jacobian comes from forward differences. The upwind directions
  // are float cube-map blends (~0.4 m of rounding on the Earth), so both sides difference
  // over 50 m (rounding ~1 %), with the coarse term alone stretched to 1.9 km voxels so that
  // few differences straddle a voxel face; agreement within 5 % at 85 % of the points.
  WindField wind;
  wind.velocity_m_s = CubeMap<glm::vec3>(32);
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i) {
        const auto d = wind.velocity_m_s.texel_direction(f, i, j);
        const double speed_m_s = 10 + 20 * d.z * d.z;  // at the equator's distance from the axis
        wind.velocity_m_s.texel(f, i, j) = glm::vec3(speed_m_s * glm::cross(earth::Vec3{0, 0, 1}, d));
      }
  const DisplacementMap map = DisplacementMap::build(wind, 6, 32, 1800);
  CloudTypeParams params = CloudModelParams()[CloudType::low_cumulus];
  params.fractals[0].length_scale_m = 60e3;
  params.fractals[1].weight = params.fractals[2].weight = 0;
  const CloudShell s(CloudType::low_cumulus, params, small_textures(), varying_mask(),
                     {DisplacementMap{}, map, map, map});
  const auto [agree, value_error] = gradient_agreement(s, 50, 50, 0.05);
  EXPECT_GE(agree, 0.85) << agree;  // 0.92 measured
  EXPECT_LT(value_error, 1e-6);
}
}  // namespace nephos::clouds
