#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>

#include <algorithm>
#include <cstdio>
#include <tuple>
#include <utility>
#include "nephos/core/error.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/core/test_support.hpp"
#include "nephos/lbm/bgk.hpp"
#include "nephos/lbm/water_model.hpp"

namespace nephos::lbm {

namespace {
// A CK4 checkpoint's bytes as the older format CK3 (no header checksum, no row checksums) or
// CK2 (nor the storage parameter), whose files must still load.
std::string older_format(std::string ck4, const Grid3& g, int format) {
  const std::size_t params_end = 16 + 4 * 8 + 19 * 8;
  ck4.resize(params_end + 8 + 2 * 19 * g.cells() * 4);  // the row checksums' table dropped
  ck4.erase(params_end, 8);                             // the header's checksum
  ck4.replace(0, 14, format == 2 ? "NEPHOS-LBM-CK2" : "NEPHOS-LBM-CK3");
  if (format == 2) ck4.erase(params_end - 8, 8);  // the storage parameter
  return ck4;
}
}  // namespace

TEST(D3Q19, EquilibriumMomentsForAnyRestFraction) {
  // sum f = rho, sum f c = rho u, sum f c c = rho (1 - d)/2 I + rho u u (eqs. 7, 8, 19): exact
  // for the seed's equilibrium (double precision: 1e-14).
  for (double d : {1.0 / 3.0, 0.1, 0.5}) {
    const double rho = 1.3, u[3] = {0.05, -0.02, 0.03};
    double f[d3q19::q];
    d3q19::equilibrium<double>(rho, u[0], u[1], u[2], d, f);
    double m0 = 0, m1[3] = {0, 0, 0}, m2[3][3] = {};
    for (int i = 0; i < d3q19::q; ++i) {
      const auto iu = static_cast<std::size_t>(i);
      const double c[3] = {double(d3q19::cx[iu]), double(d3q19::cy[iu]), double(d3q19::cz[iu])};
      m0 += f[i];
      for (int a = 0; a < 3; ++a) {
        m1[a] += f[i] * c[a];
        for (int b = 0; b < 3; ++b) m2[a][b] += f[i] * c[a] * c[b];
      }
    }
    EXPECT_NEAR(m0, rho, 1e-14);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(m1[a], rho * u[a], 1e-14);
      for (int b = 0; b < 3; ++b) EXPECT_NEAR(m2[a][b], rho * ((a == b) * (1 - d) / 2 + u[a] * u[b]), 1e-14) << d;
    }
  }
  for (int i = 0; i < d3q19::q; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    const auto o = static_cast<std::size_t>(d3q19::opposite[iu]);
    EXPECT_EQ(d3q19::cx[iu] + d3q19::cx[o], 0);
    EXPECT_EQ(d3q19::cz[iu] + d3q19::cz[o], 0);
  }
}

TEST(Lattice, DirectionsStartOnDistinctCacheLines) {
  // The padded stride puts the first cell of each of the 19 directions on a different 64-byte
  // line modulo 4 KiB (the L1 set period of 64 sets x 64 B) in FP32 and FP16 storage, for
  // power-of-two lattices (where the unpadded layout puts them all on the same line) and
  // others; and never overlaps two directions.
  for (const Grid3 g : {Grid3{128, 128, 128}, Grid3{256, 128, 128}, Grid3{64, 64, 64}, Grid3{100, 37, 19}}) {
    const std::size_t stride = g.direction_stride();
    EXPECT_GE(stride, g.cells());
    EXPECT_EQ(g.population_size(d3q19::q), d3q19::q * stride);
    for (const std::size_t bytes : {std::size_t{4}, std::size_t{2}}) {
      std::vector<std::size_t> lines;
      for (std::size_t i = 0; i < d3q19::q; ++i) lines.push_back(i * stride * bytes % 4096 / 64);
      std::sort(lines.begin(), lines.end());
      EXPECT_EQ(std::adjacent_find(lines.begin(), lines.end()), lines.end()) << g.describe() << " " << bytes << " B";
    }
  }
}

TEST(Lattice, PeriodicSpanIsTheWrappedRow) {
  // periodic_span against its definition, row[(x0 + offset + l) mod nx], for every span the
  // kernels ask for (lines of count cells at x0 = 0, count, 2 count, ..., offset -1, 0, 1): the
  // spans inside the row, both wrap-around cases, and the vector path (count a multiple of 8,
  // nx >= 8) as well as the piecewise one (nx = 4, 12; count 4, 12).
  for (int nx : {4, 8, 12, 16, 24, 32, 128})
    for (int count : {4, 8, 12, 16, 32, 64}) {
      if (count > nx || nx % count != 0) continue;
      std::vector<float> row(static_cast<std::size_t>(nx));
      for (int x = 0; x < nx; ++x) row[static_cast<std::size_t>(x)] = 100.0f + static_cast<float>(x);
      std::vector<float> edge(static_cast<std::size_t>(count), -1.0f);
      for (int x0 = 0; x0 < nx; x0 += count)
        for (int offset : {-1, 0, 1}) {
          const float* span = periodic_span(row.data(), nx, x0, offset, count, edge.data());
          for (int l = 0; l < count; ++l)
            EXPECT_EQ(span[l], 100.0f + static_cast<float>(((x0 + offset + l) % nx + nx) % nx))
                << "nx " << nx << ", count " << count << ", x0 " << x0 << ", offset " << offset << ", lane " << l;
        }
    }
}

TEST(Bgk, PoiseuilleChannel) {
  // Body force F along x between no-slip walls at z = 0 and z = H (halfway bounce-back):
  // u(z) = F z (H - z) / (2 rho nu), nu = (xi - 1/2)/3.
  const int h = 24;
  const double force = 1e-6, xi = 1.0;
  BgkSolver s({4, 4, h}, xi, ZBoundary::walls, {force, 0, 0});
  s.initialise(1.0);
  for (int t = 0; t < 12000; ++t) s.step();  // ~5 viscous times H^2 / nu
  double num = 0, den = 0;
  for (int z = 0; z < h; ++z) {
    const double zz = z + 0.5;
    const double exact = force * zz * (h - zz) / (2 * 1.0 * s.viscosity());
    const double u = s.velocity(s.grid().index(1, 2, z))[0];
    num += (u - exact) * (u - exact);
    den += exact * exact;
  }
  std::printf("[ measured ] Poiseuille L2 error %.2e\n", std::sqrt(num / den));
  EXPECT_LT(std::sqrt(num / den), 0.01) << "expected second-order accuracy";
}

TEST(Bgk, MassConservedInAPeriodicBox) {
  BgkSolver s({8, 8, 8}, 0.8, ZBoundary::periodic, {1e-4, 2e-4, -1e-4});
  s.initialise(1.0);
  const double m0 = s.total_mass();
  for (int t = 0; t < 100; ++t) s.step();
  EXPECT_NEAR(s.total_mass() / m0, 1.0, 1e-6);  // FP32 populations, double sums
}

WaterModelParams periodic_params() {
  WaterModelParams p;
  p.periodic_z = true;
  return p;
}

TEST(WaterModel, EachComponentsMassConserved) {
  // Conserved to 1e-6 relative over 100 steps without sources (periodic box, so the
  // fixed-temperature layers, the only sources, are off). Collision conserves each component's
  // mass (eq. 3) and streaming moves it; FP32 rounding stays far below 1e-6 in double sums.
  WaterModel w({16, 16, 16}, periodic_params());
  const Grid3 g{16, 16, 16};
  w.initialise(make_silos(g, w.params(), 4), 4);
  const double m1 = w.total(0), m2 = w.total(1);
  for (int t = 0; t < 100; ++t) w.step();
  std::printf("[ measured ] relative drift over 100 steps: vapour %.1e, temperature %.1e\n", w.total(0) / m1 - 1,
              w.total(1) / m2 - 1);
  EXPECT_NEAR(w.total(0) / m1, 1.0, 1e-6);
  EXPECT_NEAR(w.total(1) / m2, 1.0, 1e-6);
  std::string what;
  std::size_t cell = 0;
  EXPECT_TRUE(w.check(what, cell)) << what;
}

TEST(WaterModel, SilosAndTemperatureGradient) {
  const Grid3 g{32, 32, 24};
  WaterModel w(g, WaterModelParams{});
  const auto silos = make_silos(g, w.params(), 11);
  ASSERT_EQ(silos.size(), 4u);
  w.initialise(silos, 11);
  const auto v = w.vapour(), t = w.temperature();
  // Inside a silo: uniform in [0.99, 1.01] rho10. Far outside: the background.
  const Silo& s = silos[0];
  const float inside = v[g.index(static_cast<int>(s.x), static_cast<int>(s.y), 1)];
  EXPECT_GE(inside, 0.99f - 1e-6f);
  EXPECT_LE(inside, 1.01f + 1e-6f);
  // Linear temperature: bottom 0.505, top 0.495.
  EXPECT_NEAR(t[g.index(0, 0, 0)], 0.505, 1e-6);
  EXPECT_NEAR(t[g.index(0, 0, g.nz - 1)], 0.495, 1e-6);
  EXPECT_NEAR(t[g.index(0, 0, 12)], 0.505 - 0.01 * 12 / 23.0, 1e-6);
}

class WaterModelStorage : public ::testing::TestWithParam<Storage> {};
INSTANTIATE_TEST_SUITE_P(Storage, WaterModelStorage, ::testing::Values(Storage::fp32, Storage::fp16),
                         [](const auto& param_info) { return std::string(to_string(param_info.param)); });

TEST_P(WaterModelStorage, StableDeterministicAndResumable) {
  const Grid3 g{24, 24, 24};
  WaterModelParams p;
  p.storage = GetParam();
  auto make = [&] {
    WaterModel w(g, p);
    w.initialise(make_silos(g, w.params(), 5), 5);
    return w;
  };
  set_threads(1);
  WaterModel a = make();
  for (int t = 0; t < 20; ++t) a.step();
  set_threads(2);
  WaterModel b = make();
  for (int t = 0; t < 10; ++t) b.step();
  const auto path = test_support::temp_path("lbm_ck.bin");
  b.save(path);
  WaterModel c = WaterModel::load(path);
  std::filesystem::remove(path);
  EXPECT_EQ(c.steps_done(), 10);
  EXPECT_EQ(c.params().storage, GetParam());
  for (int t = 0; t < 10; ++t) c.step();
  // 1, 2, 3 and 5 threads cut the 24 rows into blocks of 24, 12, 8 and 4 (see fused_step_impl).
  for (const int threads : {3, 5}) {
    set_threads(threads);
    WaterModel d = make();
    for (int t = 0; t < 20; ++t) d.step();
    const auto va = a.vapour(), vd = d.vapour();
    EXPECT_EQ(std::memcmp(va.data(), vd.data(), va.size() * sizeof(float)), 0) << threads << " threads";
  }
  set_threads(0);
  const auto va = a.vapour(), vc = c.vapour();
  EXPECT_EQ(std::memcmp(va.data(), vc.data(), va.size() * sizeof(float)), 0);  // 1 vs 2 threads, resumed
  std::string what;
  std::size_t cell = 0;
  EXPECT_TRUE(a.check(what, cell)) << what << " at " << cell;
  // Bottom/top layers hold the fixed temperatures.
  const auto t = a.temperature();
  EXPECT_NEAR(t[g.index(3, 3, 0)], 0.505, 1e-6);
  EXPECT_NEAR(t[g.index(3, 3, g.nz - 1)], 0.495, 1e-6);
}

TEST(WaterModel, CollisionMomentsOfLinearFields) {
  // One step from rest equilibrium with vapour and temperature linear in x and y. Streaming a
  // rest equilibrium of a linear field leaves each cell's density and gives it the momentum
  // j = -c_s^2 grad(rho) and the second moment rho c_s^2 I exactly (the weights' odd moments
  // vanish; c_s^2 = (1 - d)/2, eq. 19). The isotropic stencil is exact on linear fields and
  // accurate to ~1e-8 on Psi_1 here (|grad rho|^3 times its third derivative). So after the
  // collision, with eqs. (9), (10), (25) and (31) written out:
  //   sum f = rho,  sum f c = j (1 - 1/xi) + rho v / xi,
  //   sum f c c = (1 - 1/xi) rho c_s^2 I + (rho c_s^2 I + rho v v) / xi,  v = u' + xi F / rho.
  // Faults caught: any gradient weight off (the diagonal one 5 % too large scales every
  // gradient by 1.033), a wrong force, common velocity, shift or equilibrium coefficient.
  // Tolerance 2e-7 on values of 1e-3 to 0.4: FP32 populations round to ~3e-9 each and the
  // forces come from differences of FP32 Psi over two cells (relative ~3e-5 of ~2e-3).
  for (const bool periodic_z : {false, true}) {  // the fused wavefront step and the two-sweep one
    WaterModelParams p;
    p.periodic_z = periodic_z;
    const Grid3 g{16, 16, 8};
    const double b1[2] = {0.004, 0.0025}, b2[2] = {0.0012, -0.0018};  // gradients [per cell]
    auto rho1 = [&](int x, int y) { return 0.7 + b1[0] * (x - 8) + b1[1] * (y - 8); };
    auto rho2 = [&](int x, int y) { return 0.5 + b2[0] * (x - 8) + b2[1] * (y - 8); };
    std::vector<float> v(g.cells()), t(g.cells());
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x)
          v[g.index(x, y, z)] = static_cast<float>(rho1(x, y)), t[g.index(x, y, z)] = static_cast<float>(rho2(x, y));
    WaterModel w(g, p);
    w.initialise_fields(v, t);
    w.step();
    const double cs2 = (1 - p.rest_fraction) / 2, xi[2] = {p.xi_vapour, p.xi_temperature};
    double worst = 0;
    // Away from the periodic wrap of the linear fields (x, y = 0 | 15) and from the walls.
    for (int z = 1; z < g.nz - 1; ++z)
      for (int y = 2; y < g.ny - 2; ++y)
        for (int x = 2; x < g.nx - 2; ++x) {
          // The fields as float, as the model holds them.
          const double r[2] = {static_cast<float>(rho1(x, y)), static_cast<float>(rho2(x, y))};
          const double grad[2][3] = {{b1[0], b1[1], 0}, {b2[0], b2[1], 0}};
          const double psi = p.rho10 * (1 - std::exp(-r[0] / p.rho10)), dpsi = std::exp(-r[0] / p.rho10);
          const double g11 = -(1 - p.rest_fraction) / p.rho10 * (1 + p.rho20 - r[1]);
          double force[2][3], j[2][3], u[3];
          for (int a = 0; a < 3; ++a) {
            force[0][a] = -psi * (2 * g11 * dpsi * grad[0][a] + p.g12 * grad[1][a]);
            force[1][a] = -r[1] * (p.g12 * dpsi * grad[0][a] + p.g22 * grad[1][a]);
            for (int c = 0; c < 2; ++c) j[c][a] = -cs2 * grad[c][a];
            u[a] = (j[0][a] / xi[0] + j[1][a] / xi[1]) / (r[0] / xi[0] + r[1] / xi[1]);
          }
          force[0][2] += r[0] * p.buoyancy * (r[1] - p.buoyancy_reference);
          for (int c = 0; c < 2; ++c) {
            const auto m = w.moments(c, x, y, z);
            double vel[3];
            for (int a = 0; a < 3; ++a) vel[a] = u[a] + xi[c] * force[c][a] / r[c];
            worst = std::max(worst, std::abs(m.density - r[c]));
            for (int a = 0; a < 3; ++a) {
              const double expected = j[c][a] * (1 - 1 / xi[c]) + r[c] * vel[a] / xi[c];
              worst = std::max(worst, std::abs(m.momentum[static_cast<std::size_t>(a)] - expected));
            }
            const int ab[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
            for (int k = 0; k < 6; ++k) {
              const int a = ab[k][0], b = ab[k][1];
              const double expected = (a == b ? r[c] * cs2 : 0.0) + r[c] * vel[a] * vel[b] / xi[c];
              worst = std::max(worst, std::abs(m.second[static_cast<std::size_t>(k)] - expected));
            }
          }
        }
    std::printf("%s: largest moment error %.2e\n", periodic_z ? "two-sweep step" : "fused step", worst);
    EXPECT_LT(worst, 2e-7) << (periodic_z ? "two-sweep step" : "fused step");
  }
}

namespace {
// The long-wave interdiffusion coefficient of the water model's two components, derived in
// docs/lbm.md ("The lattice's own unstable window") from the kinetic step at first order in
// the gradients: with G12 = G22 = 0, no buoyancy, c_s^2 = (1 - d)/2 and p1'(rho_1) = c_s^2 +
// 2 G11 Psi_1 Psi_1',
//   D = c_s^2 (p1' (rho_2 xi_1 + rho_1 (xi_2 - 1/2)) - rho_2 c_s^2 / 2) / (rho_2 c_s^2 + rho_1 p1'),
// so that a long vapour wave at constant pressure grows as exp(-D k^2 t).
double vapour_pressure_slope(const WaterModelParams& p, double rho1, double rho2) {
  const double g11 = -(1 - p.rest_fraction) / p.rho10 * (1 + p.rho20 - rho2);
  const double e = std::exp(-rho1 / p.rho10);
  return (1 - p.rest_fraction) / 2 + 2 * g11 * p.rho10 * (1 - e) * e;
}
double interdiffusion(const WaterModelParams& p, double rho1, double rho2) {
  const double cs2 = (1 - p.rest_fraction) / 2, dp1 = vapour_pressure_slope(p, rho1, rho2);
  return cs2 * (dp1 * (rho2 * p.xi_vapour + rho1 * (p.xi_temperature - 0.5)) - 0.5 * rho2 * cs2) /
         (rho2 * cs2 + rho1 * dp1);
}

// The growth rate [per step] of a vapour wave of n cells along x about rho1, with the
// temperature wave that keeps the pressure uniform, measured on the solver: the least-squares
// slope of ln |amplitude| over the last two thirds of `steps`.
double wave_growth_rate(const WaterModelParams& p, double rho1, double rho2, int n, int steps) {
  const Grid3 g{n, 4, 4};
  const double cs2 = (1 - p.rest_fraction) / 2, k = 2 * M_PI / n, eps = 2e-3;
  const double dp1 = vapour_pressure_slope(p, rho1, rho2);
  std::vector<float> v(g.cells()), t(g.cells());
  for (int z = 0; z < g.nz; ++z)
    for (int y = 0; y < g.ny; ++y)
      for (int x = 0; x < g.nx; ++x) {
        v[g.index(x, y, z)] = static_cast<float>(rho1 + eps * std::cos(k * x));
        t[g.index(x, y, z)] = static_cast<float>(rho2 - eps * dp1 / cs2 * std::cos(k * x));
      }
  WaterModel w(g, p);
  w.initialise_fields(v, t);
  auto log_amplitude = [&] {
    const auto f = w.vapour();
    double a = 0;
    for (std::size_t i = 0; i < f.size(); ++i)
      a += (f[i] - rho1) * std::cos(k * static_cast<double>(i % static_cast<std::size_t>(n)));
    return std::log(std::abs(2 * a / static_cast<double>(f.size())));
  };
  double st = 0, sa = 0, stt = 0, sta = 0, count = 0;
  for (int s = 1; s <= steps; ++s) {
    w.step();
    if (3 * s < steps) continue;
    const double a = log_amplitude();
    st += s, sa += a, stt += double(s) * s, sta += s * a, ++count;
  }
  return (count * sta - st * sa) / (count * stt - st * st);
}
// The same wave and measurement on the water model's equations linearised about the uniform
// state (docs/lbm.md, "The lattice's own unstable window"): the complex amplitudes of the 2 x 19
// post-collision populations of the Fourier mode k along x, streamed (f_i times e^{-i k c_ix})
// and collided with the linearised eqs. (9), (10), (25) and (31) (G12 = G22 = 0, no buoyancy):
// drho_c = sum_i f_c,i, j_c = sum_i f_c,i c_i, F_1 = -2 G11 Psi_1 Psi_1' (i K) drho_1 with the
// gradient stencil's symbol K = sum_i (w_i / c_s^2) c_ix sin(k c_ix) (weights 1/18, 1/36,
// Qian et al. 1992), f_eq = w_i drho + rho k1_i c_i.v (the seed's equilibrium, first order).
double linear_growth_rate(const WaterModelParams& p, double rho1, double rho2, int n, int steps) {
  using C = std::complex<double>;
  const double k = 2 * M_PI / n, d = p.rest_fraction, cs2 = (1 - d) / 2;
  const double dp1 = vapour_pressure_slope(p, rho1, rho2);
  const double rho[2] = {rho1, rho2}, xi[2] = {p.xi_vapour, p.xi_temperature};
  const double g11 = -(1 - d) / p.rho10 * (1 + p.rho20 - rho2);
  const double psi = p.rho10 * (1 - std::exp(-rho1 / p.rho10)), dpsi = std::exp(-rho1 / p.rho10);
  double symbol = 0;  // K
  std::array<double, d3q19::q> w{}, k1{};
  for (int i = 0; i < d3q19::q; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    const bool axis = i >= 1 && i <= 6;
    w[iu] = i == 0 ? d : axis ? (1 - d) / 12 : (1 - d) / 24;
    k1[iu] = i == 0 ? 0 : axis ? 1.0 / 6 : 1.0 / 12;
    symbol += (i == 0 ? 0.0 : axis ? 1.0 / 6 : 1.0 / 12) * d3q19::cx[iu] * std::sin(k * d3q19::cx[iu]);
  }
  std::array<std::array<C, d3q19::q>, 2> f;
  for (int i = 0; i < d3q19::q; ++i) f[0][static_cast<std::size_t>(i)] = w[static_cast<std::size_t>(i)] * 1.0;
  for (int i = 0; i < d3q19::q; ++i) f[1][static_cast<std::size_t>(i)] = w[static_cast<std::size_t>(i)] * (-dp1 / cs2);
  double st = 0, sa = 0, stt = 0, sta = 0, count = 0;
  for (int s = 1; s <= steps; ++s) {
    std::array<C, 3> j[2];
    C drho[2];
    for (int c = 0; c < 2; ++c) {
      drho[c] = 0, j[c] = {0, 0, 0};
      for (int i = 0; i < d3q19::q; ++i) {
        const auto iu = static_cast<std::size_t>(i);
        f[c][iu] *= std::exp(C(0, -k * d3q19::cx[iu]));  // pull streaming
        drho[c] += f[c][iu];
        j[c][0] += f[c][iu] * double(d3q19::cx[iu]), j[c][1] += f[c][iu] * double(d3q19::cy[iu]);
        j[c][2] += f[c][iu] * double(d3q19::cz[iu]);
      }
    }
    const C force_x = -psi * 2 * g11 * C(0, symbol) * dpsi * drho[0];
    for (int c = 0; c < 2; ++c) {
      std::array<C, 3> v;
      for (std::size_t a = 0; a < 3; ++a)
        v[a] = (j[0][a] / xi[0] + j[1][a] / xi[1]) / (rho[0] / xi[0] + rho[1] / xi[1]);
      if (c == 0) v[0] += xi[0] * force_x / rho[0];
      for (int i = 0; i < d3q19::q; ++i) {
        const auto iu = static_cast<std::size_t>(i);
        const C cu = double(d3q19::cx[iu]) * v[0] + double(d3q19::cy[iu]) * v[1] + double(d3q19::cz[iu]) * v[2];
        const C feq = w[iu] * drho[c] + rho[c] * k1[iu] * cu;
        f[c][iu] -= (f[c][iu] - feq) / xi[c];
      }
    }
    if (3 * s < steps) continue;
    C amplitude = 0;
    for (const C& x : f[0]) amplitude += x;
    const double a = std::log(std::abs(amplitude.real()));
    st += s, sa += a, stt += double(s) * s, sta += s * a, ++count;
  }
  return (count * sta - st * sa) / (count * stt - st * st);
}
}  // namespace

TEST(WaterModel, UnstableWindowIsTheLatticesOwn) {
  // Eq. (30) puts the spinodal, dp/drho_1 < 0, at 0.625 < rho_1 < 0.766 (rho_2 = 0.5). The
  // lattice's window is wider: the interdiffusion of the two components turns negative first,
  // at 0.269 < rho_1 < 1.116 (docs/lbm.md derives it from eq. (26): the force enters with xi,
  // the pressure with xi - 1/2). Checked three ways:
  // (a) The solver's growth rate of a vapour wave (48 and 64 cells) against the linearised
  //     equations run through the same 300 steps and fit: agreement within 2e-3 in s/k^2, the
  //     effect of FP32 rounding (~1e-8 per step on amplitude changes of >= 1e-6) and of the
  //     wave's second-order terms (amplitude 2e-3); measured at most 4e-4. A diagonal gradient
  //     weight 5 % too large moves s/k^2 by ~0.02.
  // (b) The linearised equations' long-wave limit (a 1024-cell wave, run to its slowest mode)
  //     against the closed-form -D of interdiffusion(): within 5e-4 (the
  //     finite k's correction c k^2 with c ~ 0.7 is 3e-5 there; measured at most 1.1e-4).
  // (c) Signs: waves grow at rho_1 = 0.5 and 1.0, outside eq. (30)'s window, and decay at 0.2
  //     and 1.3, outside the lattice's.
  WaterModelParams p;
  p.periodic_z = true;
  p.g12 = 0;  // only G11, as eqs. (29)-(30) assume
  p.buoyancy = 0;
  double worst = 0;
  for (double rho1 : {0.2, 0.25, 0.3, 0.5, 0.7, 1.0, 1.1, 1.15, 1.3}) {
    for (int n : {48, 64}) {
      const double k2 = std::pow(2 * M_PI / n, 2);
      const double solver = wave_growth_rate(p, rho1, 0.5, n, 300) / k2;
      const double linear = linear_growth_rate(p, rho1, 0.5, n, 300) / k2;
      worst = std::max(worst, std::abs(solver - linear));
      EXPECT_NEAR(solver, linear, 2e-3) << "rho1 " << rho1 << ", " << n << " cells";
    }
    const double k2 = std::pow(2 * M_PI / 1024, 2);
    const double long_wave = linear_growth_rate(p, rho1, 0.5, 1024, 60000) / k2;
    std::printf("rho1 %.2f: -D %+.5f, linearised s/k^2 at 1024 cells %+.5f\n", rho1, -interdiffusion(p, rho1, 0.5),
                long_wave);
    EXPECT_NEAR(long_wave, -interdiffusion(p, rho1, 0.5), 5e-4) << "rho1 " << rho1;
  }
  std::printf("largest |solver - linearised| in s/k^2: %.2e\n", worst);
  for (double rho1 : {0.5, 1.0}) EXPECT_GT(wave_growth_rate(p, rho1, 0.5, 64, 300), 0) << rho1;
  for (double rho1 : {0.2, 1.3}) EXPECT_LT(wave_growth_rate(p, rho1, 0.5, 64, 300), 0) << rho1;
  // The closed form's zeros, the window's edges quoted above and in docs/lbm.md.
  EXPECT_LT(interdiffusion(p, 0.268, 0.5) * interdiffusion(p, 0.270, 0.5), 0);
  EXPECT_LT(interdiffusion(p, 1.115, 0.5) * interdiffusion(p, 1.117, 0.5), 0);
}

TEST_P(WaterModelStorage, SlabDecompositionIsBitIdentical) {
  // Three slabs along y exchanging halo rows (what the MPI driver does between ranks, done
  // here in one process) reproduce the undecomposed run bit for bit.
  const Grid3 g{16, 18, 12};
  WaterModelParams p;
  p.storage = GetParam();
  const auto silos = make_silos(g, p, 21);
  WaterModel whole(g, p);
  whole.initialise(silos, 21);
  const int cuts[4] = {0, 5, 11, 18};
  std::vector<WaterModel> slabs;
  for (int r = 0; r < 3; ++r) slabs.emplace_back(g, p, cuts[r], cuts[r + 1]);
  auto exchange = [&](WaterModel&, WaterModel::Exchange kind) {
    // Called by slab 0 (first to step) only: exchange all halos of all slabs at once.
    std::vector<std::vector<float>> low(3), high(3);
    for (int r = 0; r < 3; ++r) {
      low[static_cast<std::size_t>(r)] =
          slabs[static_cast<std::size_t>(r)].pack_row(kind, slabs[static_cast<std::size_t>(r)].owned_begin());
      high[static_cast<std::size_t>(r)] =
          slabs[static_cast<std::size_t>(r)].pack_row(kind, slabs[static_cast<std::size_t>(r)].owned_end() - 1);
    }
    for (int r = 0; r < 3; ++r) {
      auto& s = slabs[static_cast<std::size_t>(r)];
      s.unpack_row(kind, 0, high[static_cast<std::size_t>((r + 2) % 3)]);                // from the slab below
      s.unpack_row(kind, s.local_ny() - 1, low[static_cast<std::size_t>((r + 1) % 3)]);  // from the slab above
    }
  };
  for (auto& s : slabs) s.initialise(silos, 21);
  // Step the slabs in lockstep: each exchange must see every slab at the same stage, so the
  // exchange runs once per stage from a driver loop rather than inside each slab's step.
  for (int t = 0; t < 8; ++t) {
    whole.step();
    exchange(slabs[0], WaterModel::Exchange::populations);
    for (auto& s : slabs) s.step_stage(WaterModel::Stage::stream);
    exchange(slabs[0], WaterModel::Exchange::densities);
    for (auto& s : slabs) s.step_stage(WaterModel::Stage::collide);
  }
  const auto ref = whole.vapour();
  for (int r = 0; r < 3; ++r) {
    const auto v = slabs[static_cast<std::size_t>(r)].vapour();
    const int own = cuts[r + 1] - cuts[r];
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < own; ++y)
        for (int x = 0; x < g.nx; ++x)
          ASSERT_EQ(v[(static_cast<std::size_t>(z) * own + y) * g.nx + x], ref[g.index(x, cuts[r] + y, z)])
              << "slab " << r << " at " << x << "," << y << "," << z;
  }
  // Checkpoints do not depend on the decomposition: each slab writing its own rows into the
  // created file (in any order: here the last slab first) gives the same file, byte for
  // byte, as the whole lattice; slabs loaded from that file hold exactly their rows (and step
  // on to the same state: tests/mpi_test.py).
  const auto dir = test_support::temp_path("slab_checkpoint");
  std::filesystem::create_directories(dir);
  whole.save(dir / "whole.bin");
  WaterModel::create_checkpoint(dir / "gathered.bin", g, p, whole.steps_done());
  for (int r = 2; r >= 0; --r) slabs[static_cast<std::size_t>(r)].write_owned(dir / "gathered.bin");
  EXPECT_EQ(test_support::file_bytes(dir / "whole.bin"), test_support::file_bytes(dir / "gathered.bin"));
  EXPECT_EQ(WaterModel::checkpoint_grid(dir / "whole.bin").ny, g.ny);
  for (int r = 0; r < 3; ++r) {
    const WaterModel loaded = WaterModel::load_slab(dir / "whole.bin", cuts[r], cuts[r + 1]);
    EXPECT_EQ(loaded.steps_done(), whole.steps_done());
    EXPECT_EQ(loaded.pack_owned(), slabs[static_cast<std::size_t>(r)].pack_owned()) << "slab " << r;
  }
  EXPECT_THROW(slabs[0].save(dir / "slab.bin"), ValueError);  // a slab alone is not a checkpoint
  if (GetParam() == Storage::fp32) {
    // CK3 and CK2 files (no checksums; CK2 no storage parameter either, so their populations
    // start 8 and 16 bytes before CK4's) still load, whole and as slabs.
    for (int format : {3, 2}) {
      std::ofstream(dir / "old.bin", std::ios::binary)
          << older_format(test_support::file_bytes(dir / "whole.bin"), g, format);
      EXPECT_EQ(WaterModel::load(dir / "old.bin").pack_owned(), whole.pack_owned()) << "CK" << format;
      for (int r = 0; r < 3; ++r)
        EXPECT_EQ(WaterModel::load_slab(dir / "old.bin", cuts[r], cuts[r + 1]).pack_owned(),
                  slabs[static_cast<std::size_t>(r)].pack_owned())
            << "CK" << format << ", slab " << r;
    }
  }
  std::filesystem::remove_all(dir);
}

TEST(WaterModel, Fp16StorageHoldsAccuracy) {
  // FP16 storage rounds every stored moving population to 11 significant bits of its deviation
  // from the rest value w_i rho_ref (FP32: 24 bits), so its error scales with |rho - rho_ref|;
  // the rest population stays FP32 and takes up what that rounding lost (conservative
  // rounding), so mass is conserved as in FP32.
  // (a) Stable cases in a periodic box (no sources), 1e-3 noise, 100 steps, against FP32.
  auto run = [](Storage storage, double rho1) {
    WaterModelParams p;
    p.periodic_z = true;
    p.storage = storage;
    WaterModel w({24, 24, 24}, p);
    w.initialise_uniform(rho1, 0.5, 1e-3, 3);
    const double m0 = w.total(0), t0 = w.total(1);
    for (int t = 0; t < 100; ++t) w.step();
    return std::tuple{w.vapour(), w.total(0) / m0 - 1, w.total(1) / t0 - 1};
  };
  for (double rho1 : {1.0, 0.3}) {
    const auto [v32, dm32, dt32] = run(Storage::fp32, rho1);
    const auto [v16, dm16, dt16] = run(Storage::fp16, rho1);
    double dv = 0;
    for (std::size_t k = 0; k < v32.size(); ++k) dv = std::max(dv, std::abs(double(v32[k]) - v16[k]));
    std::printf("vapour %.1f rho10, 100 steps: max |FP16 - FP32| %.2e; mass drift FP16 %.2e (temperature %.2e)\n", rho1,
                dv, dm16, dt16);
    // The mass bound, 1e-6 relative over 100 steps, for both components: measured 1.6e-9 and
    // 9.5e-8 for the vapour, 1.6e-9 and 1e-9 for the temperature. Fault caught: FP16 rounding
    // not taken up by the rest population (3.8e-4 at 0.3 rho10).
    EXPECT_LT(std::abs(dm16), 1e-6);
    EXPECT_LT(std::abs(dt16), 1e-6);
    if (rho1 == 1.0) {
      // At the reference density (silo interiors, condensed cloud) FP16 loses nothing that
      // matters: measured 1.1e-5; bound about 4x.
      EXPECT_LT(dv, 5e-5);
    } else {
      // At 0.3 rho10 the vapour is unstable (spinodal, eq. 30): in FP32 the noise grows from
      // a spread of 6e-4 after 10 steps to 1.1e-2 after 100, while FP16, whose spacing there
      // (3e-5 on a deviation of 0.05) is coarser than the noise on one population, rounds the
      // growing modes' momentum away and the spread decays (4e-4). Measured 6.2e-3; bound 3x.
      EXPECT_LT(dv, 2e-2);
    }
  }

  // (b) The default silo case, where the vapour condenses: a physical instability (spinodal
  // decomposition, eq. 30) amplifies any difference, rounding included, so cells are compared
  // statistically: the condensed fraction (vapour > 0.9 rho10) and the mean vapour density.
  const Grid3 g{32, 32, 24};
  auto silo = [&](Storage storage) {
    WaterModelParams p;
    p.storage = storage;
    WaterModel w(g, p);
    w.initialise(make_silos(g, p, 8), 8);
    for (int t = 0; t < 100; ++t) w.step();
    const auto v = w.vapour();
    double mean = 0, condensed = 0;
    for (float x : v) mean += x, condensed += x > 0.9f ? 1 : 0;
    return std::pair{mean / static_cast<double>(v.size()), condensed / static_cast<double>(v.size())};
  };
  const auto [mean32, cond32] = silo(Storage::fp32);
  const auto [mean16, cond16] = silo(Storage::fp16);
  std::printf("silo case, 100 steps: mean vapour %.6f / %.6f, condensed fraction %.4f / %.4f (FP32 / FP16)\n", mean32,
              mean16, cond32, cond16);
  // Measured differences 5e-5 (mean) and 1e-4 (condensed fraction, 3 of 24 576 cells). Bounds
  // 5e-4 and 0.005 (123 cells): ten and fifty times that, and far below what a fault in the FP16
  // paths that only this case runs (the wall layers and silo initialisation, written through
  // Populations::write/set) gives: halves scaled by 2 there blow the run up to NaN.
  EXPECT_NEAR(mean16, mean32, 5e-4);
  EXPECT_NEAR(cond16, cond32, 0.005);
}

TEST(WaterModel, ACheckpointStoresEveryNanAsTheOneQuietNan) {
  // IEEE 754 leaves the sign and payload of a NaN an operation makes open, and a slab's loops
  // and the whole lattice's may order the operands differently, so a blown-up run's NaNs
  // differed in their sign bit between process counts (found by an AddressSanitizer build's
  // code generation). A checkpoint stores every NaN as 0x7FC00000 and the stop message says
  // "NaN", so both are the same whatever the process count; every other value is kept bit for
  // bit.
  const auto path = test_support::temp_path("nan_ck.bin"), again = test_support::temp_path("nan_ck2.bin"),
             slabs = test_support::temp_path("nan_ck3.bin");
  const Grid3 g{8, 8, 8};
  WaterModel m(g, WaterModelParams{});
  m.initialise_uniform(0.3, 0.5, 0.01, 7);
  m.save(path);
  const std::string ck4 = test_support::file_bytes(path);
  // The NaNs go into a CK3 copy (no checksums, which they would break); the files written from
  // it are CK4 again.
  std::string bytes = older_format(ck4, g, 3);
  const std::size_t header = 16 + 4 * 8 + 19 * 8, cells = g.cells();
  auto at = [&](int c, int i, std::size_t cell) {
    return header + 4 * ((static_cast<std::size_t>(c) * 19 + i) * cells + cell);
  };
  auto put = [&](std::size_t offset, std::uint32_t bits) { std::memcpy(bytes.data() + offset, &bits, 4); };
  put(at(0, 3, 10), 0xFFC00000u);   // -NaN, the x86 default NaN (cell x=2, y=1, z=0)
  put(at(1, 0, 100), 0x7FC01234u);  // a quiet NaN with a payload
  put(at(1, 7, 200), 0xFFC0ABCDu);  // negative, with a payload
  std::ofstream(path, std::ios::binary) << bytes;
  const WaterModel blown = WaterModel::load(path);
  const auto message = blown.bad_density();
  ASSERT_TRUE(message.has_value());
  EXPECT_NE(message->find("vapour density NaN at cell (x=2, y=1, z=0)"), std::string::npos) << *message;
  blown.save(again);
  WaterModel::create_checkpoint(slabs, g, blown.params(), blown.steps_done());
  for (const auto& [y0, y1] : {std::pair{5, 8}, std::pair{0, 5}})
    WaterModel::load_slab(path, y0, y1).write_owned(slabs);
  const std::string saved = test_support::file_bytes(again), written = test_support::file_bytes(slabs);
  // The first byte at which two files differ (npos: none), a short failure message for 1 MiB.
  auto first_difference = [](const std::string& a, const std::string& b) {
    const auto [pa, pb] = std::mismatch(a.begin(), a.end(), b.begin(), b.end());
    return pa == a.end() && pb == b.end() ? std::string::npos : static_cast<std::size_t>(pa - a.begin());
  };
  ASSERT_EQ(saved.size(), ck4.size());
  EXPECT_EQ(first_difference(saved, written), std::string::npos);  // the slabs' file is the whole lattice's
  std::string expected = bytes;
  for (std::size_t o : {at(0, 3, 10), at(1, 0, 100), at(1, 7, 200)}) {
    const std::uint32_t quiet = 0x7FC00000u;
    std::memcpy(expected.data() + o, &quiet, 4);
  }
  // The NaNs canonical, the rest as it was; the file whole by its checksums.
  EXPECT_EQ(first_difference(older_format(saved, g, 3), expected), std::string::npos);
  EXPECT_TRUE(WaterModel::load(again).bad_density().has_value());
  for (const auto& f : {path, again, slabs}) std::filesystem::remove(f);
}

TEST(WaterModel, CheckpointErrors) {
  const auto path = test_support::temp_path("not_ck.bin");
  { std::ofstream(path) << "hello"; }
  EXPECT_THROW(WaterModel::load(path), FormatError);
  std::filesystem::remove(path);
  EXPECT_THROW(WaterModel::load(path), IoError);
  EXPECT_THROW(Grid3::parse("12x12"), ValueError);
  EXPECT_THROW(Grid3::parse("2x12x12"), ValueError);
  EXPECT_EQ(Grid3::parse("128x64x32").ny, 64);
  // A checkpoint whose header was damaged: a NaN parameter, a silo count that is not an integer,
  // a negative lattice edge or step are each a FormatError, not a model that runs into NaN: in
  // a file without checksums (CK3) by the header's checks.
  const Grid3 g{8, 8, 8};
  WaterModel m(g, WaterModelParams{});
  m.save(path);
  const std::string good = test_support::file_bytes(path), good_ck3 = older_format(good, g, 3);
  const std::size_t params_at = 16 + 4 * 8;  // magic, (nx, ny, nz, step), then the parameters
  auto damaged = [&](const std::string& file, std::size_t at, auto value) {
    std::string bytes = file;
    std::memcpy(bytes.data() + at, &value, sizeof value);
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  };
  EXPECT_THROW(WaterModel::load(damaged(good_ck3, params_at, std::nan(""))), FormatError);       // rho10
  EXPECT_THROW(WaterModel::load(damaged(good_ck3, params_at + 11 * 8, 2.5)), FormatError);       // silos
  EXPECT_THROW(WaterModel::load(damaged(good_ck3, 16, std::int64_t{-8})), FormatError);          // nx
  EXPECT_THROW(WaterModel::load(damaged(good_ck3, 16 + 3 * 8, std::int64_t{-1})), FormatError);  // step
  EXPECT_EQ(WaterModel::load(damaged(good_ck3, params_at + 11 * 8, 7.0)).params().silos, 7);     // still whole
  // CK4 refuses any change its checksums see, also one that leaves every value plausible: the
  // silo count, one bit of a population (whole or in the slab that holds it; the other slab
  // loads), the row checksums' table itself, or a file cut short of it. Each message names the
  // file and, for a population, its row.
  auto message = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const FormatError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(message([&] { WaterModel::load(damaged(good, params_at + 11 * 8, 7.0)); }).find("header"),
            std::string::npos);
  const std::size_t populations = params_at + 19 * 8 + 8, cell = g.index(3, 5, 2);
  const std::size_t at = populations + 4 * ((1 * 19 + 4) * g.cells() + cell);  // component 1, direction 4
  auto flipped = [&](const std::string& file, std::size_t offset) {
    std::string bytes = file;
    bytes[offset] = static_cast<char>(bytes[offset] ^ 1);
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  };
  const std::string row = "component 1, direction 4, row y = 5, z = 2 do not match their checksum";
  EXPECT_NE(message([&] { WaterModel::load(flipped(good, at)); }).find(path.string() + ": corrupt checkpoint"),
            std::string::npos);
  EXPECT_NE(message([&] { WaterModel::load(flipped(good, at)); }).find(row), std::string::npos);
  EXPECT_NE(message([&] { WaterModel::load_slab(flipped(good, at), 4, 8); }).find(row), std::string::npos);
  EXPECT_EQ(message([&] { WaterModel::load_slab(flipped(good, at), 0, 4); }), "no error");
  EXPECT_NE(message([&] { WaterModel::load(flipped(good, good.size() - 3)); }).find("do not match their checksum"),
            std::string::npos);
  { std::ofstream(path, std::ios::binary) << good.substr(0, good.size() - 8); }
  EXPECT_NE(message([&] { WaterModel::load(path); }).find("truncated"), std::string::npos);
  std::filesystem::remove(path);
}

}  // namespace nephos::lbm
