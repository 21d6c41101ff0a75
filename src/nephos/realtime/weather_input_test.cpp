#include "nephos/realtime/weather_input.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"
#include "nephos/weather/reader.hpp"
#include "nephos/weather/sampler.hpp"

namespace nephos::realtime {

TEST(WeatherCode, EveryDocumentedCodeDecodes) {
  // 2 (day/night) x 7 cloudiness x 5 precipitation x 3 types = 210 codes.
  int n = 0;
  for (char dn : {'d', 'n'})
    for (int c = 0; c <= 6; ++c)
      for (int p = 0; p <= 4; ++p)
        for (int t = 0; t <= 2; ++t) {
          const std::string s{dn, static_cast<char>('0' + c), static_cast<char>('0' + p), static_cast<char>('0' + t)};
          const WeatherCode w = parse_weather_code(s);
          EXPECT_EQ(w.text(), s);
          EXPECT_FALSE(w.describe().empty());
          EXPECT_NO_THROW(recipe_from_code(w));
          ++n;
        }
  EXPECT_EQ(n, 210);
  EXPECT_EQ(parse_weather_code("D210").text(), "d210");  // case-insensitive
  for (const char* bad : {"d700", "d050", "d003", "x000", "d00", "d0000", ""})
    EXPECT_THROW(parse_weather_code(bad), ValueError) << bad;
}

TEST(WeatherCode, ThesisMapping) {
  // Section 3.3.1: d000/d100/d200/d300/d400 -> 0/10/30/75/200 clouds; d300/d400 clustered.
  const int expected[] = {0, 10, 30, 75, 200};
  for (int c = 0; c <= 4; ++c) {
    const CloudRecipe r = recipe_from_code(parse_weather_code("d" + std::to_string(c) + "00"));
    EXPECT_EQ(r.sprite_clouds(), expected[c]) << c;
    EXPECT_EQ(r.clustered, c >= 3) << c;
  }
  // Thin high clouds: cirrus layers, at most two; fog: low stratus; showers/thunder: cumulus.
  const CloudRecipe ci = recipe_from_code(parse_weather_code("d500"));
  ASSERT_EQ(ci.layers.size(), 1u);
  EXPECT_EQ(ci.layers[0].type, SpriteCloudType::cirrus);
  EXPECT_LE(ci.layers[0].count, 2);
  EXPECT_EQ(recipe_from_code(parse_weather_code("n600")).layers[0].type, SpriteCloudType::low_stratus);
  for (const char* c : {"d220", "d340"})
    for (const auto& l : recipe_from_code(parse_weather_code(c)).layers)
      EXPECT_NE(l.type, SpriteCloudType::stratocumulus) << c;
  // Altitude bands are ordered: sprites below altostratus below cirrus.
  const CloudRecipe ov = recipe_from_code(parse_weather_code("d400"));
  double sprite_top = 0, as_base = 1e9;
  for (const auto& l : ov.layers) {
    if (l.type == SpriteCloudType::altostratus)
      as_base = l.base_m;
    else
      sprite_top = std::max(sprite_top, l.top_m);
  }
  EXPECT_LT(sprite_top, as_base);
  EXPECT_LT(as_base, ci.layers[0].base_m);
}

TEST(Metar, CloudGroups) {
  const CloudRecipe r = recipe_from_metar("EGLL 051350Z 24015KT 9999 FEW012 SCT025CB BKN080 OVC250 12/08 Q1012");
  ASSERT_EQ(r.layers.size(), 4u);
  EXPECT_EQ(r.layers[0].type, SpriteCloudType::cumulus);  // FEW at 1200 ft
  EXPECT_NEAR(r.layers[0].base_m, 1200 * 0.3048, 1e-9);   // hundreds of feet -> m (exact factor)
  EXPECT_EQ(r.layers[0].coverage_oktas, 1.5);
  EXPECT_EQ(r.layers[1].type, SpriteCloudType::cumulus);  // CB tower
  EXPECT_GT(r.layers[1].top_m, 9000);
  EXPECT_EQ(r.layers[2].type, SpriteCloudType::altostratus);  // BKN at 8000 ft (2438 m)
  EXPECT_EQ(r.layers[3].type, SpriteCloudType::cirrus);       // OVC at 25000 ft
  EXPECT_EQ(r.layers[3].coverage_oktas, 8);
  EXPECT_EQ(recipe_from_metar("KSFO 051356Z 00000KT CAVOK 14/07 A3001").layers.size(), 0u);
  EXPECT_EQ(recipe_from_metar("KJFK 051356Z SKC").sprite_clouds(), 0);
  EXPECT_EQ(recipe_from_metar("EDDF 051350Z 0200 FG VV002").layers.at(0).type, SpriteCloudType::low_stratus);
  EXPECT_EQ(recipe_from_metar("LFPG 051350Z OVC020").layers.at(0).type, SpriteCloudType::stratocumulus);
  EXPECT_EQ(recipe_from_metar("LFPG 051350Z OVC004").layers.at(0).type, SpriteCloudType::low_stratus);
  EXPECT_EQ(recipe_from_metar("LFPG 051350Z BKN007").layers.at(0).type, SpriteCloudType::low_stratus);
  EXPECT_THROW(recipe_from_metar("EGLL 051350Z 24015KT 9999 12/08"), ValueError);
}

TEST(Metar, TrendAndRemarksAreNotTheSkyNow) {
  // WMO No. 306 FM 15: a trend (TEMPO, BECMG, NOSIG) and national remarks (RMK) follow the
  // observed groups; their cloud groups forecast or qualify, so only FEW020 describes the sky.
  for (const char* tail : {"TEMPO 4000 RA BKN012", "BECMG OVC008", "NOSIG", "RMK BKN V OVC FEW CB DSNT N",
                           "PROB30 TEMPO SCT015CB", "INTER OVC004"}) {
    const CloudRecipe r = recipe_from_metar(std::string("EGLL 271020Z 24012KT 9999 FEW020 12/08 Q1012 ") + tail);
    ASSERT_EQ(r.layers.size(), 1u) << tail;
    EXPECT_EQ(r.layers[0].type, SpriteCloudType::cumulus) << tail;
    EXPECT_EQ(r.layers[0].coverage_oktas, 1.5) << tail;
  }
  // A report whose only cloud group is in the trend has no cloud group of its own.
  EXPECT_THROW(recipe_from_metar("EGLL 271020Z 24012KT 9999 12/08 Q1012 TEMPO BKN012"), ValueError);
}

TEST(Metar, AutomaticStationGroupsWithoutBase) {
  // Automatic stations write /// for what the sensors cannot tell (base above the ceilometer's
  // range, or cover and base unknown): those groups are left out, the others kept.
  const CloudRecipe r = recipe_from_metar("LFPG 271030Z AUTO 24012KT 9999 BKN035 OVC/// //////CB 12/08 Q1012");
  ASSERT_EQ(r.layers.size(), 1u);
  EXPECT_EQ(r.layers[0].type, SpriteCloudType::stratocumulus);  // BKN at 3500 ft = 1067 m: low, closed
  // Nothing with a base: an error that names the groups it could not use.
  try {
    recipe_from_metar("LFPG 271030Z AUTO 24012KT 9999 OVC/// 12/08 Q1012");
    ADD_FAILURE() << "expected a ValueError";
  } catch (const ValueError& e) {
    EXPECT_NE(std::string(e.what()).find("OVC///"), std::string::npos) << e.what();
  }
}

TEST(Metar, MalformedCloudGroupIsAnError) {
  // Something that starts like a cloud group but is not one is a typing error, not a group to skip.
  for (const char* group : {"SCT-10", "BKN", "OVC25", "FEW0200", "BKN025XX", "VV1"}) {
    try {
      recipe_from_metar(std::string("EDDM 271020Z 25010KT 9999 FEW040 ") + group);
      ADD_FAILURE() << group << ": expected a ValueError";
    } catch (const ValueError& e) {
      EXPECT_NE(std::string(e.what()).find(group), std::string::npos) << e.what();
      EXPECT_EQ(e.context().key, "metar");
    }
  }
}

TEST(GfsRecipe, HandCheckedCellsOfTheEmbeddedSample) {
  // The cells weather/masks_test.cpp checks against GFS's own cloud cover.
  const auto w =
      weather::open_weather(std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2");
  const auto masks = weather::compute_masks(w, weather::MaskParams{});
  // NE Pacific stratocumulus deck (GFS low cloud 97 %): mostly stratocumulus sprites, no cirrus.
  const CloudRecipe sc = recipe_from_weather(masks, w, 27.5, 222.5);
  int st = 0, high = 0;
  for (const auto& l : sc.layers) {
    if (l.type == SpriteCloudType::stratocumulus) st = l.count;
    if (l.type == SpriteCloudType::cirrus) ++high;
  }
  EXPECT_GT(st, 100);
  EXPECT_EQ(high, 0);
  // 15N 245E: GFS high cloud 99 %: a cirrus layer, hardly any sprites.
  const CloudRecipe ci = recipe_from_weather(masks, w, 15, 245);
  EXPECT_TRUE(
      std::any_of(ci.layers.begin(), ci.layers.end(), [](const auto& l) { return l.type == SpriteCloudType::cirrus; }));
  EXPECT_LT(ci.sprite_clouds(), 10);
  // Central Arabia, clear in GFS: nothing.
  EXPECT_TRUE(recipe_from_weather(masks, w, 22.5, 45).layers.empty());
  // Off a regional grid there is no weather: an error naming --position, not a clear sky.
  weather::WeatherMasks regional;
  regional.grid = {11, 21, 30, 1.0, 10, 1.0};  // 30..40 N, 10..30 E
  for (auto& v : regional.value) v.assign(regional.grid.size(), 0.5f);
  EXPECT_GT(recipe_from_weather(regional, w, 35, 20).sprite_clouds(), 0);
  for (const auto& [lat, lon] : {std::pair{45.0, 20.0}, std::pair{35.0, 40.0}}) {
    try {
      recipe_from_weather(regional, w, lat, lon);
      ADD_FAILURE() << "no error at " << lat << ", " << lon;
    } catch (const ValueError& e) {
      EXPECT_NE(std::string(e.what()).find("position"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("outside the weather grid"), std::string::npos) << e.what();
    }
  }
  // Drift = the 2000 m wind, the same numbers the weather sampler gives.
  const auto s = weather::WeatherSampler(w).sample(27.5, 222.5, 2000);
  EXPECT_EQ(sc.drift_east_m_s, s.u_m_s);
  EXPECT_EQ(sc.drift_north_m_s, s.v_m_s);
}

TEST(Foreca, HourlyAndDailyJson) {
  const auto hourly = test_support::temp_path("foreca_hourly.json"),
             daily = test_support::temp_path("foreca_daily.json");
  // The shapes of thesis section 2.3.
  std::ofstream(hourly) << R"({"id": "1172451", "weather": [
      {"s": "d000", "t": "2024-02-05T08:00Z", "temp": 16, "wd": 343, "ws": 3},
      {"s": "d210", "t": "2024-02-05T09:00Z", "temp": 17, "wd": 340, "ws": 4},
      {"s": "d400", "t": "2024-02-05T10:00Z", "temp": 17, "wd": 335, "ws": 5}]})";
  std::ofstream(daily) << R"({"id": "1040652", "weather": [
      {"d": "2023-09-05", "maxT": 33, "minT": 18, "s": "d100"},
      {"d": "2023-09-06", "maxT": 31, "minT": 17, "s": "d300"}]})";
  EXPECT_EQ(code_from_foreca_json(hourly, UtcTime::parse("2024-02-05T09:30Z")).text(), "d210");
  EXPECT_EQ(code_from_foreca_json(hourly, UtcTime::parse("2024-02-05T07:00Z")).text(), "d000");  // before all: first
  EXPECT_EQ(code_from_foreca_json(daily, UtcTime::parse("2023-09-06T12:00Z")).text(), "d300");
  std::ofstream(hourly) << R"({"weather": [{"t": "2024-02-05T08:00Z"}]})";
  try {
    code_from_foreca_json(hourly, UtcTime::parse("2024-02-05T09:30Z"));
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_EQ(e.context().field, "weather[].s");
  }
  std::ofstream(hourly) << R"({"weather": [{"s": "d999", "t": "2024-02-05T08:00Z"}]})";
  EXPECT_THROW(code_from_foreca_json(hourly, UtcTime::parse("2024-02-05T09:30Z")), FormatError);
  std::ofstream(hourly) << "not json";
  EXPECT_THROW(code_from_foreca_json(hourly, UtcTime::parse("2024-02-05T09:30Z")), FormatError);
  std::filesystem::remove(hourly);
  std::filesystem::remove(daily);
  EXPECT_THROW(code_from_foreca_json(hourly, UtcTime{}), IoError);
}

}  // namespace nephos::realtime
