#pragma once
// The ground seen from space, per sensor band: what it reflects of sunlight (a Lambertian albedo
// per surface kind with a documented spectral shape, and on open water the sun glint of a
// wind-roughened sea, Cox & Munk 1954) and what it emits (an emissivity per kind and band).
//
// Kinds and their shares of a point come from the weather: land fraction (lsm), sea ice (ci),
// snow (sdwe); GFS's broadband albedo (al) scales the land, snow and ice albedos.
#include <array>

#include "nephos/optics/optics.hpp"

namespace nephos::surface {

enum class Kind : int { ocean, land, snow, sea_ice };
inline constexpr int kind_count = 4;

/// A point of the ground: the shares of its kinds and what the weather says of it.
struct State {
  std::array<double, kind_count> share{1, 0, 0, 0};  ///< sum 1
  double broadband_albedo = -1;                      ///< GFS al [fraction]; < 0: unknown (night, or no field)
  double skin_temperature_k = 288;
  double wind_speed_m_s = 5;  ///< 10 m above the ground
};

/// The shares of ocean, land, snow and sea ice from the land fraction, the sea-ice fraction of
/// the water and the snow water equivalent [kg m^-2] of the land: snow covers the land fully
/// from 10 kg m^-2 (GFS's Noah land model's snow-depletion threshold for forests is of that
/// order; a shallower pack shows the ground through it in proportion).
State state(double land_fraction, double sea_ice_fraction, double snow_water_kg_m2);

/// Lambertian albedo of kind k in band b. For land, snow and ice a spectral shape (table in
/// surface.cpp, with sources) scaled so that its solar-weighted broadband mean is the given
/// broadband albedo (when >= 0); open water's diffuse albedo is fixed (the glint is apart).
double band_albedo(Kind k, const optics::Band& b, double broadband_albedo = -1);

/// Emissivity of kind k in band b (nadir values of published spectra; table in surface.cpp).
double emissivity(Kind k, const optics::Band& b);

/// The ground's Lambertian albedo and emissivity in band b: its kinds' values by share.
double mixed_albedo(const State& s, const optics::Band& b);
double mixed_emissivity(const State& s, const optics::Band& b);

/// Fresnel reflectance of unpolarised light from water (refractive index n) at incidence cos i.
double fresnel_reflectance(double cos_incidence, double n = 1.334);

/// Sun glint of a wind-roughened sea (Cox & Munk 1954, isotropic slopes): the reflectance factor
/// R = pi L / (E mu0) towards a sensor at cos zenith mu from a Sun at cos zenith mu0, cos_phase
/// the cosine of the angle between the Sun's and the sensor's directions seen from the surface.
/// R = pi p(facet) F(i) / (4 mu0 mu cos^4 beta), p the slope density exp(-tan^2 beta / s2) /
/// (pi s2), s2 = 0.003 + 5.12e-3 wind [m s^-1], beta the tilt of the facet that mirrors the Sun
/// into the sensor, i its angle of incidence.
double glint_reflectance(double mu0, double mu, double cos_phase, double wind_speed_m_s, double n = 1.334);

}  // namespace nephos::surface
