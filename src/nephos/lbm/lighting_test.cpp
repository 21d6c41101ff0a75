#include "nephos/lbm/lighting.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "nephos/core/error.hpp"
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
    std::printf("[ measured ] sigma_s %.1f: D / D_theory %.4f\n", ss, (m2 - m1) / (6 * 25) / ((2 / ss - 1) / 4));
    EXPECT_NEAR((m2 - m1) / (6 * 25) / ((2 / ss - 1) / 4), 1.0, 0.03) << ss;
    EXPECT_NEAR(s.total(), 1.0, 1e-5);  // photons conserved without absorption (FP32)
  }
}

TEST(Lighting, BeerLambertAlongTheSunsLatticeDirections) {
  // No scattering: every photon keeps its direction, so at steady state the light in each cell
  // is exactly the sunlight of each injected direction attenuated by (1 - sigma_a) per
  // absorbing cell crossed upstream (the lattice's Beer-Lambert law), summed over the three
  // directions. Sun at azimuth 0, elevation 45 deg: light travels along (-1, 0, -1), a lattice
  // diagonal (cosine 1), and the next closest directions are the axes -x and -z (cosine
  // 1/sqrt 2), so the documented weights (proportional to the cosine, sum 1) are 1/(1 + sqrt 2)
  // and (1/sqrt 2)/(1 + sqrt 2). A cloud box of density 0.6 (sigma_a = 0.05 per step at
  // density 1). Both collision paths: isotropic and, with an asymmetry, the phase matrix's.
  // Tolerance 1e-5 relative: FP32 products of up to 16 factors. Fault caught: absorption in a
  // collision that is not sigma_a (5 % more in the phase-matrix path), injection weights or
  // directions off.
  const Grid3 g{20, 12, 16};
  const std::vector<float> density = box_density(g, 5, 15, 3, 9, 4, 12, 0.6f);
  const double sa = 0.05 * 0.6;
  const double axis_w = (1 / std::sqrt(2.0)) / (1 + std::sqrt(2.0)), diag_w = 1 / (1 + std::sqrt(2.0));
  const int dirs[3][3] = {{-1, 0, -1}, {-1, 0, 0}, {0, 0, -1}};
  const double weights[3] = {diag_w, axis_w, axis_w};
  auto inside = [&](int x, int y, int z) { return x >= 0 && x < g.nx && y >= 0 && y < g.ny && z >= 0 && z < g.nz; };
  for (double asymmetry : {0.0, 0.5}) {
    LightingParams p;
    p.sigma_s_per_density = 0;
    p.sigma_a_per_density = 0.05;
    p.asymmetry = asymmetry;
    p.sun_azimuth_deg = 0;
    p.sun_elevation_deg = 45;
    LightingSolver s(g, density, p);
    s.solve();
    const auto light = s.light();
    double worst = 0;
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x) {
          double expected = 0;
          for (int k = 0; k < 3; ++k) {
            double t = weights[k];
            // The cells this direction's photons crossed (and collided in) on their way here.
            for (int m = 1;; ++m) {
              const int ux = x - m * dirs[k][0], uy = y - m * dirs[k][1], uz = z - m * dirs[k][2];
              if (!inside(ux, uy, uz)) break;
              t *= 1 - sa * density[g.index(ux, uy, uz)] / 0.6;
            }
            expected += t;
          }
          worst = std::max(worst, std::abs(light[g.index(x, y, z)] / expected - 1));
        }
    std::printf("[ measured ] asymmetry %.1f: largest relative error %.1e\n", asymmetry, worst);
    EXPECT_LT(worst, 1e-5) << "asymmetry " << asymmetry;
  }
}

TEST(Lighting, AbsorptionTallyIsWhatDisappears) {
  // A periodic box of uniform cloud (no sunlight, no boundary): scattering conserves photons
  // and every cell absorbs sigma_a of what it holds, so after n steps a pulse keeps exactly
  // (1 - sigma_a)^n of its photons, and each step's absorbed tally equals the photons lost in
  // it. Isotropic scattering and the phase matrix's. Tolerances: FP32 sums over 4096 cells
  // (2e-6 relative after 60 steps). Fault caught: a collision that absorbs more or less than
  // the tally counts (5 % more in either path: 9 % fewer photons after 60 steps).
  const Grid3 g{16, 16, 16};
  for (double asymmetry : {0.0, 0.6}) {
    LightingParams p;
    p.periodic = true;
    p.asymmetry = asymmetry;
    p.sigma_s_per_density = 0.3;
    p.sigma_a_per_density = 0.03;
    LightingSolver s(g, std::vector<float>(g.cells(), 1.0f), p);
    s.add_pulse(g.index(5, 7, 9), 1.0);
    double before = s.total(), tally = 0;
    for (int t = 0; t < 60; ++t) {
      s.step();
      const double after = s.total();
      EXPECT_NEAR(s.balance().absorbed, before - after, 1e-6 * before) << "step " << t;
      tally += s.balance().absorbed;
      before = after;
    }
    std::printf("[ measured ] asymmetry %.1f: photons left %.8f, (1 - sigma_a)^60 %.8f\n", asymmetry, s.total(),
                std::pow(1 - 0.03, 60));
    EXPECT_NEAR(s.total(), std::pow(1 - 0.03, 60), 2e-6) << "asymmetry " << asymmetry;
    EXPECT_NEAR(tally, 1 - std::pow(1 - 0.03, 60), 2e-6);
  }
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

TEST(Lighting, SlabsStepExactlyAsTheWholeGrid) {
  // The decomposition across MPI ranks: three slabs along y (4, 5 and 3 rows) that swap the
  // photons streamed into their halo rows after every step, with the whole grid's balance
  // summed from their per-plane balances in y order, must take the same number of steps to
  // the same light field and balance as the whole grid, bit for bit. Open boxes lit by a sun
  // whose light crosses the cuts (isotropic, and forward scattering through the full phase
  // matrix), and a periodic box (the ring of slabs wraps) with a pulse on a cut.
  const Grid3 g{10, 12, 8};
  const std::vector<float> density = box_density(g, 2, 8, 2, 10, 2, 6, 0.9f);
  const int cuts[] = {0, 4, 9, 12};
  auto rows = [&](const std::vector<float>& field, int begin, int end) {
    std::vector<float> out;
    for (int z = 0; z < g.nz; ++z)
      for (int y = begin; y < end; ++y)
        for (int x = 0; x < g.nx; ++x) out.push_back(field[g.index(x, y, z)]);
    return out;
  };
  for (int variant = 0; variant < 3; ++variant) {
    LightingParams p;
    p.sun_azimuth_deg = 70;  // light travelling towards -y, across every cut
    p.asymmetry = variant == 1 ? 0.5 : 0.0;
    p.periodic = variant == 2;
    p.max_iterations = variant == 2 ? 40 : 5000;
    LightingSolver whole(g, density, p);
    if (p.periodic) whole.add_pulse(g.index(5, 4, 3), 1000.0);
    const int steps = whole.solve();
    std::vector<LightingSolver> slabs;
    for (int r = 0; r < 3; ++r) {
      slabs.emplace_back(g, rows(density, cuts[r], cuts[r + 1]), p, cuts[r], cuts[r + 1]);
      if (p.periodic && cuts[r] <= 4 && 4 < cuts[r + 1]) slabs.back().add_pulse(g.index(5, 4, 3), 1000.0);
    }
    using Side = LightingSolver::Side;
    int slab_steps = 0, quiet = 0;
    while (slab_steps < p.max_iterations && quiet < 10) {
      for (auto& s : slabs) s.step();
      std::vector<std::vector<float>> down, up;
      for (const auto& s : slabs) down.push_back(s.leaving(Side::below)), up.push_back(s.leaving(Side::above));
      std::vector<std::array<double, 3>> planes;
      for (std::size_t r = 0; r < 3; ++r) {
        slabs[r].set_arrivals(Side::below, up[(r + 2) % 3]);
        slabs[r].set_arrivals(Side::above, down[(r + 1) % 3]);
        planes.insert(planes.end(), slabs[r].plane_balance().begin(), slabs[r].plane_balance().end());
      }
      for (auto& s : slabs) s.set_balance(LightingSolver::balance_of_planes(planes));
      ++slab_steps;
      quiet = slabs[0].residual() < p.tolerance ? quiet + 1 : 0;
    }
    ASSERT_EQ(slab_steps, steps) << "variant " << variant;
    for (int r = 0; r < 3; ++r) {
      EXPECT_EQ(slabs[static_cast<std::size_t>(r)].light(), rows(whole.light(), cuts[r], cuts[r + 1]))
          << "variant " << variant << ", slab " << r;
      EXPECT_EQ(slabs[static_cast<std::size_t>(r)].balance().inflow, whole.balance().inflow);
      EXPECT_EQ(slabs[static_cast<std::size_t>(r)].balance().outflow, whole.balance().outflow);
      EXPECT_EQ(slabs[static_cast<std::size_t>(r)].balance().absorbed, whole.balance().absorbed);
    }
  }
}

TEST(Lighting, OneSlabSolvesThroughItsExchangeHook) {
  // solve() with the hook an MPI driver passes, on one slab that is its own neighbour (one
  // rank): the same steps and light as the whole grid; without the hook a slab refuses.
  const Grid3 g{8, 6, 6};
  const std::vector<float> density = box_density(g, 2, 6, 1, 5, 1, 5, 1.0f);
  LightingParams p;
  LightingSolver whole(g, density, p);
  const int steps = whole.solve();
  LightingSolver slab(g, density, p, 0, g.ny);
  EXPECT_THROW(slab.solve(), ValueError);
  const int slab_steps = slab.solve([](LightingSolver& s) {
    using Side = LightingSolver::Side;
    const auto down = s.leaving(Side::below), up = s.leaving(Side::above);
    s.set_arrivals(Side::below, up);
    s.set_arrivals(Side::above, down);
    s.set_balance(LightingSolver::balance_of_planes(s.plane_balance()));
  });
  EXPECT_EQ(slab_steps, steps);
  EXPECT_EQ(slab.light(), whole.light());
}

}  // namespace nephos::lbm
