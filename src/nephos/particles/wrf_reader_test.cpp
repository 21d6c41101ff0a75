// WRF reader against hand-built wrfout files (test_wrfout.hpp says what each holds).
#include "nephos/particles/wrf_reader.hpp"

#include <gtest/gtest.h>
#include <netcdf.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"
#include "test_wrfout.hpp"

namespace fs = std::filesystem;
using namespace nephos;
using namespace nephos::particles;
using nephos::particles::test_data::WrfoutSpec;

namespace {

fs::path temp_file(const std::string& name) { return nephos::test_support::temp_path(name + ".nc"); }

// Writes a wrfout with the flaw of `s` as `name` and returns the FormatError reading it gives
// (a test failure, and an empty error, when it reads without one).
FormatError refusal(const WrfoutSpec& s, const std::string& name) {
  const fs::path f = temp_file(name);
  test_data::write_test_wrfout(f, s);
  try {
    read_wrf(f);
  } catch (const FormatError& e) {
    return e;
  }
  ADD_FAILURE() << name << " was read without an error";
  return FormatError("no error");
}

// Independent of the reader: air density from WRF's definitions (theta = 300 K, p = P + PB).
double air_density(double z_mass_m) {
  const double p = test_data::pressure_pa(z_mass_m);
  const double t = 300.0 * std::pow(p / 1e5, 287.0 / 1004.5);
  return p / (287.04 * t);
}

}  // namespace

TEST(WrfReader, ReadsGridTimesAndColumns) {
  const fs::path f = temp_file("wrf_ok");
  test_data::write_test_wrfout(f);
  const ParticleWeather w = read_wrf(f);
  ASSERT_EQ(w.grid.cols, 6);
  ASSERT_EQ(w.grid.rows, 5);
  EXPECT_EQ(w.grid.dx_m, 3000);
  ASSERT_EQ(w.frames.size(), 2u);
  EXPECT_EQ(w.frames[0].valid_time.iso(), "2011-01-10T12:00:00Z");
  EXPECT_EQ(w.frames[1].time_s, 3600);
  // Liquid in layer 1 (1000-2000 m) of column (2, 3): eq. 2 with r_e = 10 um.
  const auto& c0 = w.frames[0].columns;
  const std::size_t liquid = 3 * 6 + 2, ice = 1 * 6 + 4;
  const double tau_liquid = 3 * air_density(1500) * 1e-3 * 1000 / (2 * 1000 * 10e-6);
  // Tolerance: the reader works in float from float file values (~1e-6 relative).
  EXPECT_NEAR(c0.tau[liquid], tau_liquid, 1e-5 * tau_liquid);
  EXPECT_NEAR(c0.base_m[liquid], 1000, 1e-3);  // 1e-3 m: float rounding of (PH + PHB) / g
  EXPECT_NEAR(c0.top_m[liquid], 2000, 1e-3);
  // Ice in layer 2 (2000-3000 m) of column (4, 1): r_e = 25 um, rho_ice = 917 kg/m^3.
  const double tau_ice = 3 * air_density(2500) * 2e-4 * 1000 / (2 * 917 * 25e-6);
  EXPECT_NEAR(c0.tau[ice], tau_ice, 1e-5 * tau_ice);
  EXPECT_NEAR(c0.top_m[ice], 3000, 1e-3);
  // Clear columns.
  EXPECT_EQ(c0.tau[0], 0.0f);
  EXPECT_TRUE(std::isnan(c0.top_m[0]));
  // Second time: twice the liquid water.
  EXPECT_NEAR(w.frames[1].columns.tau[liquid], 2 * tau_liquid, 2e-5 * tau_liquid);
}

TEST(WrfReader, DestaggersWindsToMassPoints) {
  const fs::path f = temp_file("wrf_wind");
  test_data::write_test_wrfout(f);
  const ParticleWeather w = read_wrf(f);
  // Column (1, 1) at the mass level of layer 1 (z = 1500 m).
  const glm::dvec3 x = w.frames[0].wind.sample(w.grid, w.grid.x(1), w.grid.y(1), 1500);
  EXPECT_NEAR(x.x, 10 + 1.5, 1e-5);        // mean of U at i_stag 1 and 2
  EXPECT_NEAR(x.y, -5 + 0.5 * 1.5, 1e-5);  // mean of V at j_stag 1 and 2
  EXPECT_NEAR(x.z, 0.1 * 1.5, 1e-6);       // mean of W at k_stag 1 and 2
  EXPECT_NEAR(w.frames[1].wind.sample(w.grid, w.grid.x(1), w.grid.y(1), 1500).x, 13.5, 1e-5);
  // Linear in height between mass levels (W is linear in k, so at 2000 m: 0.2 m/s).
  EXPECT_NEAR(w.frames[0].wind.sample(w.grid, w.grid.x(1), w.grid.y(1), 2000).z, 0.2, 1e-6);
}

TEST(WrfReader, RegionKeepsTheCellsInside) {
  const fs::path f = temp_file("wrf_region");
  test_data::write_test_wrfout(f);
  // XLAT = 40 + 0.03 j, XLONG = -100 + 0.04 i: this box holds i = 1..3, j = 2..4.
  const ParticleWeather w = read_wrf(f, LatLonRegion{40.05, -99.97, 40.13, -99.87});
  EXPECT_EQ(w.grid.cols, 3);
  EXPECT_EQ(w.grid.rows, 3);
  // Column (2, 3) of the file is (1, 1) of the region.
  EXPECT_GT(w.frames[0].columns.tau[1 * 3 + 1], 0.0f);
  EXPECT_THROW(read_wrf(f, LatLonRegion{10, 10, 11, 11}), ValueError);
}

TEST(WrfReader, MissingVariablesAreNamed) {
  for (const char* var : {"XLAT", "XLONG", "PH", "PHB", "P", "PB", "T", "QCLOUD", "U", "V", "W"}) {
    WrfoutSpec s;
    s.omit = var;
    const FormatError e = refusal(s, std::string("wrf_no_") + var);
    EXPECT_EQ(e.context().field, var);
    EXPECT_NE(std::string(e.what()).find("missing"), std::string::npos) << e.what();
  }
}

TEST(WrfReader, QiceIsOptional) {
  const fs::path f = temp_file("wrf_no_qice");
  WrfoutSpec s;
  s.omit = "QICE";
  test_data::write_test_wrfout(f, s);
  const ParticleWeather w = read_wrf(f);
  EXPECT_EQ(w.frames[0].columns.tau[1 * 6 + 4], 0.0f);  // the ice column is clear without QICE
  EXPECT_GT(w.frames[0].columns.tau[3 * 6 + 2], 0.0f);
}

TEST(WrfReader, WrongUnitsDimensionsAndAttributesAreRefused) {
  {
    WrfoutSpec s;
    s.bad_units = "QCLOUD";
    const FormatError e = refusal(s, "wrf_units");
    EXPECT_EQ(e.context().field, "QCLOUD");
    EXPECT_NE(std::string(e.what()).find("kg kg-1"), std::string::npos) << e.what();
  }
  {
    WrfoutSpec s;
    s.swap_dims = "U";
    const FormatError e = refusal(s, "wrf_dims");
    EXPECT_EQ(e.context().field, "U");
    EXPECT_NE(std::string(e.what()).find("west_east_stag"), std::string::npos) << e.what();
  }
  {
    WrfoutSpec s;
    s.omit_dx = true;
    EXPECT_EQ(refusal(s, "wrf_nodx").context().key, "DX");
  }
}

TEST(WrfReader, TimesMustBeThereAndInWrfFormat) {
  const auto expect_times_error = [](const WrfoutSpec& s, const char* name) {
    const FormatError e = refusal(s, name);
    EXPECT_EQ(e.context().field, "Times") << e.what();
  };
  WrfoutSpec no_times;
  no_times.omit_times = true;
  expect_times_error(no_times, "wrf_no_times");
  WrfoutSpec bad;
  bad.bad_time = true;
  expect_times_error(bad, "wrf_bad_time");
  WrfoutSpec empty;
  empty.nt = 0;  // the unlimited Time dimension has no records
  expect_times_error(empty, "wrf_empty");
}

TEST(WrfReader, UnreadableFilesAreIoErrors) {
  EXPECT_THROW(read_wrf("/nonexistent/wrfout_d01"), IoError);
  const fs::path f = nephos::test_support::temp_path("not_netcdf.nc");
  std::ofstream(f) << "this is not NetCDF\n";
  EXPECT_THROW(read_wrf(f), IoError);
}

// A damaged file is refused, not read: one NaN or fill value in a field the clouds are made of
// (a NaN height sent particles to NaN positions and crashed the motion), named with its field
// and index; a file cut short, whose missing end NetCDF's classic format reads as zeros.
TEST(WrfReader, DamagedFilesAreRefusedNotRead) {
  const fs::path f = temp_file("wrf_damaged");
  for (const float bad : {std::nanf(""), 9.969209968386869e36f, -INFINITY}) {
    test_data::write_test_wrfout(f);
    int nc = 0, v = 0;
    ASSERT_EQ(nc_open(f.c_str(), NC_WRITE, &nc), NC_NOERR);
    ASSERT_EQ(nc_inq_varid(nc, "PH", &v), NC_NOERR);
    const std::size_t at[4] = {1, 2, 3, 4};  // time 1, bottom_top_stag 2, south_north 3, west_east 4
    ASSERT_EQ(nc_put_var1_float(nc, v, at, &bad), NC_NOERR);
    ASSERT_EQ(nc_close(nc), NC_NOERR);
    try {
      read_wrf(f);
      ADD_FAILURE() << bad << " was read";
    } catch (const FormatError& e) {
      EXPECT_EQ(e.context().field, "PH") << e.what();
      EXPECT_NE(std::string(e.what()).find("time index 1, (2, 3, 4)"), std::string::npos) << e.what();
    }
  }
  test_data::write_test_wrfout(f);
  std::string bytes;
  {
    std::ifstream in(f, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::ofstream(f, std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() / 2);
  try {
    read_wrf(f);
    ADD_FAILURE() << "a file cut in half was read";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  fs::remove(f);
}
