#include "nephos/optics/optics.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "nephos/core/error.hpp"

namespace nephos::optics {

TEST(Planck, StefanBoltzmannLaw) {
  // pi * integral of B over wavelength = sigma T^4 (CODATA sigma). Midpoint rule on a log grid
  // from 0.1 to 1000 um holds > 99.99 % of the emission at 300 K; tolerance 1e-4 relative.
  for (double t : {250.0, 300.0}) {
    double sum = 0;
    const int n = 200000;
    const double a = std::log(0.1), b = std::log(1000.0);
    for (int i = 0; i < n; ++i) {
      const double l = std::exp(a + (i + 0.5) * (b - a) / n);
      sum += planck(l, t) * l * (b - a) / n;
    }
    EXPECT_NEAR(M_PI * sum / (stefan_boltzmann * std::pow(t, 4)), 1.0, 1e-4) << t;
  }
}

TEST(Planck, WienDisplacementLaw) {
  // The peak is at lambda = b / T, b = 2897.771955 um K (CODATA 2018): the derivative changes
  // sign across it.
  const double peak = 2897.771955 / 288.0;
  EXPECT_GT(planck(peak, 288.0), planck(peak * 0.999, 288.0));
  EXPECT_GT(planck(peak, 288.0), planck(peak * 1.001, 288.0));
}

TEST(Planck, BrightnessTemperatureInvertsPlanck) {
  for (double t : {190.0, 250.0, 310.0}) {
    EXPECT_NEAR(brightness_temperature(10.35, planck(10.35, t)), t, 1e-9);
    EXPECT_NEAR(band_brightness_temperature(band("lwir"), band_planck(band("lwir"), t)), t, 1e-6);
  }
  // Band mean of a narrow band is close to the centre value (within 0.5 % here).
  EXPECT_NEAR(band_planck(band("lwir"), 280) / planck(10.35, 280), 1.0, 5e-3);
}

TEST(Bands, KnownAndUnknown) {
  EXPECT_EQ(band("vis").centre_um, 0.64);
  EXPECT_TRUE(band("lwir").thermal);
  EXPECT_GT(band("lwir").solar_irradiance, 0.1);
  EXPECT_LT(band("lwir").solar_irradiance, 0.5);
  EXPECT_THROW(band("uv"), ValueError);
}

TEST(StandardAtmosphere, Table1976) {
  // U.S. Standard Atmosphere 1976, Table I (geometric altitude): kinetic temperature [K].
  const std::array<std::pair<double, double>, 7> table{{{0, 288.150},
                                                        {5000, 255.676},
                                                        {10000, 223.252},
                                                        {20000, 216.650},
                                                        {30000, 226.509},
                                                        {40000, 250.350},
                                                        {50000, 270.650}}};
  for (auto [z, t] : table) EXPECT_NEAR(standard_atmosphere_temperature_k(z), t, 2e-3) << z;  // 3-decimal table
}

// Independent check of the slab solution: integrate (2a)/(2b) with RK4 and shoot on the
// unknown reflected stream at the lit face (the problem is linear: superpose two solutions).
std::pair<double, double> shoot(double tau, double omega) {
  auto integrate = [&](double f, double b) {
    const int n = 20000;
    const double h = tau / n;
    auto df = [&](double f_, double b_) { return -f_ + omega * b_; };
    auto db = [&](double f_, double b_) { return b_ - omega * f_; };
    for (int i = 0; i < n; ++i) {
      const double k1f = df(f, b), k1b = db(f, b);
      const double k2f = df(f + h / 2 * k1f, b + h / 2 * k1b), k2b = db(f + h / 2 * k1f, b + h / 2 * k1b);
      const double k3f = df(f + h / 2 * k2f, b + h / 2 * k2b), k3b = db(f + h / 2 * k2f, b + h / 2 * k2b);
      const double k4f = df(f + h * k3f, b + h * k3b), k4b = db(f + h * k3f, b + h * k3b);
      f += h / 6 * (k1f + 2 * k2f + 2 * k3f + k4f);
      b += h / 6 * (k1b + 2 * k2b + 2 * k3b + k4b);
    }
    return std::pair{f, b};
  };
  const auto [f1, b1] = integrate(1, 0);
  const auto [f2, b2] = integrate(0, 1);
  const double r = -b1 / b2;  // B(tau) = 0
  return {r, f1 + r * f2};
}

TEST(Slab, ConservativeLimitIsTheClosedForms3a3b) {
  for (double tau : {0.1, 1.0, 10.0, 100.0}) {
    const SlabResult s = two_stream_slab(tau, 1.0);
    EXPECT_NEAR(s.transmittance, 1 / (1 + tau), 1e-12);
    EXPECT_NEAR(s.reflectance, tau / (1 + tau), 1e-12);
    EXPECT_NEAR(s.reflectance + s.transmittance, 1.0, 1e-12);  // no absorption: energy conserved
  }
}

TEST(Slab, MatchesNumericalIntegrationOfTheTwoStreamEquations) {
  for (double omega : {0.5, 0.9, 0.999})
    for (double tau : {0.3, 3.0}) {
      const auto [r, t] = shoot(tau, omega);
      const SlabResult s = two_stream_slab(tau, omega);
      EXPECT_NEAR(s.reflectance, r, 1e-8) << omega << " " << tau;  // RK4 error at h = tau/20000
      EXPECT_NEAR(s.transmittance, t, 1e-8) << omega << " " << tau;
    }
}

TEST(Slab, SemiInfiniteLimitAndFit) {
  // tau -> infinity: R = omega / (1 + sqrt(1 - omega^2)), T = 0.
  EXPECT_NEAR(two_stream_slab(1e4, 0.8).reflectance, 0.8 / 1.6, 1e-12);
  EXPECT_EQ(two_stream_slab(1e4, 0.8).transmittance, 0.0);
  // The seed's fit (4a) equals (3b) at omega = 1 and vanishes at omega = 0.
  EXPECT_NEAR(two_stream_fit(2.0, 1.0).reflectance, 2.0 / 3.0, 1e-15);
  EXPECT_EQ(two_stream_fit(2.0, 0.0).reflectance, 0.0);
}

TEST(Beer, HomogeneousSlab) {
  // A 200 m slab with extinction 0.01/m has optical depth 2: transmittance e^-2.
  EXPECT_NEAR(beer_transmittance(0.01 * 200), 0.1353352832366127, 1e-15);
}

TEST(CloudOptics, GeometricOpticsExtinction) {
  // tau = 3 LWP / (2 rho r_e) (Stephens 1978): a 500 m stratus of 0.35 g/m^3 and r_e 10 um has
  // tau = 3 * 175 / (2 * 1e6 * 1e-5) = 26.25.
  const OpticalProperties p = cloud_optics(Phase::water, 0.35, 10.0, band("vis"));
  EXPECT_NEAR(p.extinction_per_m * 500.0, 26.25, 1e-9);
  // Visible: absorption is negligible (1 - omega ~ 1e-6); thermal IR: strongly absorbing.
  EXPECT_GT(p.single_scattering_albedo, 0.9999);
  const OpticalProperties ir = cloud_optics(Phase::water, 0.35, 10.0, band("lwir"));
  EXPECT_GT(ir.single_scattering_albedo, 0.3);
  EXPECT_LT(ir.single_scattering_albedo, 0.85);
  // Weak-absorption limit of ADT: 1 - omega = Q_abs / 2 = (8 pi / 3) n_i r / lambda.
  const double expected = 8 * M_PI / 3 * imaginary_index(Phase::water, band("nir")) * 10.0 / 0.865;
  EXPECT_NEAR(1 - cloud_optics(Phase::water, 0.35, 10.0, band("nir")).single_scattering_albedo, expected,
              expected * 0.01);
  EXPECT_THROW(cloud_optics(Phase::ice, 0.01, 0.0, band("vis")), ValueError);
}

}  // namespace nephos::optics
