#include "nephos/surface/surface.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace nephos::surface {
namespace {

// Normal incidence on water, n = 1.334: ((n - 1) / (n + 1))^2 = 0.0205 (Fresnel); grazing: 1.
TEST(Surface, FresnelReflectanceOfWater) {
  EXPECT_NEAR(fresnel_reflectance(1.0), std::pow(0.334 / 2.334, 2), 1e-12);
  EXPECT_NEAR(fresnel_reflectance(0.0), 1.0, 1e-12);
  // Brewster's angle tan(i) = n: the p-polarised part vanishes, R = rs^2 / 2.
  const double ib = std::atan(1.334);
  const double ct = std::sqrt(1 - std::pow(std::sin(ib) / 1.334, 2));
  const double rs = (std::cos(ib) - 1.334 * ct) / (std::cos(ib) + 1.334 * ct);
  EXPECT_NEAR(fresnel_reflectance(std::cos(ib)), 0.5 * rs * rs, 1e-12);
}

// Cox & Munk: for the Sun at 30 deg zenith and a light wind (1 m s^-1), over all view directions,
// the glint is brightest at the specular point (azimuth opposite the Sun, view zenith 30 deg
// within 1 deg: the factor 1 / mu moves the brightest view slightly towards the horizon, 5 deg
// at 7 m s^-1, the glitter pattern's elongation away from the Sun in Cox & Munk's photographs);
// at the specular point the mirroring facet is level and the value is pi p(0) F / (4 mu0^2).
TEST(Surface, GlintPeaksAtTheSpecularPoint) {
  const double sun_zenith = 30 * M_PI / 180, mu0 = std::cos(sun_zenith);
  const double sun[3] = {std::sin(sun_zenith), 0, mu0};  // towards the Sun
  double best = -1, best_zenith = 0, best_azimuth = 0;
  for (int zi = 1; zi < 89; ++zi)
    for (int ai = 0; ai < 360; ai += 2) {
      const double z = zi * M_PI / 180, a = ai * M_PI / 180;
      const double view[3] = {std::sin(z) * std::cos(a), std::sin(z) * std::sin(a), std::cos(z)};
      const double cos_phase = sun[0] * view[0] + sun[1] * view[1] + sun[2] * view[2];
      const double r = glint_reflectance(mu0, view[2], cos_phase, 1.0);
      if (r > best) best = r, best_zenith = zi, best_azimuth = ai;
    }
  EXPECT_NEAR(best_zenith, 30, 1);
  EXPECT_EQ(best_azimuth, 180);
  const double s2 = 0.003 + 5.12e-3 * 1;
  const double cos_phase_specular = 2 * mu0 * mu0 - 1;  // view mirrored: the angle between them is 2 x 30 deg
  EXPECT_NEAR(glint_reflectance(mu0, mu0, cos_phase_specular, 1.0), fresnel_reflectance(mu0) / (4 * mu0 * mu0 * s2),
              1e-9);
  EXPECT_GT(best, 0);
}

// The glint reflects, over the hemisphere, what the Fresnel law reflects of the direct beam:
// integrating pi L over view directions gives F for a slightly rough sea (small slopes: the
// facets' shadowing and the change of F with tilt are negligible). 3 %: at 1 m s^-1 the slopes
// still spread the reflection's incidence over +-10 deg around the Sun's.
TEST(Surface, GlintConservesTheReflectedBeam) {
  const double mu0 = std::cos(20 * M_PI / 180), sun[3] = {std::sqrt(1 - mu0 * mu0), 0, mu0};
  double flux = 0;  // integral of R mu dOmega / pi: the albedo
  const int nz = 900, na = 720;
  for (int zi = 0; zi < nz; ++zi)
    for (int ai = 0; ai < na; ++ai) {
      const double z = (zi + 0.5) * (M_PI / 2) / nz, a = (ai + 0.5) * 2 * M_PI / na;
      const double view[3] = {std::sin(z) * std::cos(a), std::sin(z) * std::sin(a), std::cos(z)};
      const double cp = sun[0] * view[0] + sun[1] * view[1] + sun[2] * view[2];
      flux += glint_reflectance(mu0, view[2], cp, 1.0) * view[2] * std::sin(z) * (M_PI / 2 / nz) * (2 * M_PI / na);
    }
  EXPECT_NEAR(flux / M_PI, fresnel_reflectance(mu0), 0.03 * fresnel_reflectance(mu0));
}

TEST(Surface, AlbedosFollowTheBroadbandAlbedo) {
  const optics::Band& vis = optics::band("vis");
  const optics::Band& swir = optics::band("swir16");
  EXPECT_GT(band_albedo(Kind::snow, vis), 0.9);
  EXPECT_LT(band_albedo(Kind::snow, swir), 0.15);  // snow is dark at 1.6 um: the snow/ice band
  EXPECT_LT(band_albedo(Kind::ocean, vis), 0.05);
  EXPECT_GT(band_albedo(Kind::land, vis, 0.38), 3 * band_albedo(Kind::land, vis, 0.13));  // desert vs forest
  const State s = state(0.5, 0.0, 0.0);
  EXPECT_NEAR(s.share[0] + s.share[1], 1.0, 1e-12);
  EXPECT_NEAR(mixed_emissivity(state(0, 0, 0), optics::band("lwir")), 0.99, 1e-12);
}

}  // namespace
}  // namespace nephos::surface
