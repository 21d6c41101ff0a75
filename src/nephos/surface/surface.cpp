#include "nephos/surface/surface.hpp"

#include <algorithm>
#include <cmath>

namespace nephos::surface {
namespace {

// Representative spectral albedos at the ABI bands' centres, read from published spectra:
// fresh snow (Warren 1982, Rev. Geophys. 20, Fig. 10: ~0.95 visible, ~0.85 at 0.86 um, ~0.1 at
// 1.6 um, ~0.05 at 2.2 um), bare sea ice (Perovich 1996, CRREL Monograph 96-1: ~0.7 visible,
// falling beyond 1 um as snow's), green vegetation and desert sand (USGS spectral library,
// Kokaly et al. 2017, splib07: grass ~0.05 red, ~0.45 near-infrared; sand ~0.3 red, ~0.5 at
// 1.6 um); open water's diffuse (subsurface) reflectance (Morel 1988: ~0.05 blue, ~0.02 red,
// dark beyond 0.7 um). Bands 1-6 in order; the thermal bands take 1 - emissivity.
struct Shape {
  std::array<double, 6> albedo;
};
constexpr Shape snow_shape{{0.96, 0.95, 0.88, 0.35, 0.10, 0.05}};
constexpr Shape ice_shape{{0.80, 0.74, 0.64, 0.30, 0.10, 0.05}};
constexpr Shape vegetation_shape{{0.04, 0.05, 0.45, 0.10, 0.25, 0.12}};
constexpr Shape sand_shape{{0.20, 0.32, 0.40, 0.30, 0.50, 0.45}};
constexpr Shape water_shape{{0.05, 0.02, 0.005, 0.002, 0.002, 0.002}};

// Weights of bands 1-6 in a broadband (0.3-4 um) solar albedo: each band's share of the solar
// spectrum it stands for (ASTM G173 extraterrestrial irradiance over 0.3-0.55, 0.55-0.75,
// 0.75-1.2, 1.2-1.45, 1.45-1.9, 1.9-4 um: 0.30, 0.22, 0.26, 0.06, 0.09, 0.07).
constexpr std::array<double, 6> broadband_weight{0.30, 0.22, 0.26, 0.06, 0.09, 0.07};

double broadband(const Shape& s) {
  double a = 0, w = 0;
  for (std::size_t i = 0; i < 6; ++i) a += broadband_weight[i] * s.albedo[i], w += broadband_weight[i];
  return a / w;
}

// Emissivities at bands 7-16 (3.9, 6.2, 6.9, 7.3, 8.5, 9.6, 10.35, 11.2, 12.3, 13.3 um), nadir:
// sea water (Masuda, Takashima & Takayama 1988: 0.99 at 11 um, 0.985 at 12 um, ~0.97 at 3.9
// um), snow and ice (Hori et al. 2006: 0.99-1.0 in 8-14 um, ~0.97 at 3.9 um), vegetation
// (~0.98 throughout; ASTER library, Baldridge et al. 2009) and quartz sand (its reststrahlen
// band: ~0.75 at 8.5 um, ~0.85 at 9.6 um, ~0.95 beyond 10 um; ~0.8 at 3.9 um).
constexpr std::array<double, 10> water_emissivity{0.975, 0.99, 0.99, 0.99, 0.985, 0.985, 0.99, 0.99, 0.985, 0.98};
constexpr std::array<double, 10> snow_emissivity{0.97, 0.99, 0.99, 0.99, 0.99, 0.99, 0.995, 0.99, 0.98, 0.97};
constexpr std::array<double, 10> vegetation_emissivity{0.96, 0.98, 0.98, 0.98, 0.97, 0.97, 0.98, 0.98, 0.98, 0.98};
constexpr std::array<double, 10> sand_emissivity{0.80, 0.95, 0.95, 0.94, 0.75, 0.85, 0.94, 0.96, 0.97, 0.97};

// Land between vegetation and sand by its broadband albedo: 0.15 or less vegetation, 0.35 or
// more sand (Sahara ~0.35-0.40; forests ~0.12-0.15).
double sandiness(double broadband_albedo) {
  if (broadband_albedo < 0) return 0.3;
  return std::clamp((broadband_albedo - 0.15) / 0.20, 0.0, 1.0);
}
}  // namespace

State state(double land, double sea_ice, double snow_water) {
  land = std::clamp(std::isnan(land) ? 0.0 : land, 0.0, 1.0);
  sea_ice = std::clamp(std::isnan(sea_ice) ? 0.0 : sea_ice, 0.0, 1.0);
  const double snow = std::clamp(std::isnan(snow_water) ? 0.0 : snow_water / 10.0, 0.0, 1.0);
  State s;
  s.share = {(1 - land) * (1 - sea_ice), land * (1 - snow), land * snow, (1 - land) * sea_ice};
  return s;
}

double band_albedo(Kind k, const optics::Band& b, double bb) {
  if (b.abi_band > 6) return 1 - emissivity(k, b);
  const auto i = static_cast<std::size_t>(b.abi_band - 1);
  if (k == Kind::ocean) return water_shape.albedo[i];
  if (k == Kind::land) {
    const double f = sandiness(bb);
    const double shaped = (1 - f) * vegetation_shape.albedo[i] + f * sand_shape.albedo[i];
    const double shaped_bb = (1 - f) * broadband(vegetation_shape) + f * broadband(sand_shape);
    return bb >= 0 ? std::clamp(shaped * bb / shaped_bb, 0.0, 1.0) : shaped;
  }
  const Shape& s = k == Kind::snow ? snow_shape : ice_shape;
  // GFS's al over snow and ice is often a blend with what lies around: scale by it only when it
  // is of the kind's order (a grid cell's mean is not the kind's own albedo).
  return bb >= 0.4 ? std::clamp(s.albedo[i] * bb / broadband(s), 0.0, 1.0) : s.albedo[i];
}

double emissivity(Kind k, const optics::Band& b) {
  if (b.abi_band < 7) return 0;  // reflective bands: emission negligible
  const auto i = static_cast<std::size_t>(b.abi_band - 7);
  switch (k) {
    case Kind::ocean:
      return water_emissivity[i];
    case Kind::snow:
    case Kind::sea_ice:
      return snow_emissivity[i];
    case Kind::land:
      break;
  }
  return vegetation_emissivity[i];  // refined by mixed_emissivity with the albedo
}

double mixed_albedo(const State& s, const optics::Band& b) {
  double a = 0;
  for (int k = 0; k < kind_count; ++k)
    a += s.share[static_cast<std::size_t>(k)] * band_albedo(static_cast<Kind>(k), b, s.broadband_albedo);
  return a;
}

double mixed_emissivity(const State& s, const optics::Band& b) {
  if (b.abi_band < 7) return 0;
  const auto i = static_cast<std::size_t>(b.abi_band - 7);
  const double f = sandiness(s.broadband_albedo);
  const double land = (1 - f) * vegetation_emissivity[i] + f * sand_emissivity[i];
  return s.share[0] * water_emissivity[i] + s.share[1] * land + (s.share[2] + s.share[3]) * snow_emissivity[i];
}

double fresnel_reflectance(double ci, double n) {
  ci = std::clamp(ci, 0.0, 1.0);
  const double si2 = 1 - ci * ci, st2 = si2 / (n * n);
  if (st2 >= 1) return 1;
  const double ct = std::sqrt(1 - st2);
  const double rs = (ci - n * ct) / (ci + n * ct), rp = (n * ci - ct) / (n * ci + ct);
  return 0.5 * (rs * rs + rp * rp);
}

double glint_reflectance(double mu0, double mu, double cos_phase, double wind, double n) {
  if (mu0 <= 0 || mu <= 0) return 0;
  // The facet normal bisects the directions to the Sun and to the sensor: cos(2i) = cos_phase.
  const double cos2i = std::clamp(cos_phase, -1.0, 1.0);
  const double cos_i = std::sqrt(0.5 * (1 + cos2i));
  const double cos_beta = (mu0 + mu) / (2 * cos_i);  // the facet's tilt from the vertical
  if (cos_beta <= 0) return 0;
  const double tan2_beta = (1 - cos_beta * cos_beta) / (cos_beta * cos_beta);
  const double s2 = 0.003 + 5.12e-3 * std::max(0.0, wind);
  const double p = std::exp(-tan2_beta / s2) / (M_PI * s2);
  const double cos2_beta = cos_beta * cos_beta;
  return M_PI * p * fresnel_reflectance(cos_i, n) / (4 * mu0 * mu * cos2_beta * cos2_beta);
}

}  // namespace nephos::surface
