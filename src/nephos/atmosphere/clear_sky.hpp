#pragma once
// Clear-sky radiative transfer through one column, per sensor band: the gas transmittance from
// each level to the sensor along the view, the thermal emission of the air between them (no
// scattering: the thermal infrared), the two-way gas transmittance along the Sun's path down
// and the view back up (solar bands), and the Rayleigh optical depth above each level.
// Plane-parallel within the column; air masses from Kasten & Young (1989), valid to the horizon.
#include <vector>

#include "nephos/atmosphere/profile.hpp"
#include "nephos/optics/optics.hpp"

namespace nephos::atmosphere {

/// Kasten & Young (1989) relative optical air mass at a zenith angle whose cosine is mu
/// (1/mu near the zenith, ~38 at the horizon).
double air_mass(double mu);

/// The diffusivity factor: a plane-parallel layer's flux transmittance is its beam transmittance
/// at air mass 1.66 (Elsasser 1942; Liou 2002, section 4.4).
inline constexpr double diffusivity_air_mass = 1.66;

struct ColumnGeometry {
  double view_air_mass = 1;        ///< along the line of sight from the column to the sensor
  double sun_air_mass = -1;        ///< along the Sun's path; <= 0: the Sun is below the horizon
  double sensor_altitude_m = 1e6;  ///< above it the air is not between the column and the sensor
};

/// A column's clear-sky optics for one band, at its levels (bottom first).
struct ClearSkyColumn {
  std::vector<float> z_m;            ///< level altitudes
  std::vector<float> t_view;         ///< gas transmittance level -> sensor
  std::vector<float> path_radiance;  ///< thermal emission of the air level -> sensor [W m^-2 sr^-1 um^-1]
  std::vector<float> t_solar;        ///< gas transmittance TOA -> level -> sensor (Sun path and view)
  std::vector<float> tau_rayleigh;   ///< Rayleigh optical depth above the level (vertical)
  /// The air's thermal emission reaching the column's bottom from the whole sky, as the radiance
  /// of an isotropic field of the same flux [W m^-2 sr^-1 um^-1]: F_down / pi, the integral of
  /// B dt along the diffusivity air mass 1.66 (Elsasser 1942), over all the air above (the
  /// sensor's altitude does not cut it). What a ground of emissivity e reflects: (1 - e) times it.
  double sky_down = 0;
  double view_air_mass = 1, sun_air_mass = -1;
  bool valid() const { return !z_m.empty(); }
};

/// The clear-sky optics of profile p in band b for geometry g at latitude [deg].
ClearSkyColumn clear_sky_column(const Profile& p, const optics::Band& b, const ColumnGeometry& g, double latitude_deg);

/// A column's optics at altitude z [m], linear between levels (clamped to the column).
struct ClearSkySample {
  float t_view = 1, path_radiance = 0, t_solar = 1, tau_rayleigh = 0;
};
ClearSkySample sample(const ClearSkyColumn& c, double z_m);

/// The clear-sky top-of-atmosphere radiance [W m^-2 sr^-1 um^-1] of a black surface at the
/// column's bottom with temperature t_surface, for tests and diagnostics: B t + path emission.
double clear_sky_radiance(const ClearSkyColumn& c, const optics::Band& b, double t_surface_k);

}  // namespace nephos::atmosphere
