// Particle generation (eqs. 3-5), motion (eq. 6), level of detail (eq. 13) and illumination
// (eqs. 14-18) against statistics, closed forms and quadrature.
#include "nephos/particles/particle_system.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <numeric>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"
#include "nephos/core/parallel.hpp"

using namespace nephos;
using namespace nephos::particles;

namespace {

PlanarGrid grid(int cols, int rows, double d = 10000) {
  PlanarGrid g;
  g.cols = cols, g.rows = rows, g.dx_m = d, g.dy_m = d;
  g.x0_m = -0.5 * (cols - 1) * d, g.y0_m = -0.5 * (rows - 1) * d;
  return g;
}

CloudColumns columns(const std::vector<float>& tau, float base = 1000, float top = 3000) {
  CloudColumns c;
  c.tau = tau;
  for (float t : tau) {
    c.base_m.push_back(t > 0 ? base : std::numeric_limits<float>::quiet_NaN());
    c.top_m.push_back(t > 0 ? top : std::numeric_limits<float>::quiet_NaN());
  }
  return c;
}

// Per-column counts of generated particles, from their positions (not from p.column).
std::vector<double> counts(const PlanarGrid& g, const Particles& p) {
  std::vector<double> n(g.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const int col = static_cast<int>(std::floor((p.x[i] - (g.x0_m - 0.5 * g.dx_m)) / g.dx_m));
    const int row = static_cast<int>(std::floor((p.y[i] - (g.y0_m - 0.5 * g.dy_m)) / g.dy_m));
    n[static_cast<std::size_t>(row * g.cols + col)] += 1;
  }
  return n;
}

double chi_square(const std::vector<double>& observed, const std::vector<double>& weight, double total) {
  const double wsum = std::accumulate(weight.begin(), weight.end(), 0.0);
  double chi2 = 0;
  for (std::size_t c = 0; c < observed.size(); ++c)
    if (weight[c] > 0) {
      const double e = total * weight[c] / wsum;
      chi2 += (observed[c] - e) * (observed[c] - e) / e;
    }
  return chi2;
}

// Upper 1 % point of the chi-square distribution with 15 degrees of freedom (NIST/SEMATECH
// e-Handbook of Statistical Methods, table 1.3.6.7.4).
constexpr double chi2_15_at_1_percent = 30.578;

}  // namespace

TEST(Generation, FollowsOpticalThicknessWeights) {
  // 6 x 3 columns, two clear: 16 cloudy columns -> 15 degrees of freedom.
  const PlanarGrid g = grid(6, 3);
  std::vector<float> tau(18);
  for (std::size_t c = 0; c < 18; ++c) tau[c] = c == 4 || c == 11 ? 0.0f : static_cast<float>(1 + c);
  const CloudColumns cols = columns(tau);
  const std::size_t n = 200000;
  const Particles p = generate(g, cols, {n, 1.0, 42});
  const auto observed = counts(g, p);
  EXPECT_EQ(observed[4], 0);
  EXPECT_EQ(observed[11], 0);
  // K = 1: a column is selected in proportion to its optical thickness.
  std::vector<double> w(18);
  for (std::size_t c = 0; c < 18; ++c) w[c] = tau[c];
  const double chi2 = chi_square(observed, w, static_cast<double>(n));
  std::cout << "[ measured ] chi-square (K = 1, 15 dof) = " << chi2 << "\n";
  EXPECT_LT(chi2, chi2_15_at_1_percent);
  // The birth column recorded agrees with the position.
  for (std::size_t i = 0; i < 1000; ++i) {
    const int col = static_cast<int>(std::floor((p.x[i] - (g.x0_m - 0.5 * g.dx_m)) / g.dx_m));
    const int row = static_cast<int>(std::floor((p.y[i] - (g.y0_m - 0.5 * g.dy_m)) / g.dy_m));
    EXPECT_EQ(p.column[i], static_cast<std::uint32_t>(row * g.cols + col));
  }
}

TEST(Generation, LargeKSaturatesThickColumns) {
  const PlanarGrid g = grid(6, 3);
  std::vector<float> tau(18);
  for (std::size_t c = 0; c < 18; ++c) tau[c] = c == 4 || c == 11 ? 0.0f : static_cast<float>(1 + c);
  const CloudColumns cols = columns(tau);
  const double k = 3;
  const std::size_t n = 200000;
  const auto observed = counts(g, generate(g, cols, {n, k, 7}));
  // Eq. 5 keeps a draw with probability min(1, K lambda / lambda_max).
  std::vector<double> w(18);
  for (std::size_t c = 0; c < 18; ++c) w[c] = std::min(1.0, tau[c] * k / 18.0);
  const double chi2 = chi_square(observed, w, static_cast<double>(n));
  std::cout << "[ measured ] chi-square (K = 3, 15 dof) = " << chi2 << "\n";
  EXPECT_LT(chi2, chi2_15_at_1_percent);
  // And not in proportion to lambda any more (the K = 1 law is rejected).
  for (std::size_t c = 0; c < 18; ++c) w[c] = tau[c];
  EXPECT_GT(chi_square(observed, w, static_cast<double>(n)), chi2_15_at_1_percent);
}

TEST(Generation, PositionsInCellAndBetweenBaseAndTop) {
  const PlanarGrid g = grid(4, 4, 5000);
  CloudColumns c = columns(std::vector<float>(16, 3.0f));
  c.base_m[5] = 2000, c.top_m[5] = 2500;
  const Particles p = generate(g, c, {20000, 1.0, 3});
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t col = p.column[i];
    EXPECT_GE(p.z[i], c.base_m[col]);
    EXPECT_LE(p.z[i], c.top_m[col]);
    EXPECT_LE(std::abs(p.x[i] - g.x(static_cast<double>(col % 4))), 2500.0f + 1e-3f);
    EXPECT_LE(std::abs(p.y[i] - g.y(static_cast<double>(col / 4))), 2500.0f + 1e-3f);
  }
}

TEST(Generation, DeterministicWhateverTheThreadCount) {
  const PlanarGrid g = grid(5, 5);
  std::vector<float> tau(25);
  for (std::size_t c = 0; c < 25; ++c) tau[c] = static_cast<float>(c % 7);
  const CloudColumns c = columns(tau);
  set_threads(1);
  const Particles a = generate(g, c, {50000, 1.0, 9});
  set_threads(4);
  const Particles b = generate(g, c, {50000, 1.0, 9});
  set_threads(0);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.y, b.y);
  EXPECT_EQ(a.z, b.z);
  const Particles other = generate(g, c, {50000, 1.0, 10});
  EXPECT_NE(a.x, other.x);
}

TEST(Generation, RefusesDegenerateInput) {
  const PlanarGrid g = grid(3, 3);
  EXPECT_THROW(generate(g, columns(std::vector<float>(9, 0.0f)), {100, 1.0, 1}), ValueError);
  EXPECT_THROW(generate(g, columns(std::vector<float>(9, 1.0f)), {100, 0.0, 1}), ValueError);
}

// ---- Motion ---------------------------------------------------------------------------------

namespace {
// Spatially uniform wind u(t) = u0 + alpha t sampled at three frames (0, 1 h, 3 h).
ParticleWeather uniform_wind(const glm::dvec3& u0, const glm::dvec3& alpha) {
  ParticleWeather w;
  w.grid = grid(4, 4, 20000);
  for (double t : {0.0, 3600.0, 10800.0}) {
    WeatherFrame f;
    f.time_s = t;
    f.columns = columns(std::vector<float>(16, 1.0f));
    f.wind.levels = 2;
    for (int k = 0; k < 2; ++k)
      for (int c = 0; c < 16; ++c) {
        const glm::dvec3 v = u0 + alpha * t;
        f.wind.z_m.push_back(k ? 10000.0f : 0.0f);
        f.wind.u.push_back(static_cast<float>(v.x));
        f.wind.v.push_back(static_cast<float>(v.y));
        f.wind.w.push_back(static_cast<float>(v.z));
      }
    w.frames.push_back(f);
  }
  return w;
}
}  // namespace

TEST(Motion, MatchesClosedFormAcrossFrames) {
  const glm::dvec3 u0{12, -4, 0.05}, alpha{0.5e-3, 0.25e-3, -1e-6};  // [m/s], [m/s^2]
  const ParticleWeather w = uniform_wind(u0, alpha);
  Particles p = generate(w.grid, w.frames[0].columns, {500, 1.0, 5});
  const Particles start = p;
  Motion m(w, p);
  for (double t : {0.0, 1800.0, 3600.0, 7200.0, 10800.0, 14400.0}) {
    m.positions_at(t, p);
    // Eq. 6 in closed form; after the last frame (10800 s) the velocity stays constant.
    const double ta = std::min(t, 10800.0), tb = t - ta;
    const glm::dvec3 shift = u0 * ta + 0.5 * alpha * ta * ta + (u0 + alpha * 10800.0) * tb;
    for (std::size_t i = 0; i < p.size(); i += 37) {
      // Tolerance: float positions of up to ~4e5 m (ulp 0.03 m) after a few float steps.
      EXPECT_NEAR(p.x[i], start.x[i] + shift.x, 0.2) << t;
      EXPECT_NEAR(p.y[i], start.y[i] + shift.y, 0.2) << t;
      EXPECT_NEAR(p.z[i], start.z[i] + shift.z, 0.02) << t;
    }
  }
}

TEST(Motion, PositionsDoNotDependOnEarlierQueries) {
  ParticleWeather w = uniform_wind({8, 3, 0}, {1e-3, 0, 0});
  // Make the wind vary in space too (shear with x), so resampling at intervals matters.
  for (auto& f : w.frames)
    for (std::size_t a = 0; a < f.wind.u.size(); ++a) f.wind.v[a] += static_cast<float>(a % 4);
  Particles p = generate(w.grid, w.frames[0].columns, {300, 1.0, 6});
  Particles q = p;
  Motion m1(w, p), m2(w, q);
  for (double t : {600.0, 4000.0, 9000.0}) m1.positions_at(t, p);
  m2.positions_at(9000.0, q);
  EXPECT_EQ(p.x, q.x);
  EXPECT_EQ(p.y, q.y);
  m1.positions_at(100.0, p);  // back in time
  m2.positions_at(100.0, q);
  EXPECT_EQ(p.x, q.x);
  EXPECT_THROW(m1.positions_at(-1.0, p), ValueError);
}

// ---- Level of detail ------------------------------------------------------------------------

TEST(Lod, BandsFollowEquation13) {
  const LodParams lod{1000.0, std::pow(2.0, 0.25)};
  EXPECT_EQ(lod_band(1000.0, lod), 0);
  EXPECT_EQ(lod_band(1000.0 * lod.band_ratio * 0.999, lod), 1);
  EXPECT_EQ(lod_band(1000.0 * lod.band_ratio * 1.001, lod), 2);
  // Particles spread along a line from the camera to 8 L0.
  Particles p;
  const std::size_t n = 200000;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.x[i] = static_cast<float>(8000.0 * (static_cast<double>(i) + 0.5) / n);
    p.y[i] = p.z[i] = 0;
  }
  const LodSelection s = select_lod(p, {0, 0, 0}, lod, 1);
  ASSERT_GE(s.band_counts.size(), 13u);
  EXPECT_EQ(s.band_kept[0], s.band_counts[0]);  // no thinning within L0
  std::size_t total = 0;
  for (std::size_t m = 1; m < s.band_counts.size(); ++m) {
    // N_m = N_0 (L0 / L_m)^3 with N_0 the band's own count (same density): within rounding.
    const double expected =
        static_cast<double>(s.band_counts[m]) * std::pow(1000.0 / lod_band_distance(static_cast<int>(m), lod), 3);
    EXPECT_NEAR(static_cast<double>(s.band_kept[m]), std::max(1.0, expected), 0.5 + 1e-9) << m;
    total += s.band_kept[m];
  }
  EXPECT_EQ(s.kept.size(), total + s.band_kept[0]);
}

TEST(Lod, UniformVolumeKeepsTheAnalyticCount) {
  // A uniform density rho of particles in a ball of radius R around the camera: eq. 13 keeps
  // rho (4/3) pi L0^3 inside L0 and Int_L0^R rho 4 pi L^2 (L0/L)^3 dL = rho 4 pi L0^3 ln(R/L0)
  // beyond. Bands of ratio r evaluated at their geometric middle over-count by
  // (r^3 - 1) / (3 r^1.5 ln r) = 1.011 for r = 2^(1/4); tolerance 3 %.
  const double radius = 20000, l0 = 2000;
  const std::size_t n = 400000;
  Particles p;
  p.resize(n);
  std::size_t m = 0;
  for (std::uint64_t k = 0; m < n; ++k) {
    const double x = (2 * uniform01(1, k, 0) - 1) * radius, y = (2 * uniform01(1, k, 1) - 1) * radius,
                 z = (2 * uniform01(1, k, 2) - 1) * radius;
    if (x * x + y * y + z * z > radius * radius) continue;
    p.x[m] = static_cast<float>(x), p.y[m] = static_cast<float>(y), p.z[m] = static_cast<float>(z);
    ++m;
  }
  const double rho = static_cast<double>(n) / (4.0 / 3.0 * M_PI * radius * radius * radius);
  const double expected = rho * 4 * M_PI * l0 * l0 * l0 * (1.0 / 3.0 + std::log(radius / l0));
  const LodSelection s = select_lod(p, {0, 0, 0}, {l0, std::pow(2.0, 0.25)}, 4);
  std::cout << "[ measured ] kept " << s.kept.size() << ", analytic " << expected << "\n";
  EXPECT_NEAR(static_cast<double>(s.kept.size()), expected, 0.03 * expected);
}

TEST(Lod, SurvivorsPersistAsTheCameraMoves) {
  Particles p;
  const std::size_t n = 50000;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.x[i] = static_cast<float>(uniform01(2, i, 0) * 1e5);
    p.y[i] = static_cast<float>(uniform01(2, i, 1) * 1e5);
    p.z[i] = 2000;
  }
  const LodParams lod{5000.0};
  auto a = select_lod(p, {0, 0, 0}, lod, 1).kept, b = select_lod(p, {100, 0, 0}, lod, 1).kept;
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  std::vector<std::uint32_t> common;
  std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(common));
  // A 100 m step moves few particles across a band edge: most survivors stay.
  EXPECT_GT(static_cast<double>(common.size()), 0.9 * static_cast<double>(std::min(a.size(), b.size())));
}

// ---- Illumination ---------------------------------------------------------------------------

namespace {
// Composite Simpson quadrature of f over [0, d] with n (even) intervals.
template <class F>
double simpson(F f, double d, int n) {
  const double h = d / n;
  double s = f(0.0) + f(d);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4 : 2) * f(i * h);
  return s * h / 3;
}
}  // namespace

TEST(Illumination, Equation17MatchesQuadrature) {
  for (std::uint64_t k = 0; k < 20; ++k) {
    const glm::dvec3 rc{uniform01(3, k, 0) * 100, uniform01(3, k, 1) * 100, uniform01(3, k, 2) * 100};
    const glm::dvec3 rd = glm::normalize(glm::dvec3{uniform01(3, k, 3) - 0.5, uniform01(3, k, 4) - 0.5, 0.3});
    const glm::dvec3 s{150, -40, 300};
    const double d = 5 + 50 * uniform01(3, k, 5), intensity = 1e4;
    const double exact = inverse_square_line_integral(rc, rd, s, d, intensity);
    const double quad = simpson(
        [&](double t) {
          const glm::dvec3 x = rc + t * rd - s;
          return intensity / glm::dot(x, x);
        },
        d, 2000);
    // Simpson with 2000 intervals on a smooth integrand: ~1e-12 relative.
    EXPECT_NEAR(exact, quad, 1e-9 * quad) << k;
  }
  // Collinear limit: towards the source from 10 m to 4 m away: I (1/4 - 1/10).
  EXPECT_NEAR(inverse_square_line_integral({0, 0, 0}, {0, 0, 1}, {0, 0, 10}, 6, 2.0), 2.0 * (0.25 - 0.1), 1e-12);
}

TEST(Illumination, OpticalDepthThroughAUniformSlab) {
  // Horizontally uniform slab 1-3 km, tau = 20 (sigma = 0.01 /m): from height z along a
  // direction of zenith angle theta the optical depth is sigma (3000 - z) / cos(theta).
  const PlanarGrid g = grid(40, 40, 2000);
  const CloudColumns c = columns(std::vector<float>(1600, 20.0f));
  for (double zen_deg : {0.0, 30.0, 60.0, 75.0}) {
    const double th = zen_deg * M_PI / 180;
    const glm::dvec3 dir{std::sin(th) * std::cos(0.3), std::sin(th) * std::sin(0.3), std::cos(th)};
    for (double z : {1000.0, 1700.0, 2900.0}) {
      const double tau = optical_depth_towards(g, c, {-1000, 500, z}, dir);
      // Tolerance: sigma is computed in float (tau / depth): 1e-7 relative.
      EXPECT_NEAR(tau, 0.01 * (3000 - z) / std::cos(th), 1e-7 * tau + 1e-12) << zen_deg << " " << z;
    }
  }
  // Below the slab looking up: the whole slab; above it: nothing.
  EXPECT_NEAR(optical_depth_towards(g, c, {0, 0, 500}, {0, 0, 1}), 20.0, 2e-6);  // float sigma
  EXPECT_EQ(optical_depth_towards(g, c, {0, 0, 3500}, {0, 0, 1}), 0.0);
}

TEST(Illumination, OpticalDepthMatchesQuadratureInBrokenCloud) {
  const PlanarGrid g = grid(12, 10, 1500);
  CloudColumns c;
  for (std::size_t q = 0; q < g.size(); ++q) {
    const bool cloudy = uniform01(8, q, 0) > 0.35;
    c.tau.push_back(cloudy ? static_cast<float>(1 + 30 * uniform01(8, q, 1)) : 0.0f);
    const float base = static_cast<float>(500 + 2000 * uniform01(8, q, 2));
    c.base_m.push_back(cloudy ? base : std::numeric_limits<float>::quiet_NaN());
    c.top_m.push_back(cloudy ? base + static_cast<float>(300 + 3000 * uniform01(8, q, 3))
                             : std::numeric_limits<float>::quiet_NaN());
  }
  auto sigma_at = [&](const glm::dvec3& x) {
    const int i = static_cast<int>(std::floor((x.x - (g.x0_m - 0.5 * g.dx_m)) / g.dx_m));
    const int j = static_cast<int>(std::floor((x.y - (g.y0_m - 0.5 * g.dy_m)) / g.dy_m));
    if (i < 0 || j < 0 || i >= g.cols || j >= g.rows) return 0.0;
    const std::size_t q = static_cast<std::size_t>(j) * g.cols + i;
    return x.z >= c.base_m[q] && x.z <= c.top_m[q] ? static_cast<double>(c.sigma_per_m(q)) : 0.0;
  };
  for (std::uint64_t k = 0; k < 12; ++k) {
    const glm::dvec3 from{(uniform01(9, k, 0) - 0.5) * 15000, (uniform01(9, k, 1) - 0.5) * 12000,
                          800 + 2500 * uniform01(9, k, 2)};
    const double zen = 0.2 + 1.1 * uniform01(9, k, 3), az = 6.283 * uniform01(9, k, 4);
    const glm::dvec3 dir{std::sin(zen) * std::cos(az), std::sin(zen) * std::sin(az), std::cos(zen)};
    const double exact = optical_depth_towards(g, c, from, dir);
    // Midpoint rule with 0.5 m steps along 60 km: each discontinuity crossed costs at most
    // sigma_max * step; a few dozen crossings bound the error by ~0.5.
    double quad = 0;
    const double h = 0.5;
    for (double t = 0.5 * h; t < 60000; t += h) quad += sigma_at(from + t * dir) * h;
    EXPECT_NEAR(exact, quad, 0.5) << k;
  }
}

TEST(Illumination, GreyValuesFromTransmissionTowardsTheLight) {
  const PlanarGrid g = grid(20, 20, 2000);
  const CloudColumns c = columns(std::vector<float>(400, 20.0f));  // 1-3 km, sigma 0.01 /m
  Particles p;
  p.resize(3);
  const double zs[3] = {2999.9, 2500, 1200};
  for (std::size_t i = 0; i < 3; ++i) p.x[i] = 0, p.y[i] = 0, p.z[i] = static_cast<float>(zs[i]), p.radius_m[i] = 50;
  Light sun;  // zenith sun
  IlluminationParams ip;
  const auto grey = illuminate(g, c, p, sun, ip);
  for (std::size_t i = 0; i < 3; ++i) {
    const double tau = 0.01 * (3000 - static_cast<double>(p.z[i]));
    // Conservative two-stream slab (eq. 3a of the fractal-cloud paper) with the similarity-scaled depth.
    EXPECT_NEAR(grey[i], ip.ambient + (1 - ip.ambient) / (1 + (1 - ip.asymmetry) * tau), 1e-5) << i;
  }
  ip.transmission = Transmission::beer;
  const auto beer = illuminate(g, c, p, sun, ip);
  EXPECT_NEAR(beer[1], ip.ambient + (1 - ip.ambient) * std::exp(-5.0), 1e-5);
  EXPECT_GT(beer[0], beer[1]);  // the boundary particle is the brightest (seed's remark)
  EXPECT_GT(beer[1], beer[2]);
  sun.direction = {0, 0.2, -1};  // below the horizon: ambient only
  EXPECT_NEAR(illuminate(g, c, p, sun, ip)[0], ip.ambient, 1e-6);
}

TEST(Illumination, PointLightFallsOffWithInverseSquare) {
  const PlanarGrid g = grid(4, 4, 1000);
  const CloudColumns c = columns(std::vector<float>(16, 0.0f));
  Particles p;
  p.resize(2);
  p.x = {0, 0}, p.y = {0, 0}, p.z = {1000, 2000}, p.radius_m = {1, 1};
  Light bulb;
  bulb.directional = false;
  bulb.position = {0, 0, 3000};
  bulb.intensity = 5;
  IlluminationParams ip;
  ip.ambient = 0;
  const auto grey = illuminate(g, c, p, bulb, ip);
  // Particle 1 (1 km from the light) is the reference; particle 0 at 2 km gets a quarter
  // (eq. 14), up to the averaging over 2 m of its diameter (relative 1e-6).
  EXPECT_NEAR(grey[1], 1.0, 1e-6);
  EXPECT_NEAR(grey[0], 0.25, 1e-6);
}
