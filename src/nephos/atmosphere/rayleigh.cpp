#include "nephos/atmosphere/rayleigh.hpp"

#include <cmath>

namespace nephos::atmosphere {
namespace {
constexpr double avogadro = 6.0221367e23;  // Bodhaine's value
constexpr double ns_288 = 2.546899e19;     // molecules cm^-3 at 288.15 K, 1013.25 hPa (their eq. 3)
}  // namespace

double air_refractivity(double l, double co2) {
  // Peck & Reeder (1972), Bodhaine eq. 18, for 300 ppm CO2, then eq. 19 for other amounts.
  const double s = 1 / (l * l);
  const double n300 = (8060.51 + 2480990.0 / (132.274 - s) + 17455.7 / (39.32957 - s)) * 1e-8;
  return n300 * (1 + 0.54 * (co2 - 0.0003));
}

double king_factor(double l, double co2) {
  // Bates (1984) for N2 and O2 (Bodhaine eqs. 5, 6), Ar 1.00, CO2 1.15, weighted by volume (eq. 23).
  const double s = 1 / (l * l);
  const double f_n2 = 1.034 + 3.17e-4 * s;
  const double f_o2 = 1.096 + 1.385e-3 * s + 1.448e-4 * s * s;
  const double c = co2 * 100;  // percent
  return (78.084 * f_n2 + 20.946 * f_o2 + 0.934 * 1.00 + c * 1.15) / (78.084 + 20.946 + 0.934 + c);
}

double rayleigh_cross_section_cm2(double l, double co2) {
  const double n = 1 + air_refractivity(l, co2);
  const double n2 = n * n;
  const double l_cm = l * 1e-4;
  return 24 * std::pow(M_PI, 3) * (n2 - 1) * (n2 - 1) / (std::pow(l_cm, 4) * ns_288 * ns_288 * (n2 + 2) * (n2 + 2)) *
         king_factor(l, co2);
}

double rayleigh_optical_depth(double l, double p_pa, double lat_deg, double z_m, double co2) {
  // Gravity (List 1968; Bodhaine eqs. 10-11) at latitude and at the mass-weighted height of the
  // column above, z_c = 0.73737 z + 5517.56 m [cm s^-2].
  const double c2 = std::cos(2 * lat_deg * M_PI / 180);
  const double g0 = 980.6160 * (1 - 0.0026373 * c2 + 0.0000059 * c2 * c2);
  const double zc = 0.73737 * z_m + 5517.56;
  const double g = g0 - (3.085462e-4 + 2.27e-7 * c2) * zc + (7.254e-11 + 1.0e-13 * c2) * zc * zc -
                   (1.517e-17 + 6e-20 * c2) * zc * zc * zc;
  // Mean molecular weight of dry air with CO2 (eq. 17) [g mol^-1]; P in dyn cm^-2.
  const double ma = 15.0556 * co2 + 28.9595;
  return rayleigh_cross_section_cm2(l, co2) * (p_pa * 10) * avogadro / (ma * g);
}

double rayleigh_optical_depth_fit(double l) {
  const double l2 = l * l;
  return 0.0021520 * (1.0455996 - 341.29061 / l2 - 0.90230850 * l2) / (1 + 0.0027059889 / l2 - 85.968563 * l2);
}

double rayleigh_phase(double mu, double rho) {
  const double gamma = rho / (2 - rho);
  return 3 / (4 * (1 + 2 * gamma)) * ((1 + 3 * gamma) + (1 - gamma) * mu * mu);
}

}  // namespace nephos::atmosphere
