// Column cloud geometry and optical thickness (the particle-cloud paper's eq. 2) and the GFS path.
#include "nephos/particles/cloud_columns.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>

#include "nephos/core/error.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/weather/reader.hpp"

using namespace nephos;
using namespace nephos::particles;
using weather::Field;

TEST(OpticalThickness, StephensLiquidWaterPathRule) {
  // tau = 3 LWP / (2 rho_w r_e) (Stephens 1978): LWP = 300 g/m^2 (0.3 g/m^3 over 1 km) with
  // r_e = 10 um gives tau = 45. Tolerance: rounding only.
  EXPECT_NEAR(layer_optical_thickness(1.0, 0.3e-3, 1000, 1000, 10e-6), 45.0, 1e-9);
  // Eq. 2 directly: a monodisperse cloud of n droplets of radius r per m^3 over dh has
  // lambda = 2 pi r^2 n dh; its water content is (4/3) pi r^3 rho_w n.
  const double r = 8e-6, n = 2e8, dh = 500;
  const double lwc = 4.0 / 3.0 * M_PI * r * r * r * 1000 * n;  // [kg/m^3]
  EXPECT_NEAR(layer_optical_thickness(1.2, lwc / 1.2, dh, 1000, r), 2 * M_PI * r * r * n * dh, 1e-9);
  EXPECT_EQ(layer_optical_thickness(1.2, -1e-5, 100, 1000, 1e-5), 0.0);  // negative mixing ratios clipped
}

TEST(ColumnCloud, BaseTopAndSumOverLayers) {
  LayerColumn c;
  c.z_lower_m = {0, 1000, 2000, 3000};
  c.z_upper_m = {1000, 2000, 3000, 4000};
  c.air_density = {1.2, 1.1, 1.0, 0.9};
  c.q_liquid = {0, 2e-4, 0, 0};
  c.q_ice = {0, 0, 0, 1e-4};
  ColumnParams p;
  const ColumnCloud cc = column_cloud(c, p);
  EXPECT_EQ(cc.base_m, 1000.0f);
  EXPECT_EQ(cc.top_m, 4000.0f);
  const double expected = 3 * 1.1 * 2e-4 * 1000 / (2 * 1000 * 10e-6) + 3 * 0.9 * 1e-4 * 1000 / (2 * 917 * 25e-6);
  EXPECT_NEAR(cc.tau, expected, 1e-5 * expected);  // float result
  c.q_liquid = {0, 0, 0, 0};
  c.q_ice = {0, 0, 0, 0.5e-6};  // below the 1e-6 kg/kg threshold: clear
  const ColumnCloud clear = column_cloud(c, p);
  EXPECT_TRUE(std::isnan(clear.top_m));
  EXPECT_EQ(clear.tau, 0.0f);
}

namespace {
// A 2.5-degree global grid with three levels, cloud water in one cell.
weather::WeatherGrid small_world() {
  weather::LatLonGrid g{73, 144, -90, 2.5, 0, 2.5};
  weather::WeatherGrid w(g, {85000, 70000, 50000});
  const double heights[3] = {1500, 3000, 5500}, temps[3] = {280, 268, 250};
  for (int k = 0; k < 3; ++k)
    for (std::size_t q = 0; q < g.size(); ++q) {
      w.level_data(Field::geopotential_height, k)[q] = static_cast<float>(heights[k]);
      w.level_data(Field::temperature, k)[q] = static_cast<float>(temps[k]);
      w.level_data(Field::cloud_water, k)[q] = 0;
      w.level_data(Field::u_wind, k)[q] = 10;
      w.level_data(Field::v_wind, k)[q] = -3;
      w.level_data(Field::omega, k)[q] = -0.5f;  // rising air
    }
  // Row 52 = 40 N, column 4 = 10 E: liquid water at 850 hPa (280 K: no ice).
  w.level_data(Field::cloud_water, 0)[w.index(0, 52, 4)] = 3e-4f;
  w.metadata().valid_time = UtcTime::from_civil(2011, 1, 10, 12);
  w.metadata().source = "small_world";
  return w;
}
}  // namespace

TEST(FromWeatherGrids, RegionProjectionAndOpticalThickness) {
  const auto pw = from_weather_grids({small_world()}, LatLonRegion{30, -10, 50, 20});
  EXPECT_EQ(pw.grid.rows, 9);   // 30, 32.5, ..., 50
  EXPECT_EQ(pw.grid.cols, 13);  // -10 .. 20 across the 0-degree meridian
  EXPECT_NEAR(pw.grid.centre_lat_deg, 40, 1e-9);
  EXPECT_NEAR(pw.grid.centre_lon_deg, 5, 1e-9);
  // Local equirectangular projection: dx = R cos(40 deg) 2.5 deg, dy = R 2.5 deg.
  EXPECT_NEAR(pw.grid.dx_m, earth::radius_m * std::cos(40 * earth::deg) * 2.5 * earth::deg, 1e-6);
  EXPECT_NEAR(pw.grid.dy_m, earth::radius_m * 2.5 * earth::deg, 1e-6);
  // 10 E is column 8 of the region (-10 + 8 * 2.5), 40 N is row 4.
  const std::size_t c = 4 * 13 + 8;
  const auto& col = pw.frames[0].columns;
  const double rho = 85000 / (287.04 * 280), dz = 0.5 * (1500 + 3000) - (1500 - 0.5 * 1500);
  const double tau = 3 * rho * 3e-4 * dz / (2 * 1000 * 10e-6);
  EXPECT_NEAR(col.tau[c], tau, 1e-5 * tau);  // float storage
  EXPECT_NEAR(col.base_m[c], 750, 1e-3);     // interfaces half-way between level heights
  EXPECT_NEAR(col.top_m[c], 2250, 1e-3);
  EXPECT_EQ(col.tau[c + 1], 0.0f);
  // omega -> w by hydrostatic balance: -(-0.5 Pa/s) / (rho g).
  const glm::dvec3 wind = pw.frames[0].wind.sample(pw.grid, pw.grid.x(8), pw.grid.y(4), 1500);
  EXPECT_NEAR(wind.z, 0.5 / (rho * 9.80665), 1e-6);
  EXPECT_NEAR(wind.x, 10, 1e-6);
  EXPECT_NEAR(wind.y, -3, 1e-6);
}

TEST(FromWeatherGrids, ErrorsNameTheProblem) {
  auto w = small_world();
  EXPECT_THROW(from_weather_grids({w}, LatLonRegion{40, 10, 41, 11}), ValueError);  // one cell
  weather::WeatherGrid no_clwmr(w.grid(), w.pressure_levels_pa());
  no_clwmr.metadata().source = "x.grib2";
  for (int k = 0; k < 3; ++k)
    for (Field f : {Field::geopotential_height, Field::temperature, Field::u_wind, Field::v_wind})
      std::copy_n(w.level_data(f, k), w.grid().size(), no_clwmr.level_data(f, k));
  try {
    from_weather_grids({no_clwmr}, LatLonRegion{30, -10, 50, 20});
    ADD_FAILURE();
  } catch (const FormatError& e) {
    EXPECT_EQ(e.context().field, "clwmr");
  }
  EXPECT_THROW(LatLonRegion::parse("50,0,40,10", "--region"), ValueError);  // south > north
  EXPECT_THROW(LatLonRegion::parse("50,0,40", "--region"), ValueError);
}

TEST(FromWeatherGrids, RealGfsColumnsAgreeWithGfsCloudCover) {
  const auto w =
      weather::open_weather(std::filesystem::path(NEPHOS_SOURCE_DIR) / "data" / "gfs_20110110_12z_f120_2p5deg.grib2");
  const auto pw = from_weather_grids({w}, LatLonRegion{-80, 0, 80, 357.5});
  const auto& c = pw.frames[0].columns;
  ASSERT_TRUE(w.has_cloud_cover(weather::CloudLayer::total));
  const auto& tcc = w.cloud_cover(weather::CloudLayer::total);
  // A consistency check with GFS, not a validation of realism: columns thick enough to see
  // (tau > 5) should be mostly cloudy in GFS's own total cloud cover. Both come from GFS's
  // condensate (tcc from its cloud scheme, tau from clwmr by our eq. 2), so this catches
  // columns that do not follow GFS's clouds (a wrong level order, unit or grid row).
  std::size_t thick = 0, thick_and_cloudy = 0;
  for (int r = 0; r < pw.grid.rows; ++r)
    for (int i = 0; i < pw.grid.cols; ++i) {
      const std::size_t q = static_cast<std::size_t>(r) * pw.grid.cols + i;
      ASSERT_FALSE(std::isnan(c.tau[q]));
      if (c.tau[q] > 5) {
        ++thick;
        const int j = r + 4;  // rows start at -80 = row 4 of the global grid
        thick_and_cloudy += tcc[static_cast<std::size_t>(j) * 144 + i] > 0.5f;
        EXPECT_GT(c.top_m[q], c.base_m[q]);
        EXPECT_LT(c.top_m[q], 20000);
      }
    }
  ASSERT_GT(thick, 200u);
  std::cout << "[ measured ] " << thick_and_cloudy << " of " << thick << " columns with tau > 5 have GFS tcc > 0.5\n";
  EXPECT_GT(static_cast<double>(thick_and_cloudy) / static_cast<double>(thick), 0.85);
}

TEST(Refine, SubdividesCellsAndKeepsTheWindField) {
  const auto pw = from_weather_grids({small_world()}, LatLonRegion{30, -10, 50, 20});
  const auto r = refine(pw, 4);
  EXPECT_EQ(r.grid.cols, 52);
  EXPECT_EQ(r.grid.rows, 36);
  EXPECT_NEAR(r.grid.dx_m, pw.grid.dx_m / 4, 1e-9);
  // The new cells tile the old ones: the outer edges coincide.
  EXPECT_NEAR(r.grid.x0_m - 0.5 * r.grid.dx_m, pw.grid.x0_m - 0.5 * pw.grid.dx_m, 1e-6);
  // The cloudy cell's optical thickness fades bilinearly: at the old centre's nearest new cells
  // (1/8 of an old cell away in x and y) it keeps (7/8)^2 of its value.
  const float tau_old = pw.frames[0].columns.tau[4 * 13 + 8];
  const std::size_t near = static_cast<std::size_t>(4 * 4 + 2) * 52 + (8 * 4 + 2);
  EXPECT_NEAR(r.frames[0].columns.tau[near], tau_old * 49.0f / 64.0f, 1e-4 * tau_old);
  EXPECT_NEAR(r.frames[0].columns.top_m[near], pw.frames[0].columns.top_m[4 * 13 + 8], 1e-3);
  // Inside the grid the refined wind equals the original bilinear wind.
  for (double fx : {0.3, 0.55, 0.8})
    for (double z : {1000.0, 2500.0, 4000.0}) {
      const double x = pw.grid.x0_m + fx * (pw.grid.cols - 1) * pw.grid.dx_m, y = pw.grid.y0_m + fx * pw.grid.dy_m;
      const glm::dvec3 a = pw.frames[0].wind.sample(pw.grid, x, y, z), b = r.frames[0].wind.sample(r.grid, x, y, z);
      EXPECT_NEAR(glm::length(a - b), 0.0, 1e-4);  // float storage
    }
  EXPECT_EQ(refine_factor_for(pw.grid, 30000), 10);  // 278 km / 30 km -> 10
  EXPECT_THROW(refine(pw, 0), ValueError);
}
