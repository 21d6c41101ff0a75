#include "nephos/weather/masks.hpp"

#include <gtest/gtest.h>

#include <limits>

#include <cmath>
#include <cstring>

#include "nephos/core/config.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/weather/reader.hpp"

namespace nephos::weather {
namespace {

constexpr double inf = std::numeric_limits<double>::infinity();

// Isothermal (250 K) atmosphere on a coarse global grid, levels every 50 hPa. Relative
// humidity 0.95 on the given pressure plateaus [hPa] and 0.3 elsewhere, no condensate field
// (so the RH-ramp cloud fraction applies: (0.95 - 0.9) / 0.1 = 0.5 on a plateau).
WeatherGrid plateau_grid(std::vector<std::pair<double, double>> plateaus_hpa, double omega_pa_s) {
  LatLonGrid g{3, 4, -90, 90, 0, 90};
  std::vector<double> levels;
  for (double p = 1000; p >= 100; p -= 50) levels.push_back(p * 100);
  WeatherGrid w(g, levels);
  for (int k = 0; k < w.level_count(); ++k) {
    const double p = levels[static_cast<std::size_t>(k)];
    const double h = 287.05 * 250.0 / earth::g0_m_s2 * std::log(1e5 / p);
    bool wet = false;
    for (auto [hi, lo] : plateaus_hpa) wet |= p / 100 <= hi && p / 100 >= lo;
    for (std::size_t q = 0; q < g.size(); ++q) {
      w.level_data(Field::geopotential_height, k)[q] = static_cast<float>(h);
      w.level_data(Field::temperature, k)[q] = 250.0f;
      w.level_data(Field::relative_humidity, k)[q] = wet ? 0.95f : 0.3f;
      w.level_data(Field::omega, k)[q] = static_cast<float>(omega_pa_s);
    }
  }
  return w;
}

MaskParams one_band_everything() {
  MaskParams p;
  for (auto& t : p.types) t.band_bottom_m = 0, t.band_top_m = 15000;
  return p;
}

TEST(CloudFraction, LimitsAndMonotonicity) {
  const CloudFractionParams p;
  // Saturated air with ample condensate is overcast: RH^p = 1 and exp(-50) ~ 2e-22.
  EXPECT_NEAR(cloud_fraction(1.0, 1e-3, 280, 90000, p), 1.0, 1e-12);
  EXPECT_EQ(cloud_fraction(0.95, 0.0, 280, 90000, p), 0.0);  // no condensate, no cloud
  double prev = 0;
  for (double q : {1e-6, 1e-5, 3e-5, 1e-4}) {
    const double c = cloud_fraction(0.9, q, 280, 90000, p);
    EXPECT_GT(c, prev);
    prev = c;
  }
  // Without a condensate field: the humidity ramp (RH - 0.9) / 0.1.
  EXPECT_NEAR(cloud_fraction(0.95, std::nan(""), 280, 90000, p), 0.5, 1e-12);  // rounding of 0.95 - 0.9
  EXPECT_EQ(cloud_fraction(0.85, std::nan(""), 280, 90000, p), 0.0);
}

TEST(CloudFraction, SaturationMixingRatioMatchesTables) {
  // Saturation vapour pressure over water at 20 degC is 2.3389 kPa and over ice at -30 degC
  // 0.03801 kPa (WMO-No. 8 / Murphy & Koop 2005 tables). q_s = 0.622 e / (p - 0.378 e).
  // 0.3 % covers the Alduchov-Eskridge fit error (< 0.1 % here) and table rounding.
  auto qs = [](double e, double p) { return 0.622 * e / (p - 0.378 * e); };
  EXPECT_NEAR(saturation_mixing_ratio(293.15, 1e5) / qs(2338.9, 1e5), 1.0, 3e-3);
  EXPECT_NEAR(saturation_mixing_ratio(243.15, 5e4) / qs(38.01, 5e4), 1.0, 3e-3);
}

TEST(Masks, MaximumRandomOverlap) {
  // Two separated layers of cloud fraction 0.5 overlap at random: 1 - 0.5 * 0.5 = 0.75;
  // one deep layer of 0.5 stays 0.5 however many samples it spans (maximum overlap).
  const MaskParams p = one_band_everything();
  const auto two = compute_masks(plateau_grid({{900, 800}, {500, 450}}, 0.0), p);
  EXPECT_NEAR(two[CloudType::low_stratus][5], 0.75, 1e-6);  // float storage
  const auto one = compute_masks(plateau_grid({{900, 600}}, 0.0), p);
  EXPECT_NEAR(one[CloudType::low_stratus][5], 0.5, 1e-6);
  const auto none = compute_masks(plateau_grid({}, 0.0), p);
  EXPECT_EQ(none[CloudType::low_stratus][5], 0.0f);
}

TEST(Masks, VerticalWindDecidesStratusOrCumulus) {
  const MaskParams p = one_band_everything();
  // omega = -0.5 Pa/s is rising air well above the 0.12 Pa/s threshold: all cumulus.
  const auto rising = compute_masks(plateau_grid({{900, 800}}, -0.5), p);
  EXPECT_NEAR(rising[CloudType::low_cumulus][5], 0.5, 1e-6);
  EXPECT_EQ(rising[CloudType::low_stratus][5], 0.0f);
  // Sinking air (omega > 0): stratus (subsidence stratocumulus), never cumulus.
  const auto sinking = compute_masks(plateau_grid({{900, 800}}, 0.05), p);
  EXPECT_NEAR(sinking[CloudType::low_stratus][5], 0.5, 1e-6);
  EXPECT_EQ(sinking[CloudType::low_cumulus][5], 0.0f);
  // Exactly on the 0.12 Pa/s threshold each gate is at the middle of its ramp (0.5): the
  // cloud is split evenly and the two types sum to it.
  const auto edge = compute_masks(plateau_grid({{900, 800}}, -0.12), p);
  EXPECT_NEAR(edge[CloudType::low_stratus][5], 0.25, 1e-6);
  EXPECT_NEAR(edge[CloudType::low_cumulus][5], 0.25, 1e-6);
}

TEST(Masks, TemperatureDecidesAltostratusOrCirrus) {
  const MaskParams p = one_band_everything();
  // 250 K = -23 degC: warmer than -40 degC, so altostratus and no cirrus.
  const auto m = compute_masks(plateau_grid({{500, 450}}, 0.0), p);
  EXPECT_NEAR(m[CloudType::altostratus][5], 0.5, 1e-6);
  EXPECT_EQ(m[CloudType::cirrus][5], 0.0f);
}

TEST(Masks, ParametersFromTomlRejectUnknownKeys) {
  const auto d =
      ParamDict::from_string("[masks.cirrus]\nband_bottom_m = 7000\n[masks.low_stratus]\nbogus = 1\n", "m.toml");
  const MaskParams p = MaskParams::from(d);
  EXPECT_EQ(p[CloudType::cirrus].band_bottom_m, 7000);
  EXPECT_THROW(d.check_unused(), ConfigError);
  EXPECT_THROW(MaskParams::from(ParamDict::from_string("[masks.cirrus]\ntemperature_at = 'middle'\n")), ConfigError);
  EXPECT_THROW(MaskParams::from(ParamDict::from_string("[masks.cirrus]\nband_top_m = -5.0\n")), ConfigError);
  // Values that would make the column walk never end (a 1e-9 m step, a band up to infinity) or
  // divide by zero (rh_critical = 1) are errors, while inf stays the "no bound" of a threshold.
  EXPECT_THROW(MaskParams::from(ParamDict::from_string("[masks]\nvertical_step_m = 1e-9\n")), ConfigError);
  EXPECT_THROW(MaskParams::from(ParamDict::from_string("[masks.cirrus]\nband_top_m = inf\n")), ConfigError);
  EXPECT_THROW(MaskParams::from(ParamDict::from_string("[cloud_fraction]\nrh_critical = 1.0\n")), ConfigError);
  EXPECT_EQ(MaskParams::from(ParamDict::from_string("[masks.cirrus]\nupdraft_max_pa_s = inf\n"))
                .types[static_cast<std::size_t>(CloudType::cirrus)]
                .updraft_max_pa_s,
            std::numeric_limits<double>::infinity());
}

TEST(Masks, ShippedParameterFileIsCompleteAndEqualsTheDefaults) {
  const auto d = ParamDict::from_file(std::filesystem::path(NEPHOS_SOURCE_DIR) / "configs/masks.toml");
  const MaskParams p = MaskParams::from(d);
  EXPECT_NO_THROW(d.check_unused());
  const MaskParams def;
  EXPECT_EQ(p.cloud_fraction.rh_critical, def.cloud_fraction.rh_critical);
  EXPECT_EQ(p.vertical_step_m, def.vertical_step_m);
  for (int t = 0; t < cloud_type_count; ++t) {
    const auto& a = p.types[static_cast<std::size_t>(t)];
    const auto& b = def.types[static_cast<std::size_t>(t)];
    EXPECT_EQ(a.band_bottom_m, b.band_bottom_m);
    EXPECT_EQ(a.band_top_m, b.band_top_m);
    EXPECT_EQ(a.updraft_min_pa_s, b.updraft_min_pa_s);
    EXPECT_EQ(a.updraft_max_pa_s, b.updraft_max_pa_s);
    EXPECT_EQ(a.temperature_min_c, b.temperature_min_c);
    EXPECT_EQ(a.temperature_max_c, b.temperature_max_c);
    EXPECT_EQ(a.temperature_at, b.temperature_at);
  }
}

TEST(Masks, MissingFieldsAreNamed) {
  WeatherGrid w(LatLonGrid{3, 4, -90, 90, 0, 90}, {100000, 50000});
  w.level_data(Field::geopotential_height, 0);
  try {
    compute_masks(w, MaskParams{});
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("t, r, w"), std::string::npos) << e.what();
  }
}

// ---- The real GFS samples ---------------------------------------------------------------

WeatherGrid real(const char* name) { return open_weather(std::filesystem::path(NEPHOS_SOURCE_DIR) / "data" / name); }
std::size_t cell(const LatLonGrid& g, double lat, double lon) {
  return static_cast<std::size_t>(std::lround((lat - g.lat0_deg) / g.dlat_deg) * g.nlon +
                                  std::lround(lon / g.dlon_deg));
}

TEST(MasksOnGfs, HandCheckedCells) {
  const WeatherGrid w = real("gfs_20110110_12z_f120_2p5deg.grib2");
  const auto m = compute_masks(w, MaskParams{});
  const auto& g = w.grid();
  // 27.5N 222.5E, the NE Pacific stratocumulus deck: GFS low cloud 97 %, middle and high 0 %,
  // omega(800 hPa) = +0.010 Pa/s (subsiding). Expect stratus, not cumulus, nothing aloft.
  const auto sc = cell(g, 27.5, 222.5);
  EXPECT_GT(m[CloudType::low_stratus][sc], 0.5f);
  EXPECT_LT(m[CloudType::low_cumulus][sc], 0.05f);
  EXPECT_LT(m[CloudType::cirrus][sc], 0.05f);
  // 15N 245E: GFS high cloud 99 %, low 0 %, middle 0 %: cirrus only.
  const auto ci = cell(g, 15, 245);
  EXPECT_GT(m[CloudType::cirrus][ci], 0.5f);
  EXPECT_LT(std::max(m[CloudType::low_stratus][ci], m[CloudType::low_cumulus][ci]), 0.05f);
  // 22.5N 45E, central Arabia: GFS clear in every layer.
  const auto clear = cell(g, 22.5, 45);
  for (int t = 0; t < cloud_type_count; ++t)
    EXPECT_LT(m.value[static_cast<std::size_t>(t)][clear], 0.05f) << name(static_cast<CloudType>(t));
}

void expect_agreement(const char* file) {
  const WeatherGrid w = real(file);
  const auto agreement = compare_with_gfs_cloud_cover(compute_masks(w, MaskParams{}), w);
  ASSERT_EQ(agreement.size(), 3u);
  for (const auto& a : agreement) {
    // Area-weighted correlation >= 0.75 per layer with one threshold set (a consistency check).
    EXPECT_GE(a.correlation, 0.75) << file << " layer " << name(a.layer);
    // Cover within 0.08 (absolute) of GFS's: the masks neither flood nor starve the sky.
    EXPECT_NEAR(a.mask_cover, a.gfs_cover, 0.08) << file << " layer " << name(a.layer);
  }
}

TEST(MasksOnGfs, AgreeWithGfsCloudCoverOnTheTuningDate) { expect_agreement("gfs_20110110_12z_f120_2p5deg.grib2"); }
TEST(MasksOnGfs, AgreeWithGfsCloudCoverOnAnUntunedDate) {
  expect_agreement("validation/gfs_20111008_00z_f072_2p5deg.grib2");
}

TEST(MasksOnGfs, BitIdenticalForOneAndTwoThreads) {
  const WeatherGrid w = real("gfs_20110110_12z_f120_2p5deg.grib2");
  set_threads(1);
  const auto a = compute_masks(w, MaskParams{});
  set_threads(2);
  const auto b = compute_masks(w, MaskParams{});
  set_threads(0);
  for (int t = 0; t < cloud_type_count; ++t)
    EXPECT_EQ(std::memcmp(a.value[static_cast<std::size_t>(t)].data(), b.value[static_cast<std::size_t>(t)].data(),
                          a.value[0].size() * sizeof(float)),
              0);
}

}  // namespace
}  // namespace nephos::weather
