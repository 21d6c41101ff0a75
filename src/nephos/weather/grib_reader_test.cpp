#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"
#include "nephos/weather/grib_reader.hpp"
#include "test_grib_writer.hpp"

namespace nephos::weather {
namespace {

using testing::GribGridSpec;

// A smooth field periodic in longitude, so any longitude convention must give the same value.
double analytic(double lat, double lon) {
  return 1000.0 + 3.0 * lat + 20.0 * std::sin(lon * M_PI / 180.0) + 5.0 * std::cos(2 * lon * M_PI / 180.0);
}
// 24-bit packing of a field spanning ~400 units quantises to ~400/2^24 = 2.4e-5; 1e-3 is ample.
constexpr double packing_tol = 1e-3;

class GribReaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        test_support::temp_path("grib_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path file(const std::string& n) const { return dir_ / n; }

  // Writes gh/t/r at three levels, r missing at 850 hPa.
  std::filesystem::path write_file(const GribGridSpec& spec, const std::string& fname) {
    const auto p = file(fname);
    for (long lev : {1000L, 850L, 500L}) {
      append_grib(p, spec, "gh", "isobaricInhPa", lev,
                  [lev](double la, double lo) { return analytic(la, lo) + static_cast<double>(1000 - lev) * 10; });
      append_grib(p, spec, "t", "isobaricInhPa", lev, [lev](double la, double lo) {
        return 250 + 0.1 * analytic(la, lo) - static_cast<double>(1000 - lev) * 0.05;
      });
      if (lev != 850) append_grib(p, spec, "r", "isobaricInhPa", lev, [](double la, double) { return 50 + la / 2; });
    }
    return p;
  }

  void expect_grid_matches_analytic(const WeatherGrid& w) {
    const auto& g = w.grid();
    for (int k = 0; k < w.level_count(); ++k) {
      const double lev = w.pressure_levels_pa()[static_cast<std::size_t>(k)] / 100.0;
      for (int j = 0; j < g.nlat; ++j)
        for (int i = 0; i < g.nlon; ++i)
          ASSERT_NEAR(w.value(Field::geopotential_height, k, j, i), analytic(g.lat(j), g.lon(i)) + (1000 - lev) * 10,
                      packing_tol)
              << "k=" << k << " lat=" << g.lat(j) << " lon=" << g.lon(i);
    }
  }
  std::filesystem::path dir_;
};

TEST_F(GribReaderTest, Grib2NorthToSouthZeroTo360) {
  GribGridSpec s;  // rows 60, 30, 0, -30, -60; lon 0..315
  const WeatherGrid w = open_weather(write_file(s, "a.grib2"));
  EXPECT_EQ(w.grid().nlat, 5);
  EXPECT_EQ(w.grid().nlon, 8);
  EXPECT_DOUBLE_EQ(w.grid().lat0_deg, -60);
  EXPECT_DOUBLE_EQ(w.grid().lon0_deg, 0);
  EXPECT_TRUE(w.grid().wraps());
  ASSERT_EQ(w.level_count(), 3);
  EXPECT_EQ(w.pressure_levels_pa()[0], 100000.0);  // bottom first
  expect_grid_matches_analytic(w);
  // A known point: lat 30, lon 90 -> row j = 3, column i = 2.
  EXPECT_NEAR(w.value(Field::geopotential_height, 0, 3, 2), 1000 + 90 + 20 - 5, packing_tol);
}

TEST_F(GribReaderTest, Grib2SouthToNorthMinus180To180) {
  GribGridSpec s;
  s.j_scans_positively = true;
  s.lat_first = -60;
  s.lon_first = -180;
  const WeatherGrid w = open_weather(write_file(s, "b.grib2"));
  EXPECT_DOUBLE_EQ(w.grid().lon0_deg, 0);  // normalised to 0..360
  EXPECT_TRUE(w.grid().wraps());
  expect_grid_matches_analytic(w);
}

TEST_F(GribReaderTest, Grib2EastToWest) {
  GribGridSpec s;
  s.i_scans_negatively = true;
  s.lon_first = 315;
  const WeatherGrid w = open_weather(write_file(s, "c.grib2"));
  expect_grid_matches_analytic(w);
}

TEST_F(GribReaderTest, Grib1BothConventionsAndScans) {
  GribGridSpec s;
  s.edition = 1;
  const WeatherGrid a = open_weather(write_file(s, "d.grib1"));
  EXPECT_EQ(a.metadata().grib_edition, 1);
  expect_grid_matches_analytic(a);
  s.j_scans_positively = true;
  s.lat_first = -60;
  s.lon_first = -180;
  const WeatherGrid b = open_weather(write_file(s, "e.grib1"));
  expect_grid_matches_analytic(b);
}

TEST_F(GribReaderTest, RegionalGridAcrossGreenwich) {
  GribGridSpec s;
  s.ni = 5;
  s.dlon = 10;
  s.lon_first = -20;  // -20..20
  const WeatherGrid w = open_weather(write_file(s, "f.grib2"));
  EXPECT_FALSE(w.grid().wraps());
  EXPECT_DOUBLE_EQ(w.grid().lon0_deg, 340);
  expect_grid_matches_analytic(w);
}

TEST_F(GribReaderTest, MetadataTimes) {
  const WeatherGrid w = open_weather(write_file(GribGridSpec{}, "g.grib2"));
  EXPECT_EQ(w.metadata().reference_time.iso(), "2011-01-10T12:00:00Z");
  EXPECT_EQ(w.metadata().forecast_step_h, 120.0);
  EXPECT_EQ(w.metadata().valid_time.iso(), "2011-01-15T12:00:00Z");
}

TEST_F(GribReaderTest, MissingLevelIsExplicit) {
  const WeatherGrid w = open_weather(write_file(GribGridSpec{}, "h.grib2"));
  EXPECT_TRUE(w.has(Field::relative_humidity, 0));
  EXPECT_FALSE(w.has(Field::relative_humidity, 1));  // 850 hPa was not written
  EXPECT_EQ(w.levels_of(Field::relative_humidity), (std::vector<int>{0, 2}));
  EXPECT_TRUE(std::isnan(w.value(Field::relative_humidity, 1, 0, 0)));
  // Percent converted to a fraction: 50 + lat/2 at lat -60 = 20 % -> 0.2.
  EXPECT_NEAR(w.value(Field::relative_humidity, 0, 0, 0), 0.20, 1e-5);
  EXPECT_FALSE(w.has(Field::omega));
  EXPECT_EQ(missing_for_masks(w), (std::vector<std::string>{"w"}));
}

TEST_F(GribReaderTest, RefusesOtherGridTypesByName) {
  const auto p = file("ps.grib2");
  testing::append_grib_from_sample(p, "polar_stereographic_pl_grib2", "t");
  try {
    open_weather(p);
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("polar_stereographic"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("ps.grib2"), std::string::npos);
  }
  const auto q = file("gg.grib2");
  testing::append_grib_from_sample(q, "reduced_gg_pl_32_grib2", "t");
  EXPECT_THROW(open_weather(q), FormatError);
}

TEST_F(GribReaderTest, NotGrib) {
  const auto p = file("text.grib2");
  std::ofstream(p) << "this is not a GRIB file\n";
  try {
    open_weather(p);
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("not a GRIB file"), std::string::npos) << e.what();
  }
}

// Damaged data that breaks one of ecCodes' internal assertions (here four bytes of a complex-
// packed field of the embedded sample overwritten, so that its groups overrun its values): a
// FormatError naming the file, where ecCodes itself would abort the process (found by
// overwriting bytes of the sample at random offsets). Reading continues to work after it.
TEST_F(GribReaderTest, DamagedPackingIsAnErrorNotAnAbort) {
  const auto sample = std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2";
  std::ifstream in(sample, std::ios::binary);
  std::string bytes(std::istreambuf_iterator<char>(in), {});
  ASSERT_GT(bytes.size(), 672370u);
  bytes.replace(672366, 4, "\xff\xff\xff\xff");
  const auto p = file("damaged.grib2");
  std::ofstream(p, std::ios::binary) << bytes;
  try {
    open_weather(p);
    FAIL() << "the damaged file was read";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.context().file, p.string());
    EXPECT_NE(std::string(e.what()).find("damaged GRIB data (ecCodes assertion failed"), std::string::npos) << e.what();
  }
  EXPECT_EQ(open_weather(sample).metadata().valid_time.iso(), "2011-01-15T12:00:00Z");
}

// The embedded sample with `bytes` written at `offset`, where it held `was` (checked, so that a
// changed sample fails here, not silently); the FormatError reading it throws.
std::string error_reading_sample_with(const std::filesystem::path& p, std::size_t offset, const std::string& was,
                                      const std::string& bytes) {
  const auto sample = std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2";
  std::ifstream in(sample, std::ios::binary);
  std::string data(std::istreambuf_iterator<char>(in), {});
  if (data.compare(offset, was.size(), was) != 0) return "the embedded sample changed: find the bytes again";
  data.replace(offset, bytes.size(), bytes);
  std::ofstream(p, std::ios::binary) << data;
  try {
    open_weather(p);
  } catch (const FormatError& e) {
    return e.context().file == p.string() ? e.what() : "the error does not name the file";
  }
  return "the damaged file was read";
}

// Damage ecCodes 2.28 does not survive, each found by changing bytes of the sample at random
// (docs/weather.md, damaged files): refused with a FormatError before ecCodes meets it.
TEST_F(GribReaderTest, SectionShorterThanItsFixedPartIsAnErrorNotAnAbort) {
  // The second message's section 6 (the bitmap section) said to be 2 bytes long: ecCodes
  // overruns its buffer and the process aborts (double free) when the handle is deleted.
  const std::string e = error_reading_sample_with(file("s6.grib2"), 16491, std::string("\0\0\0\x06\x06", 5),
                                                  std::string("\0\0\0\x02", 4));
  EXPECT_NE(e.find("GRIB message 2 (at byte 16299) is corrupt: it has a section 6 of 2 bytes"), std::string::npos) << e;
}

TEST_F(GribReaderTest, MessageCutShortIsNamed) {
  // The sample cut at 1 000 000 bytes, inside its 91st message: no message after a damaged one
  // is parsed unchecked.
  const auto sample = std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2";
  std::ifstream in(sample, std::ios::binary);
  std::string data(std::istreambuf_iterator<char>(in), {});
  const auto p = file("cut.grib2");
  std::ofstream(p, std::ios::binary) << data.substr(0, 1000000);
  try {
    open_weather(p);
    FAIL() << "the cut file was read";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("GRIB message 91 is corrupt: End of resource reached"), std::string::npos)
        << e.what();
  }
}

TEST_F(GribReaderTest, MoreGroupsThanValuesIsAnErrorNotACrash) {
  // Message 75's number of groups (section 5 octets 32-35) with its top bit set: ecCodes reads
  // far past the message (SIGSEGV).
  const std::string e =
      error_reading_sample_with(file("ng.grib2"), 796104 + 143 + 31, std::string("\0\0", 2), std::string("\x80", 1));
  EXPECT_NE(e.find("groups for 10512 values"), std::string::npos) << e;
}

TEST_F(GribReaderTest, UnknownUnitOfTimeIsAnErrorNotAHang) {
  // Message 196 (t at the tropopause) gives its forecast time in units of code 41, which GRIB2's
  // code table 4.4 does not define: ecCodes 2.28 computes its validityTime forever.
  const std::string e = error_reading_sample_with(file("unit.grib2"), 2282793, "\x01", "\x29");
  EXPECT_NE(e.find("field 't@tropopause' gives its forecast time in units of code 41"), std::string::npos) << e;
}

TEST_F(GribReaderTest, ValuesOutsideTheirQuantitysRangeAreAnError) {
  // t at 500 hPa with its packing's reference value (section 5 octets 12-15) made 1.7e38: every
  // value decodes far outside 100-400 K.
  const std::string e =
      error_reading_sample_with(file("ref.grib2"), 958823, "\x45\x0b\xd0\x00", std::string("\x7f\0\0\0", 4));
  EXPECT_NE(e.find("field 't@500hPa': 10512 of its 10512 values lie outside 100..400 K"), std::string::npos) << e;
}

TEST_F(GribReaderTest, SurfaceOnlyFileHasNoPressureLevels) {
  const auto p = file("sfc.grib2");
  testing::append_grib(p, GribGridSpec{}, "2t", "surface", 0, [](double, double) { return 280.0; });
  try {
    open_weather(p);
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("no pressure-level fields"), std::string::npos) << e.what();
  }
}

TEST_F(GribReaderTest, EcmwfGeopotentialGivesTheHeights) {
  // ECMWF's IFS and ERA5 store geopotential z [m2 s-2], not geopotential height gh [gpm]:
  // gh = z / 9.80665 (WMO's standard gravity defines the geopotential metre). The same levels
  // written as z must read as the gh file does.
  // ERA5 comes from ECMWF's archive as GRIB1 or GRIB2: both editions.
  for (int edition : {1, 2}) {
    GribGridSpec s;
    s.edition = edition;
    const auto p = file("era5_like.grib" + std::to_string(edition));
    for (long lev : {1000L, 850L, 500L}) {
      append_grib(p, s, "z", "isobaricInhPa", lev, [lev](double la, double lo) {
        return 9.80665 * (analytic(la, lo) + static_cast<double>(1000 - lev) * 10);
      });
      append_grib(p, s, "t", "isobaricInhPa", lev, [](double, double) { return 250.0; });
    }
    // And the ground: ECMWF's surface geopotential instead of NCEP's orog; and its cloud cover,
    // fractions of 0-1 where NCEP's tcc is in %.
    append_grib(p, s, "z", "surface", 0, [](double la, double) { return 9.80665 * (1000 + 10 * la); });
    append_grib(p, s, "lcc", "surface", 0, [](double, double) { return 0.25; });
    append_grib(p, s, "mcc", "surface", 0, [](double, double) { return 0.5; });
    append_grib(p, s, "hcc", "surface", 0, [](double la, double) { return la > 0 ? 1.0 : 0.0; });
    const WeatherGrid w = open_weather(p);
    ASSERT_EQ(w.level_count(), 3) << "GRIB" << edition;
    ASSERT_TRUE(w.has_orography()) << "GRIB" << edition;
    for (int j = 0; j < w.grid().nlat; ++j)  // a 1200 m2 s-2 range at 24 bits: steps of 1e-4 m2 s-2
      EXPECT_NEAR(w.orography_m()[static_cast<std::size_t>(j) * w.grid().nlon], 1000 + 10 * w.grid().lat(j), 1e-3);
    ASSERT_TRUE(w.has_cloud_cover(CloudLayer::low) && w.has_cloud_cover(CloudLayer::middle) &&
                w.has_cloud_cover(CloudLayer::high));
    for (int j = 0; j < w.grid().nlat; ++j) {  // constant fields pack exactly
      const auto p0 = static_cast<std::size_t>(j) * w.grid().nlon;
      EXPECT_EQ(w.cloud_cover(CloudLayer::low)[p0], 0.25f);
      EXPECT_EQ(w.cloud_cover(CloudLayer::middle)[p0], 0.5f);
      EXPECT_NEAR(w.cloud_cover(CloudLayer::high)[p0], w.grid().lat(j) > 0 ? 1.0 : 0.0, 1e-6);  // 24-bit step
    }
    // z spans ~10x the gh field's range, so its packing step is ~10x larger: ~2.4e-4 m2 s-2 at
    // 24 bits, ~2.5e-5 gpm after the division; the gh tolerance (1e-3 gpm) holds.
    expect_grid_matches_analytic(w);
    EXPECT_EQ(inventory_grib(p).unused_fields, 0) << "GRIB" << edition;
  }
}

TEST_F(GribReaderTest, CloudCondensateIsLiquidPlusIce) {
  // GFS's cloud-fraction diagnostic takes total condensate. GFS since 2019 writes liquid (clwmr)
  // and ice (icmr) mixing ratios apart, ECMWF liquid (clwc) and ice (ciwc) contents: the parts
  // at a level are summed; a level with one part takes that part.
  GribGridSpec s;
  auto liquid = [](double la, double) { return 1e-4 * (1 + la / 90); };
  auto ice = [](double, double lo) { return 5e-5 * (1 + std::cos(lo * M_PI / 180)); };
  for (const auto& [l, i] : {std::pair{"clwmr", "icmr"}, std::pair{"clwc", "ciwc"}}) {
    const auto p = file(std::string(l) + ".grib2");
    for (long lev : {850L, 500L}) {
      append_grib(p, s, "gh", "isobaricInhPa", lev, [lev](double, double) { return lev == 850 ? 1500.0 : 5500.0; });
      append_grib(p, s, "t", "isobaricInhPa", lev, [](double, double) { return 250.0; });
      append_grib(p, s, i, "isobaricInhPa", lev, ice);
    }
    append_grib(p, s, l, "isobaricInhPa", 500, liquid);  // liquid at 500 hPa only, after the ice
    const WeatherGrid w = open_weather(p);
    ASSERT_EQ(w.level_count(), 2);
    ASSERT_EQ(w.pressure_levels_pa()[1], 50000.0);
    ASSERT_TRUE(w.has(Field::cloud_water, 0) && w.has(Field::cloud_water, 1)) << l;
    const auto& g = w.grid();
    // 24-bit packing of fields spanning ~2e-4 kg/kg: steps of ~1e-11; 1e-9 is ample.
    for (int j = 0; j < g.nlat; ++j)
      for (int k = 0; k < g.nlon; ++k) {
        const double la = g.lat(j), lo = g.lon(k);
        EXPECT_NEAR(w.value(Field::cloud_water, 0, j, k), ice(la, lo), 1e-9) << l << " 850 hPa";
        EXPECT_NEAR(w.value(Field::cloud_water, 1, j, k), ice(la, lo) + liquid(la, lo), 1e-9) << l << " 500 hPa";
      }
    EXPECT_EQ(inventory_grib(p).unused_fields, 0);
  }
}

TEST_F(GribReaderTest, MissingFile) { EXPECT_THROW(open_weather(file("absent.grib2")), IoError); }

TEST(RealGfsSample, HoldsWhatTheMasksNeed) {
  const WeatherGrid w =
      open_weather(std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2");
  EXPECT_EQ(w.grid().nlon, 144);
  EXPECT_EQ(w.grid().nlat, 73);
  EXPECT_EQ(w.level_count(), 26);
  EXPECT_TRUE(missing_for_masks(w).empty());
  EXPECT_EQ(w.levels_of(Field::relative_humidity).size(), 25u);  // GFS omits r at 20 hPa
  EXPECT_EQ(w.levels_of(Field::omega).size(), 21u);              // and w above 100 hPa
  EXPECT_TRUE(w.has_cloud_cover(CloudLayer::low) && w.has_cloud_cover(CloudLayer::middle) &&
              w.has_cloud_cover(CloudLayer::high));
  EXPECT_EQ(w.metadata().valid_time.iso(), "2011-01-15T12:00:00Z");
  // Hand checks read with ecCodes' own tool (grib_get -l LAT,LON,1), which prints 2 decimals:
  // gh at 500 hPa at the North Pole = 4966.13 gpm; t at 850 hPa at 40N 255E = 273.9 K.
  const int k500 = 12, k850 = 5;
  ASSERT_EQ(w.pressure_levels_pa()[k500], 50000.0);
  ASSERT_EQ(w.pressure_levels_pa()[k850], 85000.0);
  EXPECT_NEAR(w.value(Field::geopotential_height, k500, 72, 0), 4966.13, 0.01);  // print rounding
  EXPECT_NEAR(w.value(Field::temperature, k850, 52, 102), 273.9, 0.05);          // print rounding
}

// Forecast steps are often concatenated into one file. open_weather() reads the fields of one
// valid time, the first pressure-level field's, and skips the others (cloud cover included)
// instead of mixing them in; open_weather_times() reads every time, one grid each, in time
// order. Two real files, the embedded sample and the validation date, in both orders.
TEST(MultiTimeGrib, ReadsTheFirstValidTimeAloneOrEveryTime) {
  const auto dir = std::filesystem::path(NEPHOS_SOURCE_DIR) / "data";
  const auto a_path = dir / "gfs_20110110_12z_f120_2p5deg.grib2";
  const auto b_path = dir / "validation/gfs_20111008_00z_f072_2p5deg.grib2";
  const WeatherGrid a = open_weather(a_path), b = open_weather(b_path);
  ASSERT_LT(a.metadata().valid_time, b.metadata().valid_time);
  auto expect_same = [](const WeatherGrid& w, const WeatherGrid& want, const std::string& what) {
    EXPECT_EQ(w.metadata().valid_time, want.metadata().valid_time) << what;
    EXPECT_EQ(w.metadata().reference_time, want.metadata().reference_time) << what;
    ASSERT_EQ(w.level_count(), want.level_count()) << what;
    for (int f = 0; f < field_count; ++f)
      for (int k = 0; k < w.level_count(); ++k) {
        ASSERT_EQ(w.has(static_cast<Field>(f), k), want.has(static_cast<Field>(f), k)) << what;
        if (!w.has(static_cast<Field>(f), k)) continue;
        const float *x = w.level_data(static_cast<Field>(f), k), *y = want.level_data(static_cast<Field>(f), k);
        ASSERT_TRUE(std::equal(x, x + w.grid().size(), y))
            << what << ": " << info(static_cast<Field>(f)).grib_short_name << " level " << k;
      }
    for (CloudLayer l : {CloudLayer::low, CloudLayer::middle, CloudLayer::high})
      EXPECT_EQ(w.cloud_cover(l), want.cloud_cover(l)) << what << ": tcc " << name(l);
  };
  const auto tmp = test_support::temp_path("multi_time");
  std::filesystem::create_directories(tmp);
  const auto bytes = test_support::file_bytes;
  for (const bool a_first : {true, false}) {
    const auto both = tmp / (a_first ? "ab.grib2" : "ba.grib2");
    std::ofstream(both, std::ios::binary) << (a_first ? bytes(a_path) + bytes(b_path) : bytes(b_path) + bytes(a_path));
    const std::string order = a_first ? "(a, b)" : "(b, a)";
    expect_same(open_weather(both), a_first ? a : b, "first time " + order);
    const std::vector<WeatherGrid> all = open_weather_times(both);
    ASSERT_EQ(all.size(), 2u);
    expect_same(all[0], a, "every time, earlier " + order);  // in time order, whatever the file's
    expect_same(all[1], b, "every time, later " + order);
    expect_same(open_weather(both, b.metadata().valid_time), b, "the later time asked for " + order);
    try {
      open_weather(both, UtcTime::from_civil(2011, 1, 15, 18));
      ADD_FAILURE() << "no error for a time the file lacks";
    } catch (const FormatError& e) {
      EXPECT_NE(std::string(e.what()).find("2011-01-15T12:00:00Z, 2011-10-11T00:00:00Z"), std::string::npos)
          << e.what();
    }
  }
  std::filesystem::remove_all(tmp);
}

// NCEP packs u and v wind into one GRIB2 message with two fields. The test file holds two
// messages copied byte for byte from the NOAA file in shared/data (data/README.md): gh at 500
// hPa, and u and v at 500 hPa in one message. Fault caught: reading only a message's first
// field (v lost).
TEST(MultiFieldGrib, EveryFieldOfAMessageIsRead) {
  const auto path =
      std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/test/gfs_20110110_12z_f120_500hPa_gh_uv_multifield.grib2";
  const WeatherGrid w = open_weather(path);
  ASSERT_EQ(w.level_count(), 1);
  EXPECT_TRUE(w.has(Field::u_wind, 0));
  EXPECT_TRUE(w.has(Field::v_wind, 0));
  EXPECT_TRUE(missing_for_winds(w).empty());
  // ecCodes' own tool on the same file, grib_get -l 40,255,1 (2 decimals): u 15.63, v -7.84 m/s.
  EXPECT_NEAR(w.value(Field::u_wind, 0, 52, 102), 15.63, 0.005);  // print rounding
  EXPECT_NEAR(w.value(Field::v_wind, 0, 52, 102), -7.84, 0.005);  // print rounding
  // Every value as in the embedded sample, whose u and v ecCodes' grib_copy wrote as separate
  // messages from the same NOAA file: the same packed numbers, so equal to the bit.
  const WeatherGrid ref =
      open_weather(std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2");
  const int k500 = 12;
  ASSERT_EQ(ref.pressure_levels_pa()[k500], 50000.0);
  for (Field f : {Field::geopotential_height, Field::u_wind, Field::v_wind})
    for (int j = 0; j < w.grid().nlat; ++j)
      for (int i = 0; i < w.grid().nlon; ++i)
        ASSERT_EQ(w.value(f, 0, j, i), ref.value(f, k500, j, i)) << info(f).grib_short_name << " at " << j << "," << i;
  // The inventory counts messages and fields apart.
  const GribInventory inv = inventory_grib(path);
  EXPECT_EQ(inv.messages, 2);
  EXPECT_EQ(inv.fields, 3);
  EXPECT_EQ(inv.unused_fields, 0);
}

// ecCodes keeps its place within a multi-field message per open file: reading the file again,
// and another file after it, starts from the beginning of each.
TEST(MultiFieldGrib, RereadingGivesTheSameFields) {
  const auto multi =
      std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/test/gfs_20110110_12z_f120_500hPa_gh_uv_multifield.grib2";
  const auto single = std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2";
  for (int round = 0; round < 3; ++round) {
    const WeatherGrid a = open_weather(multi);
    EXPECT_TRUE(a.has(Field::u_wind, 0) && a.has(Field::v_wind, 0)) << "round " << round;
    EXPECT_EQ(inventory_grib(multi).fields, 3) << "round " << round;
    EXPECT_EQ(inventory_grib(single).fields, 203) << "round " << round;
  }
}

// The embedded sample's single-level fields, read with their units, against what is known of
// the Earth independently of GFS: land covers 29 % of the surface, and the global mean
// outgoing long-wave flux is ~239 W m-2 (Trenberth, Fasullo & Kiehl 2009, Fig. 1); one
// 6-hour January mean lies within ~15 W m-2 of the annual mean.
TEST(EmbeddedSample, CarriesTheSurfaceAndTopOfAtmosphereFields) {
  const WeatherGrid w =
      open_weather(std::filesystem::path(NEPHOS_SOURCE_DIR) / "data/gfs_20110110_12z_f120_2p5deg.grib2");
  for (const auto& si : all_surface_fields())
    EXPECT_TRUE(w.has(si.field)) << si.grib_short_name << "@" << si.grib_level_type;
  EXPECT_TRUE(w.has(Field::ozone));
  const LatLonGrid& g = w.grid();
  auto mean = [&](SurfaceField f) {
    double sum = 0, area = 0;
    for (int j = 0; j < g.nlat; ++j)
      for (int i = 0; i < g.nlon; ++i) {
        const double a = g.cell_area_fraction(j);
        sum += a * w.surface(f)[static_cast<std::size_t>(j) * g.nlon + i], area += a;
      }
    return sum / area;
  };
  EXPECT_NEAR(mean(SurfaceField::land_fraction), 0.29, 0.03);  // 2.5 deg cells blur coasts
  EXPECT_NEAR(mean(SurfaceField::toa_outgoing_longwave), 239, 15);
  const auto& al = w.surface(SurfaceField::surface_albedo);
  const auto& ts = w.surface(SurfaceField::skin_temperature);
  // Percent scaled to a fraction; 0 where the Sun stayed below the horizon for the 6 hours.
  EXPECT_GE(*std::min_element(al.begin(), al.end()), 0.0f);
  EXPECT_LT(*std::max_element(al.begin(), al.end()), 1.0f);
  EXPECT_GT(*std::max_element(al.begin(), al.end()), 0.5f);  // snow and ice
  EXPECT_GT(*std::min_element(ts.begin(), ts.end()), 180.0f);
  EXPECT_LT(*std::max_element(ts.begin(), ts.end()), 340.0f);
}

}  // namespace
}  // namespace nephos::weather
