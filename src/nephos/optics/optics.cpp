#include "nephos/optics/optics.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>

#include "nephos/core/error.hpp"
#include "nephos/core/simd_math.hpp"

namespace nephos::optics {
namespace {
constexpr double q_ext = 2.0;  // cloud particles' extinction efficiency: the geometric-optics limit
}  // namespace

double planck(double lambda_um, double t_k) {
  const double x = c2_um_k / (lambda_um * t_k);
  return c1_w_um4_m2_sr / (std::pow(lambda_um, 5) * std::expm1(x));
}

namespace data {
extern const double astm_g173_extraterrestrial[];  // [nm, W m^-2 nm^-1] rows
extern const std::size_t astm_g173_extraterrestrial_rows, astm_g173_extraterrestrial_cols;
}  // namespace data

namespace {
// Sun as a 5772 K blackbody (IAU 2015 nominal effective temperature) seen from 1 AU:
// E = pi B(lambda, T_sun) (R_sun / AU)^2, R_sun = 695,700 km, AU = 149,597,870.7 km.
double solar_blackbody_irradiance(double lo_um, double hi_um) {
  const double dilution = std::pow(695700.0 / 149597870.7, 2);
  double sum = 0;
  constexpr int n = 64;
  for (int i = 0; i < n; ++i) sum += planck(lo_um + (i + 0.5) * (hi_um - lo_um) / n, 5772.0);
  return M_PI * dilution * sum / n;
}

// The ASTM G173-03 extraterrestrial irradiance at wavelength [nm], linear between its rows.
double astm_irradiance_w_m2_nm(double nm) {
  const double* t = data::astm_g173_extraterrestrial;
  const std::size_t n = data::astm_g173_extraterrestrial_rows;
  std::size_t lo = 0, hi = n - 1;
  while (hi - lo > 1) {
    const std::size_t mid = (lo + hi) / 2;
    (t[2 * mid] <= nm ? lo : hi) = mid;
  }
  const double x0 = t[2 * lo], x1 = t[2 * hi];
  return t[2 * lo + 1] + (nm - x0) / (x1 - x0) * (t[2 * hi + 1] - t[2 * lo + 1]);
}
}  // namespace

double solar_spectrum_irradiance(double lo_um, double hi_um) {
  if (lo_um >= 4.0 || lo_um < 0.28) return solar_blackbody_irradiance(lo_um, hi_um);
  // Mean over the band by the midpoint rule at <= 0.1 nm, finer than the table's 0.5-5 nm rows.
  const int n = std::max(64, static_cast<int>((hi_um - lo_um) * 1e4));
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += astm_irradiance_w_m2_nm(1000 * (lo_um + (i + 0.5) * (hi_um - lo_um) / n));
  return 1000 * sum / n;  // per nm -> per um
}

const std::vector<Band>& bands() {
  // Band edges and centres: the ABI's nominal wavelength ranges (Schmit et al. 2017, BAMS 98,
  // 681-698, Table 1). Solar irradiance of the reflective bands 1-6: the band-equivalent values
  // "esun" that GOES-16 L1b files carry, so that reflectances computed from nephos's radiances
  // as from ABI's (pi L d^2 / esun) agree. Bands 7-16: the ASTM G173 spectrum (band 7) and the
  // 5772 K Sun beyond 4 um, negligible beside the emission there (0.01-0.25 W m^-2 um^-1).
  static const std::vector<Band> b = [] {
    std::vector<Band> v{
        {"blue", "GOES-16 ABI band 1 (blue)", 1, 0.47, 0.45, 0.49, 2017.1648, false},
        {"vis", "GOES-16 ABI band 2 (red)", 2, 0.64, 0.59, 0.69, 1631.3351, false},
        {"nir", "GOES-16 ABI band 3 (veggie)", 3, 0.865, 0.846, 0.885, 957.0699, false},
        {"cirrus", "GOES-16 ABI band 4 (cirrus)", 4, 1.378, 1.371, 1.386, 360.90176, false},
        {"swir16", "GOES-16 ABI band 5 (snow/ice)", 5, 1.61, 1.58, 1.64, 242.54037, false},
        {"swir22", "GOES-16 ABI band 6 (cloud particle size)", 6, 2.24, 2.225, 2.275, 76.8999, false},
        {"mwir", "GOES-16 ABI band 7 (shortwave window)", 7, 3.9, 3.8, 4.0, solar_spectrum_irradiance(3.8, 4.0), true},
        {"wv62", "GOES-16 ABI band 8 (upper-level water vapour)", 8, 6.19, 5.77, 6.6,
         solar_spectrum_irradiance(5.77, 6.6), true},
        {"wv69", "GOES-16 ABI band 9 (mid-level water vapour)", 9, 6.95, 6.75, 7.15,
         solar_spectrum_irradiance(6.75, 7.15), true},
        {"wv73", "GOES-16 ABI band 10 (lower-level water vapour)", 10, 7.34, 7.24, 7.44,
         solar_spectrum_irradiance(7.24, 7.44), true},
        {"ir85", "GOES-16 ABI band 11 (cloud-top phase)", 11, 8.5, 8.3, 8.7, solar_spectrum_irradiance(8.3, 8.7), true},
        {"o3", "GOES-16 ABI band 12 (ozone)", 12, 9.61, 9.42, 9.8, solar_spectrum_irradiance(9.42, 9.8), true},
        {"lwir", "GOES-16 ABI band 13 (clean long-wave window)", 13, 10.35, 10.1, 10.6,
         solar_spectrum_irradiance(10.1, 10.6), true},
        {"lwir11", "GOES-16 ABI band 14 (long-wave window)", 14, 11.2, 10.8, 11.6,
         solar_spectrum_irradiance(10.8, 11.6), true},
        {"lwir12", "GOES-16 ABI band 15 (dirty long-wave window)", 15, 12.3, 11.8, 12.8,
         solar_spectrum_irradiance(11.8, 12.8), true},
        {"co2", "GOES-16 ABI band 16 (CO2 long-wave)", 16, 13.3, 13.0, 13.6, solar_spectrum_irradiance(13.0, 13.6),
         true},
    };
    for (Band& band : v)
      band.k_water = refractive_index(Phase::water, band.centre_um).k,
      band.k_ice = refractive_index(Phase::ice, band.centre_um).k;
    return v;
  }();
  return b;
}

std::string band_names() {
  std::string s;
  for (const auto& b : bands()) s += (s.empty() ? "" : ", ") + b.name;
  return s;
}

const Band& band(const std::string& name) {
  for (const auto& b : bands())
    if (b.name == name || name == fmt::format("C{:02d}", b.abi_band)) return b;
  throw ValueError("unknown band '" + name + "' (known: " + band_names() + ")", {.key = "bands"});
}

double band_planck(const Band& b, double t_k) {
  // Midpoint rule with 32 sub-intervals: relative error < 1e-5 for these narrow bands.
  constexpr int n = 32;
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += planck(b.lo_um + (i + 0.5) * (b.hi_um - b.lo_um) / n, t_k);
  return sum / n;
}

double band_brightness_temperature(const Band& b, double radiance) {
  if (!(radiance > 0)) return 0.0;
  // Start from the monochromatic inverse at the centre, then Newton on the band mean.
  double t = brightness_temperature(b.centre_um, radiance);
  for (int it = 0; it < 20; ++it) {
    const double f = band_planck(b, t) - radiance;
    const double df = (band_planck(b, t + 0.01) - band_planck(b, t - 0.01)) / 0.02;
    const double step = f / df;
    t -= step;
    if (std::abs(step) < 1e-9) break;
  }
  return t;
}

double standard_atmosphere_temperature_k(double altitude_m) {
  // U.S. Standard Atmosphere 1976, Table 4: base geopotential heights [m'] and lapse rates [K/m'].
  static constexpr double hb[] = {0, 11000, 20000, 32000, 47000, 51000, 71000, 84852};
  static constexpr double lapse[] = {-0.0065, 0.0, 0.001, 0.0028, 0.0, -0.0028, -0.002};
  constexpr double r0 = 6356766.0;  // the standard's effective Earth radius [m]
  const double z = std::clamp(altitude_m, 0.0, 86000.0);
  const double h = r0 * z / (r0 + z);
  double t = 288.15;
  for (int i = 0; i < 7; ++i) {
    const double top = hb[i + 1];
    if (h <= top) return t + lapse[i] * (h - hb[i]);
    t += lapse[i] * (top - hb[i]);
  }
  return t;
}

void two_stream_slabs(const double* tau, const double* omega_in, std::size_t n, double* r, double* t) {
  // In chunks: k and x = k tau, then sinh and cosh from one expm1 each (with e = exp(x),
  // sinh x = expm1(x) (e + 1) / (2 e) keeps full relative precision at small x), then the
  // regimes: empty (tau <= 0), conservative (the series in k tau), semi-infinite (sinh and
  // cosh would overflow), general.
  constexpr std::size_t chunk = 16;
  for (std::size_t c0 = 0; c0 < n; c0 += chunk) {
    const std::size_t m = std::min(chunk, n - c0);
    alignas(64) double k[chunk], x[chunk], em[chunk], omega[chunk];
    for (std::size_t i = 0; i < m; ++i) {
      omega[i] = std::clamp(omega_in[c0 + i], 0.0, 1.0);
      k[i] = std::sqrt(std::max(0.0, 1.0 - omega[i] * omega[i]));
      x[i] = std::min(k[i] * tau[c0 + i], 350.0);
    }
    for (std::size_t i = 0; i < m; ++i) em[i] = std::expm1(x[i]);
    for (std::size_t i = 0; i < m; ++i) {
      const double ta = tau[c0 + i], xi = k[i] * ta, e = 1 + em[i];
      const double sh = 0.5 * em[i] * (e + 1) / e, ch = sh + 1 / e, d = k[i] * ch + sh;
      if (ta <= 0)
        r[c0 + i] = 0, t[c0 + i] = 1;
      else if (xi < 1e-6)
        r[c0 + i] = omega[i] * ta / (1 + ta), t[c0 + i] = 1 / (1 + ta);
      else if (xi > 350)
        r[c0 + i] = omega[i] / (k[i] + 1), t[c0 + i] = 0;
      else
        r[c0 + i] = omega[i] * sh / d, t[c0 + i] = k[i] / d;
    }
  }
}

namespace {

// delta_eddington_beam() for one slab: f = g^2 and gs = g / (1 + g) of its asymmetry g; mu0
// already at least 1e-3 (mu0_in the caller's, for the Sun below the horizon). Meador & Weaver's
// forms with numerator and denominator divided by exp(k tau'), so that every exponential decays;
// at mu0 = 1 / k they are 0 / 0 (a removable pole), and mu0 is nudged off it.
[[gnu::always_inline]] inline void beam_slab(double tau, double omega, double f, double gs, double mu0_in, double mu0,
                                             double& r, double& t, double& direct) {
  const double w = std::clamp(omega, 0.0, 1.0), ta = std::max(tau, 0.0);
  const double ws = (1 - f) * w / (1 - w * f), ts = (1 - w * f) * ta;
  const double g1 = (7 - ws * (4 + 3 * gs)) / 4, g2 = -(1 - ws * (4 - 3 * gs)) / 4;
  const double g3 = (2 - 3 * gs * mu0) / 4, g4 = 1 - g3;
  // k^2 = g1^2 - g2^2 = 3 (1 - ws)(1 - ws gs), as a product: no cancellation near ws = 1.
  const double k = std::sqrt(3 * (1 - ws) * (1 - ws * gs));
  const double near_pole = std::abs(1 - k * mu0) < 1e-6 ? 1 + 2e-6 : 1.0;
  const double m = mu0 * near_pole, km = k * m, a1 = g1 * g4 + g2 * g3, a2 = g1 * g3 + g2 * g4;
  const double beam = std::exp(-ts / m), e2 = std::exp(-2 * k * ts), ek = std::exp(-k * ts);
  const double den = (1 - km * km) * ((k + g1) + (k - g1) * e2);
  const double r_general =
      ws * ((1 - km) * (a2 + k * g3) - (1 + km) * (a2 - k * g3) * e2 - 2 * k * (g3 - a2 * m) * beam * ek) / den;
  const double t_general =
      -ws * ((1 + km) * (a1 + k * g4) * beam - (1 - km) * (a1 - k * g4) * e2 * beam - 2 * k * (g4 + a1 * m) * ek) / den;
  // Conservative (k tau' < 1e-4): R closed, and what is not reflected is transmitted.
  const double r_conservative = (g1 * ts + (g3 - g1 * mu0) * (1 - beam)) / (1 + g1 * ts);
  const bool conservative = k * ts < 1e-4, lit = (ta > 0) & (mu0_in > 0);
  const double rr = std::clamp(conservative ? r_conservative : r_general, 0.0, 1.0);
  const double tt = std::clamp(conservative ? 1 - r_conservative - beam : t_general, 0.0, 1.0 - rr);
  r = lit ? rr : 0.0;
  t = lit ? tt : 0.0;
  direct = mu0_in > 0 ? beam : 0.0;
}

}  // namespace

BeamSlab delta_eddington_beam(double tau, double omega, double g, double mu0) {
  BeamSlab b{};
  beam_slab(tau, omega, g * g, g / (1 + g), mu0, std::max(mu0, 1e-3), b.reflectance, b.diffuse_transmittance,
            b.direct_transmittance);
  return b;
}

void delta_eddington_beam_reflectances(const double* tau, const double* omega, double g, double mu0_in, std::size_t n,
                                       double* r) {
  const double f = g * g, gs = g / (1 + g), mu0 = std::max(mu0_in, 1e-3);
#pragma omp simd
  for (std::size_t i = 0; i < n; ++i) {
    double t, direct;
    beam_slab(tau[i], omega[i], f, gs, mu0_in, mu0, r[i], t, direct);
  }
}

SlabResult two_stream_slab(double tau, double omega) {
  SlabResult s{};
  two_stream_slabs(&tau, &omega, 1, &s.reflectance, &s.transmittance);
  return s;
}

SlabResult two_stream_fit(double tau, double omega) {
  const double f = 1 - std::sqrt(std::max(0.0, 1 - omega * omega));
  if (tau <= 0) return {0.0, 1.0};
  return {f * tau / (1 + tau), f / (1 + tau)};
}

double beer_transmittance(double tau) { return std::exp(-tau); }

SlabOptics similarity_scaled(double tau, double omega, double g) {
  const double f = 1 - omega * g;
  return {f * tau, (1 - g) * omega / f};
}

double imaginary_index(Phase phase, const Band& b) { return phase == Phase::water ? b.k_water : b.k_ice; }

OpticalProperties cloud_optics(Phase phase, double water_content_g_m3, double r_e_um, const Band& b) {
  if (!(water_content_g_m3 >= 0) || !(r_e_um > 0))
    throw ValueError(fmt::format("water content {} g/m3 and effective radius {} um must be >= 0 and > 0",
                                 water_content_g_m3, r_e_um));
  const double rho = phase == Phase::water ? 1.0e6 : 0.917e6;  // density [g/m^3]
  const double r_m = r_e_um * 1e-6;
  const double beta = 3.0 * water_content_g_m3 * q_ext / (4.0 * rho * r_m);
  const double w = anomalous_diffraction_w(imaginary_index(phase, b), r_e_um, b.centre_um);
  double omega = 0;
  anomalous_diffraction_albedos(&w, 1, &omega);
  return {beta, omega};
}

void anomalous_diffraction_albedos(const double* w, std::size_t n, double* omega) {
  // Q_abs(w) = 1 + 2 e^-w / w + 2 (e^-w - 1) / w^2 (van de Hulst 1957), its series 2w/3 - w^2/4
  // below w = 1e-4; e^-w as 1 + expm1(-w), one exponential (its rounding, 1e-16 of 1, is
  // 2e-16 / w of Q_abs: below 1e-7 of it for w >= 1e-4). The expm1 in a loop of its own that
  // vectorises.
  constexpr std::size_t chunk = 16;
  for (std::size_t c0 = 0; c0 < n; c0 += chunk) {
    const std::size_t m = std::min(chunk, n - c0);
    alignas(64) double em1[chunk];
    for (std::size_t i = 0; i < m; ++i) em1[i] = std::expm1(-w[c0 + i]);
    for (std::size_t i = 0; i < m; ++i) {
      const double wi = w[c0 + i];
      const double q_abs =
          wi < 1e-4 ? (2.0 / 3.0) * wi - wi * wi / 4.0 : 1.0 + 2.0 * (1.0 + em1[i]) / wi + 2.0 * em1[i] / (wi * wi);
      omega[c0 + i] = std::clamp(1.0 - q_abs / q_ext, 0.0, 1.0);
    }
  }
}

}  // namespace nephos::optics
