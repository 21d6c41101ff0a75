#pragma once
// Cloud weather masks (the fractal-cloud paper, section 2.2, Table 1): for each of four cloud types a
// continuous value in [0, 1] per grid column, the fraction of the column's sky covered by that
// type, which the renderer's cloud function adds (equation 1).
//
// The model (docs/weather.md has the derivation, the defaults and the validation):
//  1. Cloud fraction at each altitude sample from relative humidity and cloud condensate with
//     GFS's own diagnostic (Xu & Randall 1996 as coded in GFS radiation, progcld1):
//       c = RH^p * (1 - exp(-a * q_c / ((1 - RH) q_s)^(1/4))),  c = 0 if q_c < q_min * p/1000hPa
//     or, for files without clwmr, a relative-humidity ramp between rh_critical and 1.
//  2. Table 1 decides the class of the cloud at each sample: the vertical-wind condition on the
//     updraft -omega [Pa/s, positive = rising], the temperature condition in degrees Celsius
//     (Table 1 prints "-40 K"; -40 degC, the homogeneous freezing point, is meant), evaluated at
//     the sample or at the cloud top of the type's band. Edges are linear ramps of a given width
//     so that the mask is continuous; complementary types (stratus/cumulus) sum to the cloud.
//  3. The classified fractions are combined over the type's altitude band with maximum-random
//     overlap (contiguous cloudy samples overlap maximally, separated ones randomly), as GFS does.
#include <array>
#include <limits>
#include <string>
#include <vector>

#include "nephos/core/config.hpp"
#include "nephos/weather/weather_grid.hpp"

namespace nephos::weather {

enum class CloudType : int { low_stratus, low_cumulus, altostratus, cirrus };
inline constexpr int cloud_type_count = 4;
const char* name(CloudType t);                            ///< "low_stratus", ...
const char* long_name(CloudType t);                       ///< "low stratus cloud fraction"
CloudType cloud_type_from_name(const std::string& name);  ///< ValueError if unknown

enum class TemperatureReference { sample, cloud_top };

struct CloudFractionParams {
  double rh_exponent = 0.25;               ///< p
  double condensate_coefficient = 2000.0;  ///< a [dimensionless]
  double min_condensate_kg_kg = 1e-6;      ///< q_min at 1000 hPa, scaled by p/1000 hPa
  double rh_critical = 0.9;                ///< RH-ramp fallback when the file has no clwmr
  bool use_condensate = true;              ///< false: always the RH ramp (for comparison)
};

struct CloudTypeMaskParams {
  double band_bottom_m = 0, band_top_m = 0;  ///< altitude band the mask gathers cloud from [m MSL]
  double updraft_min_pa_s = -std::numeric_limits<double>::infinity();   ///< -omega lower bound [Pa/s]
  double updraft_max_pa_s = std::numeric_limits<double>::infinity();    ///< -omega upper bound [Pa/s]
  double temperature_min_c = -std::numeric_limits<double>::infinity();  ///< [degC]
  double temperature_max_c = std::numeric_limits<double>::infinity();   ///< [degC]
  TemperatureReference temperature_at = TemperatureReference::sample;
};

struct MaskParams {
  CloudFractionParams cloud_fraction;
  double vertical_step_m = 250.0;        ///< altitude sampling step inside each band [m]
  double updraft_ramp_pa_s = 0.02;       ///< width of the vertical-wind condition edges [Pa/s]
  double temperature_ramp_k = 2.0;       ///< width of the temperature condition edges [K]
  double cloud_top_min_fraction = 0.01;  ///< a sample counts as cloud top above this fraction
  std::array<CloudTypeMaskParams, cloud_type_count> types;

  /// Defaults (docs/weather.md): Table 1's conditions, bands tuned on 2011-01-10 GFS.
  MaskParams();
  /// Reads [cloud_fraction], [masks], [masks.<type>] tables; unknown keys are errors (on check_unused).
  static MaskParams from(const ParamDict& dict);
  const CloudTypeMaskParams& operator[](CloudType t) const { return types[static_cast<std::size_t>(t)]; }
  CloudTypeMaskParams& operator[](CloudType t) { return types[static_cast<std::size_t>(t)]; }
};

/// Fraction of a grid box covered by cloud from RH [fraction], condensate [kg/kg] (NaN = none
/// in file), temperature [K] and pressure [Pa].
double cloud_fraction(double relative_humidity, double condensate_kg_kg, double temperature_k, double pressure_pa,
                      const CloudFractionParams& p);
/// Saturation mixing ratio [kg/kg] over water (T >= 0 degC), ice (T <= -20 degC), linearly
/// blended between (as GFS's fpvs), Alduchov & Eskridge (1996) formulas.
double saturation_mixing_ratio(double temperature_k, double pressure_pa);

/// The altitudes [m MSL] whose condensate each type's clouds carry, [bottom, top) per type:
/// its band, from the top of any band it overlaps from below (cirrus, 3-20 km, from the top of
/// altostratus's 3-7 km), so that no condensate is carried twice. Types of one band (the two
/// low types) share it.
std::array<std::array<double, 2>, cloud_type_count> condensate_layers_m(const MaskParams& params);

struct WeatherMasks {
  LatLonGrid grid;
  std::array<std::vector<float>, cloud_type_count> value;  ///< per type, nlat*nlon in grid order
  /// condensate_layers_m() of the parameters the masks were computed with.
  std::array<std::array<double, 2>, cloud_type_count> condensate_layer_m = condensate_layers_m(MaskParams());
  const std::vector<float>& operator[](CloudType t) const { return value[static_cast<std::size_t>(t)]; }
};

/// Computes all four masks (OpenMP over rows; bit-identical for any thread count).
/// Throws FormatError naming the missing fields if the weather lacks gh, t, r or w.
WeatherMasks compute_masks(const WeatherGrid& weather, const MaskParams& params);

/// Agreement of the masks with GFS's own cloud cover (tcc) for one layer.
struct LayerAgreement {
  CloudLayer layer;
  std::string mask;        ///< which mask(s) were compared
  double mask_cover = 0;   ///< area-weighted mean of the mask
  double gfs_cover = 0;    ///< area-weighted mean of tcc
  double correlation = 0;  ///< area-weighted Pearson correlation
};
/// low: max(low_stratus, low_cumulus); middle: altostratus; high: cirrus. Layers without tcc are skipped.
std::vector<LayerAgreement> compare_with_gfs_cloud_cover(const WeatherMasks& masks, const WeatherGrid& weather);

/// Area-weighted mean and correlation helpers on a lat-lon grid (cell areas from cell_area_fraction).
double area_mean(const LatLonGrid& g, const std::vector<float>& v);
double area_correlation(const LatLonGrid& g, const std::vector<float>& a, const std::vector<float>& b);

}  // namespace nephos::weather
