#include "nephos/lbm/lighting.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "nephos/core/parallel.hpp"

namespace nephos::lbm {

namespace {

// A density field of `value` inside the box [x0, x1) x [y0, y1) x [z0, z1), 0 elsewhere.
std::vector<float> box_density(const Grid3& g, int x0, int x1, int y0, int y1, int z0, int z1, float value) {
  std::vector<float> density(g.cells(), 0.0f);
  for (int z = z0; z < z1; ++z)
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) density[g.index(x, y, z)] = value;
  return density;
}

}  // namespace

TEST(Lighting, PhaseMatrixConservesPhotonsAndHasTheRequestedAsymmetry) {
  for (double g : {0.0, 0.5, 0.85}) {
    const PhaseMatrix p = phase_matrix(g);
    for (int j = 0; j < light_dirs; ++j) {
      double col = 0;
      for (int i = 0; i < light_dirs; ++i) col += p[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      EXPECT_NEAR(col, 1.0, 1e-12);             // scattering conserves photons
      EXPECT_NEAR(mean_cosine(p, j), g, 1e-9);  // first moment = HG's g (bisection to 1e-30)
    }
  }
}

TEST(Lighting, DiffusionLimit) {
  // Isotropic scattering, no absorption, periodic box, a pulse at the centre: the mean squared
  // displacement grows as 6 D t with D = (2 / sigma_s - 1) / 4 (docs/lbm.md). Slope between
  // t = 25 and t = 50, after the ballistic start (velocity correlation (1 - sigma_s)^25 < 1e-9);
  // the spread stays within a third of the box (minimum-image distances). 3 % covers the
  // lattice's finite-size and FP32 effects.
  for (double ss : {0.6, 0.9}) {
    const Grid3 g{48, 48, 48};
    LightingParams p;
    p.periodic = true;
    p.sigma_s_per_density = ss;
    p.sigma_a_per_density = 0;
    LightingSolver s(g, std::vector<float>(g.cells(), 1.0f), p);
    s.add_pulse(g.index(24, 24, 24), 1.0);
    auto msd = [&] {
      const auto l = s.light();
      double m = 0, w = 0;
      auto d2 = [](int a) {
        const int d = std::abs(a - 24);
        return static_cast<double>(std::min(d, 48 - d) * std::min(d, 48 - d));
      };
      for (int z = 0; z < g.nz; ++z)
        for (int y = 0; y < g.ny; ++y)
          for (int x = 0; x < g.nx; ++x) {
            const double v = l[g.index(x, y, z)];
            m += v * (d2(x) + d2(y) + d2(z));
            w += v;
          }
      return m / w;
    };
    for (int t = 0; t < 25; ++t) s.step();
    const double m1 = msd();
    for (int t = 0; t < 25; ++t) s.step();
    const double m2 = msd();
    EXPECT_NEAR((m2 - m1) / (6 * 25) / ((2 / ss - 1) / 4), 1.0, 0.03) << ss;
    EXPECT_NEAR(s.total(), 1.0, 1e-5);  // photons conserved without absorption (FP32)
  }
}

TEST(Lighting, PhotonBalanceAtSteadyState) {
  // inflow = outflow + absorption at steady state, to 1e-4 (issue).
  const Grid3 g{24, 24, 24};
  const std::vector<float> density = box_density(g, 4, 20, 4, 20, 6, 18, 1.0f);
  LightingParams p;
  p.sigma_a_per_density = 0.02;
  LightingSolver s(g, density, p);
  const int steps = s.solve();
  EXPECT_LT(steps, p.max_iterations);
  const auto& b = s.balance();
  EXPECT_GT(b.inflow, 0);
  EXPECT_GT(b.absorbed, 0);
  EXPECT_LT(std::abs(b.inflow - b.outflow - b.absorbed) / b.inflow, 1e-4);
}

TEST(Lighting, SameStepsAndLightForAnyThreadCount) {
  // The photon balance (which decides when to stop) is summed per row in a fixed order, so 1
  // and 2 threads take the same number of steps to the same field, bit for bit; with forward
  // scattering (the full phase matrix path) and a grid whose rows do not fill whole vectors.
  const Grid3 g{20, 18, 16};
  const std::vector<float> density = box_density(g, 5, 15, 3, 15, 4, 12, 0.8f);
  LightingParams p;
  p.asymmetry = 0.6;
  set_threads(1);
  LightingSolver a(g, density, p);
  const int steps_a = a.solve();
  set_threads(2);
  LightingSolver b(g, density, p);
  const int steps_b = b.solve();
  set_threads(0);
  EXPECT_EQ(steps_a, steps_b);
  EXPECT_EQ(a.light(), b.light());
  EXPECT_EQ(a.balance().inflow, b.balance().inflow);
}

TEST(Lighting, ForwardBackwardRatioOfOneScatteringStep) {
  // A beam travelling down (-z, D3Q19 direction 6) in a uniformly scattering periodic box: after
  // one step the scattered photons moving down versus up must split as the phase function says:
  // 1 : 1 for isotropic scattering, and for HG g = 0.8 the ratio of the matrix's column sums,
  // which is far larger (forward-peaked).
  auto ratio = [](double g, double& expected) {
    const Grid3 grid{8, 8, 8};
    LightingParams p;
    p.periodic = true;
    p.asymmetry = g;
    p.sigma_s_per_density = 0.3;
    p.sigma_a_per_density = 0;
    LightingSolver s(grid, std::vector<float>(grid.cells(), 1.0f), p);
    s.add_beam(grid.index(4, 4, 4), 6, 1.0);
    s.step();
    double down = 0, up = 0, pd = 0, pu = 0;
    const PhaseMatrix m = phase_matrix(g);
    for (int dir = 1; dir <= light_dirs; ++dir) {
      const int cz = d3q19::cz[static_cast<std::size_t>(dir)];
      const double photons = s.total_in_direction(dir) - (dir == 6 ? 0.7 : 0.0);  // minus the unscattered beam
      const double pm = m[static_cast<std::size_t>(dir - 1)][5];
      if (cz < 0) down += photons, pd += pm;
      if (cz > 0) up += photons, pu += pm;
    }
    expected = pd / pu;
    return down / up;
  };
  double e_iso = 0, e_hg = 0;
  const double iso = ratio(0.0, e_iso), hg = ratio(0.8, e_hg);
  EXPECT_NEAR(e_iso, 1.0, 1e-12);
  EXPECT_NEAR(iso, 1.0, 1e-4);  // FP32 of 0.3 * weights
  EXPECT_NEAR(hg / e_hg, 1.0, 1e-4);
  EXPECT_GT(e_hg, 10.0);
}

}  // namespace nephos::lbm
