#pragma once
// Radiometry of the global renderer: a plane-parallel cloud layer (reflectance, transmittance
// seen along a line of sight, emissivity) from its vertical optical depth; sunlight reaching a
// level through Rayleigh scattering; the Rayleigh path radiance above a level, of a sky seen from
// below and of the limb, all in single scattering.

#include <cstddef>

namespace nephos::render {

/// One cloud layer as a plane-parallel slab of vertical optical depth tau (similarity-scaled
/// inside: tau' = (1 - omega g) tau, omega' = (1 - g) omega / (1 - omega g)).
struct LayerOptics {
  double reflectance = 0;    ///< two-stream diffuse reflectance (the slab's albedo)
  double transmittance = 1;  ///< what lies behind, seen through it along the view: direct + diffuse
  double emissivity = 0;     ///< 1 - diffuse transmittance: an isothermal slab in surroundings of its
                             ///< own temperature emits B (1 - T) whatever its reflectance
};
/// @param tau_vertical  the layer's vertical optical depth (extinction x depth along the view x
///                      mu_view: a plane-parallel layer of the same thickness)
/// @param mu_view       cos of the view's zenith angle at the layer (>= 0.05 used)
LayerOptics cloud_layer(double tau_vertical, double omega, double g, double mu_view);
/// cloud_layer() for n layers (arrays of n: per band, say) of one asymmetry and view at once,
/// the exponentials in loops that vectorise (optics::two_stream_slabs()).
void cloud_layers(const double* tau_vertical, const double* omega, double g, double mu_view, std::size_t n,
                  double* reflectance, double* transmittance, double* emissivity);

/// The share of sunlight at cos zenith mu_sun that reaches a level under Rayleigh optical depth
/// tau: the direct beam exp(-tau / mu) and half of what is scattered out of it (Rayleigh
/// scattering sends as much forwards as backwards).
double rayleigh_down(double tau, double mu_sun);
/// The share of light leaving a level towards the sensor at cos zenith mu that arrives: the
/// same two parts.
double rayleigh_up(double tau, double mu);

/// Single-scattering Rayleigh path radiance [W m^-2 sr^-1 um^-1] of the air above a level of
/// vertical optical depth tau, seen from above along cos zenith mu_view, lit by irradiance e0 [W
/// m^-2 um^-1, normal to the beam] from cos zenith mu_sun; cos_scatter the cosine of the
/// scattering angle: e0 P(Theta) / (4 pi) mu0 / (mu0 + mu) (1 - exp(-tau (1 / mu0 + 1 / mu)))
/// (Chandrasekhar 1950; Liou 2002, eq. 3.4.33 for a layer over a black ground).
double rayleigh_path(double e0, double tau, double mu_view, double mu_sun, double cos_scatter);
/// The same for a layer of optical depth tau above an observer looking up at cos zenith mu_view:
/// e0 P / (4 pi) mu0 / (mu0 - mu) (exp(-tau / mu0) - exp(-tau / mu)).
double rayleigh_sky(double e0, double tau, double mu_view, double mu_sun, double cos_scatter);
/// The Chapman grazing factor: the air along a line of sight tangent at height h over that of the
/// vertical column above h, sqrt(2 pi (R + h) / H) for scale height H [m].
double grazing_air_mass(double tangent_height_m, double scale_height_m = 8000.0);

}  // namespace nephos::render
