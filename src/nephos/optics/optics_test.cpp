#include "nephos/optics/optics.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <tuple>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"

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

TEST(Slab, EveryLaneOfABatchMeetsTheReferences) {
  // two_stream_slabs() over 16 lanes (its vectorised path) in every regime, each lane against a
  // reference not from the code under test: empty {0, 1}; omega = 1, the closed forms (3a)/(3b);
  // the semi-infinite limit omega / (1 + sqrt(1 - omega^2)); general lanes, the RK4 integration
  // (1e-8: its error at h = tau / 20000). Catches a lane's regime or inputs mixed up with another's.
  const std::array<double, 16> tau = {0, 0.5, 2, 50, 1e4, 1e4, 0.3, 3.0, 0.3, 3.0, -1, 0.3, 3.0, 1.0, 20, 0.3};
  const std::array<double, 16> omega = {0.9, 1, 1, 1, 0.8, 0.3, 0.5, 0.5, 0.9, 0.9, 0.7, 0.999, 0.999, 1, 1, 0.2};
  std::array<double, 16> r{}, t{};
  two_stream_slabs(tau.data(), omega.data(), tau.size(), r.data(), t.data());
  for (std::size_t i = 0; i < tau.size(); ++i) {
    double r_ref, t_ref, tol = 1e-12;
    if (tau[i] <= 0) {
      r_ref = 0, t_ref = 1;
    } else if (omega[i] == 1) {
      r_ref = tau[i] / (1 + tau[i]), t_ref = 1 / (1 + tau[i]);
    } else if (tau[i] > 1e3) {
      r_ref = omega[i] / (1 + std::sqrt(1 - omega[i] * omega[i])), t_ref = 0;
    } else {
      std::tie(r_ref, t_ref) = shoot(tau[i], omega[i]);
      tol = 1e-8;
    }
    EXPECT_NEAR(r[i], r_ref, tol) << "lane " << i;
    EXPECT_NEAR(t[i], t_ref, tol) << "lane " << i;
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

// Exact transport in a plane-parallel slab, by Monte Carlo: photons enter the top at cosine mu0,
// travel exp(-tau)-distributed optical paths, scatter with the Henyey-Greenstein phase function
// of asymmetry g (the single-scattering albedo as the photon's weight); the reflectance is the
// weight that leaves the top, the transmittance the weight that leaves the bottom, scattered or
// not. Every random number a counter-based hash of (photon, event, draw). Their standard errors
// are below 0.5 / sqrt(photons).
struct Transport {
  double reflectance, transmittance;
};
Transport monte_carlo_slab(double tau, double omega, double g, double mu0, int photons) {
  Transport sum{0, 0};
  for (int p = 0; p < photons; ++p) {
    double z = 0, mu = mu0, weight = 1;  // optical depth below the top; direction cosine downwards
    for (std::uint64_t event = 0; weight > 1e-6; ++event) {
      z += -std::log(1 - uniform01(11, p, event, 0)) * mu;
      if (z < 0) sum.reflectance += weight;
      if (z > tau) sum.transmittance += weight;
      if (z < 0 || z > tau) break;
      weight *= omega;
      const double xi = uniform01(11, p, event, 1);
      const double s = (1 - g * g) / (1 - g + 2 * g * xi);
      const double cos_theta = g == 0 ? 2 * xi - 1 : (1 + g * g - s * s) / (2 * g);
      const double phi = 2 * M_PI * uniform01(11, p, event, 2);
      const double sin_theta = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
      mu = mu * cos_theta + std::sqrt(std::max(0.0, 1 - mu * mu)) * sin_theta * std::cos(phi);
    }
  }
  return {sum.reflectance / photons, sum.transmittance / photons};
}

TEST(Slab, DeltaEddingtonBeamAgreesWithExactTransport) {
  // A cloud lit by the Sun's beam against exact transport (the Monte Carlo above, 40000
  // photons: standard errors < 0.0025) for droplets (g 0.85) and ice (0.77), conservative,
  // absorbing as in the near infrared (omega 0.99) and more (0.95), optical depths 3-30, the Sun
  // at mu0 1, 0.7 and 0.5: the reflectance, and the transmittance (the diffuse part and the
  // undeflected beam together, as transport cannot tell the forward peak from the beam). Bound
  // 0.045: delta-Eddington's own error (a few hundredths, largest for thin layers under a low
  // Sun: Joseph, Wiscombe & Weinman 1976) and 3 standard errors; measured at most 0.030
  // reflected and 0.038 transmitted. The reflectance must also grow as the Sun sinks, as
  // transport's does. Faults caught: the hemispheric reflectance two_stream_slab() gives
  // whatever the Sun's height (0.60 against 0.42 at tau 10, mu0 1), the forward peak left
  // unscaled (0.065 off), Eddington's gamma3 with mu0 dropped (0.135), gamma3 for gamma4 in the
  // transmittance (0.235).
  struct Case {
    double tau, omega, g;
  };
  const Case cases[] = {{3, 1, 0.85}, {10, 1, 0.85}, {30, 1, 0.85}, {10, 0.99, 0.85}, {3, 0.95, 0.85}, {10, 1, 0.77}};
  double worst_r = 0, worst_t = 0;
  for (const Case& c : cases) {
    double previous = -1;
    for (double mu0 : {1.0, 0.7, 0.5}) {
      const BeamSlab b = delta_eddington_beam(c.tau, c.omega, c.g, mu0);
      const Transport exact = monte_carlo_slab(c.tau, c.omega, c.g, mu0, 40000);
      const double t = b.diffuse_transmittance + b.direct_transmittance;
      worst_r = std::max(worst_r, std::abs(b.reflectance - exact.reflectance));
      worst_t = std::max(worst_t, std::abs(t - exact.transmittance));
      const std::string at = fmt::format("tau {} omega {} g {} mu0 {}", c.tau, c.omega, c.g, mu0);
      EXPECT_NEAR(b.reflectance, exact.reflectance, 0.045) << at;
      EXPECT_NEAR(t, exact.transmittance, 0.045) << at;
      EXPECT_GT(b.reflectance, previous) << at;
      previous = b.reflectance;
    }
  }
  std::printf("[ measured ] delta-Eddington against Monte Carlo: largest difference %.4f reflected, %.4f transmitted\n",
              worst_r, worst_t);
}

TEST(Slab, DeltaEddingtonEveryLaneAndLimit) {
  // The batched reflectance over 16 lanes (its vectorised path) equals delta_eddington_beam()'s
  // per lane (to 1e-14 relative: the vector and scalar exponentials may differ in their last
  // bits). The conservative limit is Joseph et al.'s (1976) closed form with the delta scaling's
  // tau' and g', R = ((1 - g') tau' + (2/3 - mu0)(1 - exp(-tau'/mu0))) / (4/3 + (1 - g') tau'),
  // and a conservative slab reflects or passes everything (R + T + direct = 1); an absorbing slab
  // reaches both continuously (omega 1 - 1e-9: within 1e-6). An empty lane reflects nothing and
  // passes the whole beam; a Sun below the horizon lights nothing. Tolerances: double rounding.
  std::array<double, 16> tau{}, omega{}, r{};
  for (std::size_t i = 0; i < 16; ++i) {
    const double x = static_cast<double>(i);
    tau[i] = i == 3 ? 0.0 : 0.5 * x + 0.1, omega[i] = 1 - 0.01 * x;
  }
  delta_eddington_beam_reflectances(tau.data(), omega.data(), 0.85, 0.6, 16, r.data());
  for (std::size_t i = 0; i < 16; ++i) {
    const double one = delta_eddington_beam(tau[i], omega[i], 0.85, 0.6).reflectance;
    EXPECT_NEAR(r[i], one, 1e-14 * one) << "lane " << i;
  }
  EXPECT_EQ(r[3], 0.0);
  const BeamSlab empty = delta_eddington_beam(0, 1, 0.85, 0.6);
  EXPECT_EQ(empty.diffuse_transmittance, 0.0);
  EXPECT_EQ(empty.direct_transmittance, 1.0);
  for (double t : {1.0, 10.0, 100.0})
    for (double mu0 : {1.0, 0.3}) {
      const double g = 0.85, ts = (1 - g * g) * t, gs = g / (1 + g);
      const double closed = ((1 - gs) * ts + (2.0 / 3 - mu0) * (1 - std::exp(-ts / mu0))) / (4.0 / 3 + (1 - gs) * ts);
      const BeamSlab c = delta_eddington_beam(t, 1, g, mu0), a = delta_eddington_beam(t, 1 - 1e-9, g, mu0);
      EXPECT_NEAR(c.reflectance, closed, 1e-12) << t << " " << mu0;
      EXPECT_NEAR(c.reflectance + c.diffuse_transmittance + c.direct_transmittance, 1.0, 1e-12) << t << " " << mu0;
      EXPECT_NEAR(a.reflectance, closed, 1e-6) << t << " " << mu0;
      EXPECT_NEAR(a.diffuse_transmittance, c.diffuse_transmittance, 1e-6) << t << " " << mu0;
    }
  const BeamSlab below = delta_eddington_beam(10, 1, 0.85, -0.2);
  EXPECT_EQ(below.reflectance + below.diffuse_transmittance + below.direct_transmittance, 0.0);
}

TEST(Slab, SimilarityRelations) {
  // van de Hulst's similarity relations keep the absorption optical depth (1 - omega) tau and
  // scale the scattering one omega tau by (1 - g); g = 0 changes nothing, to the bit (the
  // renderer's default must reproduce the seed's slab exactly). Tolerances: double rounding.
  for (double omega : {1.0, 0.99, 0.7, 0.3})
    for (double g : {0.0, 0.5, 0.85}) {
      const SlabOptics s = similarity_scaled(20.0, omega, g);
      EXPECT_NEAR((1 - s.omega) * s.tau, (1 - omega) * 20.0, 1e-12) << omega << " " << g;
      EXPECT_NEAR(s.omega * s.tau, (1 - g) * omega * 20.0, 1e-12) << omega << " " << g;
    }
  EXPECT_EQ(similarity_scaled(20.0, 0.7, 0.0).tau, 20.0);
  EXPECT_EQ(similarity_scaled(20.0, 0.7, 0.0).omega, 0.7);
  // A conservative cloud of droplets (g = 0.85) against the published hemispheric-mean
  // two-stream closure (Meador & Weaver 1980, J. Atmos. Sci. 37, 630, Table 1), whose
  // conservative slab reflects R = gamma1 tau / (1 + gamma1 tau) with gamma1 = 1 - g: equal to
  // double rounding. Fault caught: an unscaled or wrongly scaled optical depth. The seed's
  // unscaled slab is far brighter (0.91 against 0.60 at tau 10).
  for (double tau : {2.0, 10.0, 30.0, 100.0}) {
    const SlabOptics s = similarity_scaled(tau, 1.0, 0.85);
    const double r = two_stream_slab(s.tau, s.omega).reflectance;
    EXPECT_NEAR(r, 0.15 * tau / (1 + 0.15 * tau), 1e-12) << tau;
  }
  EXPECT_GT(two_stream_slab(10.0, 1.0).reflectance - 0.15 * 10 / (1 + 0.15 * 10), 0.3);
  // Thermal IR (10.35 um, omega ~ 0.7 for r_e 10 um water): a thick cloud emits with
  // eps = 1 - R; forward scattering (g ~ 0.85) makes it a far better emitter than the seed's
  // slab (0.59).
  const double omega_ir = cloud_optics(Phase::water, 0.3, 10.0, band("lwir")).single_scattering_albedo;
  const SlabOptics thick = similarity_scaled(100.0, omega_ir, 0.85);
  EXPECT_GT(1 - two_stream_slab(thick.tau, thick.omega).reflectance, 0.85);
  EXPECT_LT(1 - two_stream_slab(100.0, omega_ir).reflectance, 0.65);
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
  EXPECT_THROW(cloud_optics(Phase::ice, 0.01, 0.0, band("vis")), ValueError);
}

TEST(RefractiveIndex, PublishedTables) {
  // Values printed in Hale & Querry (1973), Table 1 (liquid water, 25 C), and Warren & Brandt
  // (2008), whose compilation tabulates these wavelengths (ice, -7 C): returned exactly at a
  // tabulated wavelength (only the table's own rounding in the source, so compared to 1e-12
  // relative).
  struct Case {
    Phase phase;
    double wavelength_um, n, k;
  };
  for (const Case c : {Case{Phase::water, 0.65, 1.331, 1.64e-8}, Case{Phase::water, 1.6, 1.317, 8.55e-5},
                       Case{Phase::water, 3.9, 1.357, 3.80e-3}, Case{Phase::water, 11.0, 1.153, 0.0968},
                       Case{Phase::water, 12.0, 1.111, 0.199}, Case{Phase::ice, 0.64, 1.3083, 1.22e-8},
                       Case{Phase::ice, 1.613, 1.2890, 2.659e-4}, Case{Phase::ice, 2.24, 1.2591, 2.037e-4},
                       Case{Phase::ice, 11.0, 1.0886, 0.248}, Case{Phase::ice, 12.2, 1.3194, 0.422}}) {
    const RefractiveIndex m = refractive_index(c.phase, c.wavelength_um);
    EXPECT_NEAR(m.n, c.n, 1e-12 * c.n) << c.wavelength_um;
    EXPECT_NEAR(m.k, c.k, 1e-12 * c.k) << c.wavelength_um;
  }
  // Between rows: n linear, log k linear (midway between 10.0 and 10.5 um for water: the mean
  // of n and the geometric mean of k; tolerance: double rounding).
  const RefractiveIndex mid = refractive_index(Phase::water, 10.25);
  EXPECT_NEAR(mid.n, (1.218 + 1.185) / 2, 1e-12);
  EXPECT_NEAR(mid.k, std::sqrt(0.0508 * 0.0662), 1e-14);
  EXPECT_THROW(refractive_index(Phase::water, 0.3), ValueError);
  EXPECT_THROW(refractive_index(Phase::ice, 14.0), ValueError);
  EXPECT_THROW(refractive_index(Phase::ice, std::nan("")), ValueError);
}

TEST(Bands, EveryBandHasOpticsAndARadianceScale) {
  EXPECT_EQ(bands().size(), max_band_count);
  for (const Band& b : bands()) {
    EXPECT_LT(b.lo_um, b.centre_um) << b.name;
    EXPECT_LT(b.centre_um, b.hi_um) << b.name;
    EXPECT_GT(b.solar_irradiance, 0) << b.name;
    for (Phase p : {Phase::water, Phase::ice}) EXPECT_GT(imaginary_index(p, b), 0) << b.name;
    // Thermal (brightness temperature reported) where a 300 K surface's emission is more than
    // 1 % of what a white Lambertian surface reflects under an overhead Sun (E / pi): 2e-5 at
    // 2.24 um, 0.2 at 3.9 um.
    EXPECT_EQ(b.thermal, band_planck(b, 300.0) > 0.01 * b.solar_irradiance / M_PI) << b.name;
  }
  EXPECT_THROW(band("swir"), ValueError);
}

TEST(Bands, TheSixteenAbiBandsByNameAndChannel) {
  ASSERT_EQ(bands().size(), 16u);
  for (std::size_t i = 0; i < bands().size(); ++i) {
    const Band& b = bands()[i];
    EXPECT_EQ(b.abi_band, static_cast<int>(i) + 1);
    EXPECT_EQ(&band(fmt::format("C{:02d}", b.abi_band)), &b) << b.name;
  }
  EXPECT_EQ(band("C13").name, "lwir");
  EXPECT_EQ(band("C08").name, "wv62");
}

// The reflective bands' solar irradiance (the esun that GOES-16 L1b files carry, from NOAA's own
// solar spectrum and band responses) against an independent published spectrum, ASTM G173-03's
// extraterrestrial irradiance, averaged over each band's nominal edges. 2.5 %: the flat average
// over nominal edges against the response-weighted one, and the spectra's own differences
// (~1-2 % at 10 nm resolution; Gueymard 2004, Table 3).
TEST(Bands, SolarIrradianceAgainstAnIndependentSpectrum) {
  for (const Band& b : bands()) {
    if (b.abi_band > 6) continue;
    EXPECT_NEAR(solar_spectrum_irradiance(b.lo_um, b.hi_um) / b.solar_irradiance, 1.0, 0.025) << b.name;
  }
  // The whole spectrum holds 1348 W m-2 of the total solar irradiance (1366 W m-2 in the
  // standard; the rest lies outside 0.28-4 um: ~1.2 % beyond 4 um for a 5772 K Sun).
  EXPECT_NEAR(solar_spectrum_irradiance(0.28, 4.0) * 3.72, 1348, 5);
}

TEST(CloudOptics, WeakAbsorptionOfDropletsInTheNearAndShortwaveInfrared) {
  // Anomalous diffraction (van de Hulst 1957) at small w = 8 pi n_i r / lambda: Q_abs = 2 w / 3
  // - w^2 / 4 + O(w^3), so with Q_ext = 2 the co-albedo 1 - omega = w / 3 - w^2 / 8 + O(w^3),
  // with n_i at the band centre (0.865, 1.61, 2.24 um) from the printed rows of Hale & Querry
  // (1973, Table 1) that bracket it, log-linear between them as documented (3.5e-7, 8.7e-5,
  // 3.7e-4). This is what makes ABI bands 5 and 6 see droplet size (Nakajima &
  // King 1990): the co-albedo grows linearly with r_e. Tolerance: the next term, w^3 / 30,
  // below 8.1e-4 of the co-albedo for w < 0.09 (r_e up to 20 um). Faults caught: a band's centre or its table
  // lookup, r_e in the wrong unit, a size dependence other than linear.
  struct Row {
    const char* band;
    double lambda_um, lo_um, n_lo, hi_um, n_hi;  // Hale & Querry rows bracketing the centre
  };
  for (const Row row :
       {Row{"nir", 0.865, 0.85, 2.93e-7, 0.875, 3.91e-7}, Row{"swir16", 1.61, 1.6, 8.55e-5, 1.8, 1.15e-4},
        Row{"swir22", 2.24, 2.2, 2.89e-4, 2.4, 9.56e-4}})
    for (double r_e : {5.0, 10.0, 20.0}) {
      // log-linear between the rows, as the documented interpolation
      const double f = (row.lambda_um - row.lo_um) / (row.hi_um - row.lo_um);
      const double n_i = std::exp((1 - f) * std::log(row.n_lo) + f * std::log(row.n_hi));
      const double w = 8 * M_PI * n_i * r_e / row.lambda_um;
      ASSERT_LT(w, 0.09);
      const double expected = w / 3 - w * w / 8;
      const double got = 1 - cloud_optics(Phase::water, 0.35, r_e, band(row.band)).single_scattering_albedo;
      EXPECT_NEAR(got / expected, 1.0, 9e-4) << row.band << " r_e " << r_e;
    }
}

}  // namespace nephos::optics
