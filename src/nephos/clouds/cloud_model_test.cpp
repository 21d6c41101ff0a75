#include "nephos/clouds/cloud_model.hpp"

#include <gtest/gtest.h>

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
      FractalTextures{noise::bake({noise::FractalKind::perlin, 4, 3, 0.5, false}, 1, 32),
                      noise::bake({noise::FractalKind::perlin, 4, 3, 0.5, false}, 2, 32),
                      noise::bake({noise::FractalKind::worley, 4, 2, 0.5, true}, 3, 32)});
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

TEST(CloudShell, CalibratedMaskMeansCloudFraction) {
  // A mask is a cloud fraction (the weather masks' meaning), so a uniform mask m must give a
  // fraction m of cloudy points, for every m, not only where a calibration is anchored. On the
  // mid-shell sphere with the altitude barriers off (with them, CF is 0.006 lower there and
  // the fraction ~0.02 lower: docs/render.md). 20 000 points: binomial standard error <=
  // 0.0035; the 32^3 textures' tiles repeat over the sphere, so the points are not independent
  // samples of the texture, and the calibration's own 32 768-sample quantiles add ~0.003:
  // bound 0.015 (4 standard errors of both). Fault caught: a linear mask term b + w m anchored
  // at the 5 % and 95 % quantiles, as before (0.25 gave 0.186, 0.75 gave 0.813).
  CloudTypeParams p = CloudModelParams()[CloudType::low_stratus];
  p.altitude_scale = 0;
  for (float m : {0.05f, 0.1f, 0.25f, 0.5f, 0.75f, 0.9f, 0.95f}) {
    const double f = cloudy_fraction(shell_with_mask(m, p));
    std::printf("mask %.2f: cloudy fraction %.4f\n", m, f);
    EXPECT_NEAR(f, m, 0.015) << "mask " << m;
  }
  EXPECT_EQ(cloudy_fraction(shell_with_mask(0.0f)), 0.0);  // below min_mask: clear sky
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
