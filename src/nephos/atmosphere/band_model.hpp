#pragma once
// Gas absorption in a sensor band: the LOWTRAN 7 band model (Kneizys et al. 1988, "Users guide
// to LOWTRAN 7", AFGL-TR-88-0177; molecular parameters of Pierluissi & Maragoudakis 1986,
// AFGL-TR-86-0272), its water-vapour continuum (Clough, Kneizys & Davies 1989, CKD), N2
// collision-induced absorption and ozone's visible (Chappuis) band, with the tables in
// data/spectroscopy (scripts/extract_lowtran7_tables.py).
//
// The model: in each 5 cm^-1 bin a molecule's transmittance along a path is
//   t = exp(-(W 10^C')^a),   W = sum over the path of u (P/P0)^n (T0/T)^m,
// u the absorber amount (H2O in g cm^-2, the other gases in atm-cm), P0 = 1013.25 hPa,
// T0 = 273.15 K, and C', a, n, m tabulated per bin and spectral region. Molecules multiply
// (random overlap), as in LOWTRAN.
//
// For speed, a band is cut into sub-bands (at the molecules' region boundaries and at most 60
// cm^-1 wide in the thermal infrared) and each molecule's sub-band mean transmittance as a
// function of W is fitted once by a sum of exponentials with positive weights (Wiscombe & Evans
// 1977): t(W) = sum_i w_i exp(-k_i W). A path's transmittance is then exact to the fit for any
// non-homogeneous path, like the band model itself, since both depend on the path only through W.
#include <array>
#include <vector>

#include "nephos/optics/optics.hpp"

namespace nephos::atmosphere {

enum class Gas : int { h2o, co2, o3, n2o, ch4, o2 };
inline constexpr int gas_count = 6;
const char* name(Gas g);

/// Transmittance as a sum of exponentials in the scaled amount W: sum_i w_i exp(-k_i W).
struct ExpSum {
  static constexpr int max_terms = 16;
  int n = 0;  ///< 0: the gas does not absorb here
  std::array<double, max_terms> k{}, w{};
  double transmittance(double scaled_amount) const;
  /// transmittance() of `count` scaled amounts into out (the same sums, in a loop over the
  /// amounts that vectorises).
  void transmittances(const double* scaled_amounts, std::size_t count, double* out) const;
};

/// One sub-band of a sensor band.
struct SubBand {
  double nu_lo_cm1 = 0, nu_hi_cm1 = 0;                 ///< its 5 cm^-1 bins' centres, first and last
  double wavelength_um = 0;                            ///< mean wavelength (bins weighted by their wavelength width)
  double weight = 0;                                   ///< its share of the band's wavelength width
  std::array<ExpSum, gas_count> gas;                   ///< fitted transmittance per gas
  std::array<double, gas_count> n{}, m{};              ///< the amount scaling exponents per gas (P/P0)^n (T0/T)^m
  double self_296 = 0, self_260 = 0, foreign_296 = 0;  ///< CKD coefficients [1e-20 cm^2 molec^-1 (cm^-1)^-1]
  double n2_per_km = 0;                                ///< N2 continuum coefficient [km^-1]
  double o3_visible = 0;                               ///< Chappuis absorption [(atm-cm)^-1]
  double fit_error = 0;                                ///< largest |fit - band model| of its gases' transmittance
};

struct BandGasModel {
  std::vector<SubBand> sub;
  double fit_error = 0;  ///< largest over the sub-bands
};

/// The gas model of a band, built on first use and kept for the process.
const BandGasModel& gas_model(const optics::Band& band);

/// The band model itself (no fit): the mean transmittance over the bins of [nu_lo, nu_hi] [cm^-1]
/// (each bin weighted by its wavelength width) of gas g for the scaled amount W. For tests.
double band_model_transmittance(Gas g, double nu_lo_cm1, double nu_hi_cm1, double scaled_amount);

}  // namespace nephos::atmosphere
