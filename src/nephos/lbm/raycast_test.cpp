#include "nephos/lbm/raycast.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <initializer_list>

namespace nephos::lbm {

namespace {

// A density of 1 in the cells [lo, hi) along each axis (z from z_lo), 0 elsewhere.
std::vector<float> block(const Grid3& g, int lo, int hi, int z_lo) {
  std::vector<float> density(g.cells(), 0.0f);
  for (int z = z_lo; z < hi; ++z)
    for (int y = lo; y < hi; ++y)
      for (int x = lo; x < hi; ++x) density[g.index(x, y, z)] = 1.0f;
  return density;
}

// The 8-bit value the ray caster stores for linear colour v (gamma 2.2), before rounding.
double encoded(double v) { return 255 * std::pow(v, 1 / 2.2); }

// The colour of the one pixel of a 1 x 1 image from `eye` towards `target` [lattice units], the
// Sun at `sun_elevation_deg`, extinction kappa per lattice unit at density 1; checked against the
// linear colour `expected(kappa)` within the 8-bit output's rounding (half a count).
template <class Expected>
void expect_pixel(const std::vector<float>& density, const std::array<double, 3>& eye,
                  const std::array<double, 3>& target, double sun_elevation_deg, std::initializer_list<double> kappas,
                  Expected expected) {
  const Grid3 g{32, 32, 32};
  const std::vector<float> light(g.cells(), 1.0f);
  for (double kappa : kappas) {
    RaycastParams p;
    p.width = p.height = 1;
    p.eye = eye, p.target = target;
    p.sun_elevation_deg = sun_elevation_deg;
    p.extinction_per_density = kappa;
    const std::vector<std::uint8_t> rgb = raycast(g, density, light, p);
    const std::array<double, 3> v = expected(kappa);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(rgb[c], encoded(v[c]), 0.5 + 1e-9) << "kappa " << kappa << ", channel " << c;
  }
}

}  // namespace

TEST(Raycast, TheGroundUnderASlabIsLitThroughItsColumnsOpticalDepth) {
  // The Sun at the zenith over a slab of 16 cells of density 1 (z 16-31): the ground below sees
  // it through optical depth 16 kappa (Beer-Lambert), so its colour is the grassland's
  // (0.32, 0.38, 0.22) times 0.25 + 0.75 exp(-16 kappa). The view ray runs under the slab, through
  // empty cells. Tolerance: the 8-bit output's rounding (half a count); one cell more or less in
  // the column moves the red channel by 0.85 counts at kappa 0.02.
  expect_pixel(block(Grid3{32, 32, 32}, 0, 32, 16), {16, -40, 4}, {16, 16, 0}, 90, {0.02, 0.05, 0.1}, [](double kappa) {
    const double lit = 0.25 + 0.75 * std::exp(-16 * kappa);
    return std::array<double, 3>{0.32 * lit, 0.38 * lit, 0.22 * lit};
  });
}

TEST(Raycast, ASlabSeenThroughIsItsSourceAndTheSkyByItsTransmittance) {
  // A homogeneous block of 24 cells (4-27) of density 1, uniformly lit, seen edge-on along y
  // against the horizon's sky (0.55, 0.70, 0.95): front-to-back compositing must give the
  // emission-absorption solution S (1 - T) + T sky, with T = exp(-24 kappa) (the trilinear
  // ramps at its faces add up to the block's width) and S the block's source (1.00, 0.98, 0.95)
  // x (0.25 ambient + 0.85 light). Tolerance: the 8-bit output's rounding (half a count).
  expect_pixel(
      block(Grid3{32, 32, 32}, 4, 28, 4), {16, -40, 16}, {16, 16, 16}, 45, {0.01, 0.02, 0.029}, [](double kappa) {
        const double t = std::exp(-24 * kappa), source = (0.25 + 0.85) * (1 - t);
        return std::array<double, 3>{1.00 * source + t * 0.55, 0.98 * source + t * 0.70, 0.95 * source + t * 0.95};
      });
}

}  // namespace nephos::lbm
