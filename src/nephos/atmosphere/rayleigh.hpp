#pragma once
// Rayleigh scattering by dry air from first principles (Bodhaine, Wood, Dutton & Slusser 1999,
// "On Rayleigh optical depth calculations", J. Atmos. Oceanic Technol. 16, 1854-1861): the
// refractive index of Peck & Reeder (1972) corrected for CO2, the King factors of N2 and O2
// (Bates 1984), the scattering cross section (their eq. 2) and the optical depth of a column
// of air of surface pressure p (eq. 4), with gravity at latitude and height (List 1968, their
// eqs. 10-11).

namespace nephos::atmosphere {

/// (n - 1) of dry air at 288.15 K, 1013.25 hPa with CO2 volume fraction co2 [mol mol^-1].
double air_refractivity(double wavelength_um, double co2 = 360e-6);
/// King correction factor F(air) (depolarisation) of dry air, Bodhaine eq. 23.
double king_factor(double wavelength_um, double co2 = 360e-6);
/// Rayleigh scattering cross section per molecule [cm^2], Bodhaine eq. 2.
double rayleigh_cross_section_cm2(double wavelength_um, double co2 = 360e-6);
/// Rayleigh optical depth of the atmosphere above pressure p [Pa] at latitude [deg] and height
/// [m] (Bodhaine eq. 4: sigma P A / (m_a g)).
double rayleigh_optical_depth(double wavelength_um, double pressure_pa = 101325.0, double latitude_deg = 45.0,
                              double height_m = 0.0, double co2 = 360e-6);
/// Bodhaine's eq. 30: their four-parameter fit of eq. 4 at sea level, 45 deg, 360 ppm CO2.
double rayleigh_optical_depth_fit(double wavelength_um);
/// The Rayleigh phase function with molecular anisotropy (Chandrasekhar 1950; Hansen & Travis
/// 1974, eq. 2.15): P(Theta) = 3 / (4 (1 + 2 gamma)) ((1 + 3 gamma) + (1 - gamma) cos^2 Theta),
/// gamma = rho / (2 - rho), rho the depolarisation ratio; normalised so that its mean over the
/// sphere is 1.
double rayleigh_phase(double cos_theta, double depolarisation = 0.0279);

}  // namespace nephos::atmosphere
