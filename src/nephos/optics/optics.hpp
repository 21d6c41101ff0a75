#pragma once
// Radiometry and cloud optics for the global renderer (the fractal-cloud paper, section 2.3):
// Planck radiance and its inverse, sensor bands, the 1976 U.S. Standard Atmosphere temperature,
// the two-stream slab relations (2a)-(4b), the delta-Eddington slab lit by a beam, Beer's law,
// and cloud optical properties.
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

namespace nephos::optics {

// ---- Planck -------------------------------------------------------------------------------
inline constexpr double c1_w_um4_m2_sr = 1.191042972e8;     ///< 2 h c^2 [W um^4 m^-2 sr^-1]
inline constexpr double c2_um_k = 1.438776877e4;            ///< h c / k [um K]
inline constexpr double stefan_boltzmann = 5.670374419e-8;  ///< [W m^-2 K^-4] (CODATA 2018)

/// Spectral radiance B(lambda, T) [W m^-2 sr^-1 um^-1].
double planck(double wavelength_um, double temperature_k);
/// Brightness temperature [K] of a monochromatic radiance (exact inverse of planck()): 0 for a
/// radiance <= 0. Inline, so that loops over radiances vectorise.
inline double brightness_temperature(double wavelength_um, double radiance) {
  const double r = radiance > 0 ? radiance : 1.0;
  const double t = c2_um_k / (wavelength_um * std::log1p(c1_w_um4_m2_sr / (std::pow(wavelength_um, 5) * r)));
  return radiance > 0 ? t : 0.0;
}

// ---- Sensor bands -------------------------------------------------------------------------
struct Band {
  std::string name;                ///< "vis", "nir", "lwir", ...
  std::string description;         ///< e.g. "GOES-16 ABI band 2 (red)"
  int abi_band;                    ///< GOES-16 ABI band number, 1-16
  double centre_um, lo_um, hi_um;  ///< central wavelength and band edges
  double solar_irradiance;         ///< top-of-atmosphere band-mean solar irradiance at 1 AU [W m^-2 um^-1]
  bool thermal;                    ///< thermal emission matters (report brightness temperature)
  /// The imaginary refractive indices of water and ice at the centre (refractive_index(); kept
  /// with the band since cloud_optics() needs them per pixel and band).
  double k_water = 0, k_ice = 0;
  /// Sunlight matters: the reflective bands 1-6 and band 7 (3.9 um: reflected sunlight by day).
  bool sunlit() const { return abi_band <= 7; }
};
/// The 16 bands of GOES-16's Advanced Baseline Imager, in band order: blue (1, 0.47 um), vis
/// (2, 0.64), nir (3, 0.865), cirrus (4, 1.378), swir16 (5, 1.61), swir22 (6, 2.24), mwir (7,
/// 3.9), wv62 (8, 6.19), wv69 (9, 6.95), wv73 (10, 7.34), ir85 (11, 8.5), o3 (12, 9.61), lwir
/// (13, 10.35), lwir11 (14, 11.2), lwir12 (15, 12.3), co2 (16, 13.3).
const std::vector<Band>& bands();
/// The band of a name or of its ABI channel name ("C01".."C16"); ValueError listing the names.
const Band& band(const std::string& name);
std::string band_names();  ///< "blue, vis, nir, ..."
/// The most bands one render takes: every built-in band once.
inline constexpr std::size_t max_band_count = 16;
/// Doubles per vector in the build's vectorised loops: 256-bit vectors, which CMakeLists.txt
/// asks GCC to prefer (its 512-bit band loops measured slower: docs/PERFORMANCE.md).
inline constexpr std::size_t vector_doubles = 4;
/// Lanes for loops over n bands padded with inert lanes to whole vectors (at least one): a
/// batched loop (two_stream_slabs()) then runs every band through the same vector arithmetic,
/// with no scalar remainder.
inline constexpr std::size_t band_lanes(std::size_t n) {
  return n <= vector_doubles ? vector_doubles : (n + vector_doubles - 1) / vector_doubles * vector_doubles;
}
static_assert(band_lanes(max_band_count) == max_band_count, "every band's lanes fit arrays of max_band_count");
/// Band-mean extraterrestrial solar irradiance at 1 AU [W m^-2 um^-1] over [lo, hi] um, from the
/// ASTM G173-03 extraterrestrial spectrum (0.28-4 um; Gueymard 2004), and beyond 4 um from the
/// Sun as a 5772 K blackbody.
double solar_spectrum_irradiance(double lo_um, double hi_um);

/// Band-mean Planck radiance [W m^-2 sr^-1 um^-1]: (1 / (hi - lo)) * integral of B over the band.
double band_planck(const Band& b, double temperature_k);
/// Inverse of band_planck() [K].
double band_brightness_temperature(const Band& b, double radiance);

// ---- 1976 U.S. Standard Atmosphere --------------------------------------------------------
/// Kinetic temperature [K] at geometric altitude [m], 0-86 km (clamped outside), from the
/// standard's seven geopotential layers (its own Earth radius r0 = 6356.766 km).
double standard_atmosphere_temperature_k(double altitude_m);

// ---- Slab transport -----------------------------------------------------------------------
struct SlabResult {
  double reflectance;    ///< I_ref / I_0
  double transmittance;  ///< diffuse + direct I_trans / I_0
};
/// Exact solution of the two-stream equations (2a)/(2b) (each stream's derivative taken along
/// its own direction of travel, depth x from the lit face): dI_f/dx = -(Bs+Ba) I_f + Bs I_r,
/// -dI_r/dx = -(Bs+Ba) I_r + Bs I_f, with I_f(0) = I_0, I_r(L) = 0. With tau = B_ext L,
/// k = sqrt(1 - omega^2), D = k cosh(k tau) + sinh(k tau):
///   R = omega sinh(k tau) / D,  T = k / D.
/// For omega = 1 it reduces to (3a)/(3b).
SlabResult two_stream_slab(double tau, double omega);
/// two_stream_slab() for n slabs at once (arrays of n), its exponentials in a loop that
/// vectorises; every lane of a whole vector (n a multiple of 8) takes the same arithmetic.
void two_stream_slabs(const double* tau, const double* omega, std::size_t n, double* reflectance,
                      double* transmittance);
/// A plane-parallel slab lit by a direct beam at cosine of incidence mu0 [-], each part as a
/// share of the beam's flux: the reflectance, the diffusely transmitted part and the beam left
/// undeflected exp(-tau'/mu0) (tau' delta-scaled, below). The delta-Eddington approximation
/// (Joseph, Wiscombe & Weinman 1976, J. Atmos. Sci. 33, 2452: the forward peak g^2 taken as
/// unscattered, tau' = (1 - omega g^2) tau, omega' = (1 - g^2) omega / (1 - omega g^2),
/// g' = g / (1 + g)) in Meador & Weaver's (1980, J. Atmos. Sci. 37, 630) closed forms for a beam
/// with their Table 1's Eddington coefficients; where k tau' < 1e-4 the conservative form
/// R = (g1 tau' + (g3 - g1 mu0)(1 - exp(-tau'/mu0))) / (1 + g1 tau') and T = 1 - R - exp(-tau'/mu0).
/// Unlike two_stream_slab()'s, the parts depend on the Sun's height: a thin cloud reflects more
/// of a low Sun. Each part in [0, 1], R + T at most 1; all 0 for mu0 <= 0, R and T 0 for
/// tau <= 0. Within 0.045 of exact transport for tau 3-30, omega 0.95-1 and mu0 >= 0.5
/// (optics_test: at most 0.030 reflected and 0.038 transmitted, thin layers under a low Sun).
struct BeamSlab {
  double reflectance, diffuse_transmittance, direct_transmittance;
};
BeamSlab delta_eddington_beam(double tau, double omega, double g, double mu0);
/// delta_eddington_beam()'s reflectance for n slabs at once (arrays of n) of one asymmetry g, in a
/// loop that vectorises.
void delta_eddington_beam_reflectances(const double* tau, const double* omega, double g, double mu0, std::size_t n,
                                       double* r);
/// The seed's conservative closed forms (3a) I_trans = I0/(1+tau), (3b) I_ref = I0 tau/(1+tau),
/// scaled by its absorption fit (4a)/(4b): factor 1 - sqrt(1 - omega^2).
SlabResult two_stream_fit(double tau, double omega);
/// Beer's law (5): direct transmittance exp(-tau).
double beer_transmittance(double tau);
/// A slab's optical depth and single-scattering albedo.
struct SlabOptics {
  double tau, omega;
};
/// van de Hulst's similarity relations for particles that scatter forwards with asymmetry g:
/// tau' = (1 - omega g) tau, omega' = (1 - g) omega / (1 - omega g), i.e. the scattering
/// coefficient times (1 - g) and the absorption unchanged: the fraction g of each scattering
/// event counted as going on undeflected. In (2a)/(2b), where every scattered photon reverses,
/// g = 0 leaves the seed's slab. The particle clouds and the sprite textures use the same
/// scaling.
SlabOptics similarity_scaled(double tau, double omega, double asymmetry);

// ---- Cloud optical properties -------------------------------------------------------------
enum class Phase { water, ice };
/// Complex refractive index m = n + i k.
struct RefractiveIndex {
  double n, k;
};
/// Liquid water (Hale & Querry 1973, 25 C) or ice (Warren & Brandt 2008, -7 C) at a vacuum
/// wavelength of 0.4-13.5 um (ValueError outside): the published table's value at a tabulated
/// wavelength, else n interpolated linearly and log k linearly between the neighbouring rows.
RefractiveIndex refractive_index(Phase phase, double wavelength_um);
struct OpticalProperties {
  double extinction_per_m;  ///< B_ext [1/m]
  double single_scattering_albedo;
};
/// Extinction in the geometric-optics limit, B_ext = 3 W Q_ext / (4 rho r_e) with Q_ext = 2
/// (Stephens 1978; Hansen & Travis 1974), and single-scattering albedo 1 - Q_abs/Q_ext with the
/// anomalous-diffraction absorption efficiency of a sphere (van de Hulst 1957) for the band's
/// imaginary refractive index (water: Hale & Querry 1973; ice: Warren & Brandt 2008).
/// water_content in g/m^3, effective radius in um.
OpticalProperties cloud_optics(Phase phase, double water_content_g_m3, double effective_radius_um, const Band& band);
/// cloud_optics()'s single-scattering albedo 1 - Q_abs / Q_ext for n anomalous-diffraction size
/// parameters w = 8 pi k r_e / lambda (k the band's imaginary index, lambda its centre) at once,
/// the exponentials in a loop that vectorises (as two_stream_slabs()).
void anomalous_diffraction_albedos(const double* w, std::size_t n, double* omega);
/// The anomalous-diffraction size parameter w = 8 pi k r_e / lambda [-] of particles of
/// effective radius r_e [um] and imaginary refractive index k at wavelength lambda [um].
inline double anomalous_diffraction_w(double k_imag, double r_e_um, double lambda_um) {
  return 8.0 * M_PI * k_imag * r_e_um / lambda_um;
}
/// Imaginary refractive index used for a band: refractive_index() at its centre.
double imaginary_index(Phase phase, const Band& band);

}  // namespace nephos::optics
