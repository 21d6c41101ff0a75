#include "nephos/weather/weather_grid.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

namespace nephos::weather {
namespace {

// A field on `g` with the value f(lat, lon) at every node.
std::vector<float> field_of(const LatLonGrid& g, const std::function<double(double, double)>& f) {
  std::vector<float> v(g.size());
  for (int j = 0; j < g.nlat; ++j)
    for (int i = 0; i < g.nlon; ++i)
      v[static_cast<std::size_t>(j) * g.nlon + i] = static_cast<float>(f(g.lat(j), g.lon(i)));
  return v;
}

const LatLonGrid global{73, 144, -90, 2.5, 0, 2.5};  // the GFS 2.5-degree grid

TEST(SampleBicubic, PassesThroughTheNodes) {
  const auto v = field_of(global, [](double lat, double lon) { return std::sin(0.3 * lat) * std::cos(0.07 * lon); });
  for (int j = 0; j < global.nlat; j += 7)
    for (int i = 0; i < global.nlon; i += 11)
      // Exact up to the float rounding of the weighted sum (weights 0 and 1 at a node).
      EXPECT_NEAR(sample_bicubic(global, v, global.lat(j), global.lon(i)), v[static_cast<std::size_t>(j) * 144 + i],
                  1e-6);
}

TEST(SampleBicubic, ReproducesMonotoneQuadratics) {
  // Keys' kernel (a = -1/2) is exact for polynomials of degree <= 2 (Keys 1981, eq. 27); this
  // one is monotone in both coordinates over the points sampled, so the clamp to a cell's corner
  // range never acts. Bilinear interpolation misses its curvature by up to (h/2)^2 c per axis.
  auto f = [](double lat, double lon) {
    return 0.002 * (lat + 100) * (lat + 100) + 0.001 * lon * lon + 0.01 * lat * lon;
  };
  const auto v = field_of(global, f);
  double worst = 0, worst_bilinear = 0;
  for (double lat = 10.3; lat < 60; lat += 3.7)
    for (double lon = 20.1; lon < 300; lon += 13.3) {
      worst = std::max(worst, std::abs(sample_bicubic(global, v, lat, lon) - f(lat, lon)));
      worst_bilinear = std::max(worst_bilinear, std::abs(sample_bilinear(global, v, lat, lon) - f(lat, lon)));
    }
  // Values up to ~ 200; float storage and sums: relative 1e-6.
  EXPECT_LT(worst, 2e-4);
  EXPECT_GT(worst_bilinear, 1e-3) << "the test field has curvature that bilinear interpolation misses";
}

TEST(SampleBicubic, StaysWithinTheCellAndIsSmoothAcrossCellEdges) {
  // A step in longitude: bicubic would ring (overshoot to -0.07 and 1.07) next to it; the clamp
  // keeps every value within its cell's corners, so a fraction stays in [0, 1].
  const auto step = field_of(global, [](double, double lon) { return lon >= 100 ? 1.0 : 0.0; });
  for (double lon = 90; lon < 110; lon += 0.1) {
    const float s = sample_bicubic(global, step, 30.0, lon);
    EXPECT_GE(s, 0.0f);
    EXPECT_LE(s, 1.0f);
  }
  // A smooth field: the one-sided slopes at a cell edge agree (C1), to the finite differences'
  // truncation; bilinear interpolation's slopes jump there.
  // (Monotone in both coordinates around the point, so the clamp is not active there.)
  auto g = [](double lat, double lon) { return std::sin(lat * 0.02) + std::cos(lon * 0.04); };
  const auto v = field_of(global, g);
  const double e = 1e-3, lon_edge = 100.0;  // a node column
  auto slope_jump = [&](auto sample) {
    const double left = (sample(global, v, 31.2, lon_edge) - sample(global, v, 31.2, lon_edge - e)) / e;
    const double right = (sample(global, v, 31.2, lon_edge + e) - sample(global, v, 31.2, lon_edge)) / e;
    return std::abs(right - left);
  };
  const double jump_bicubic = slope_jump(sample_bicubic), jump_bilinear = slope_jump(sample_bilinear);
  // The derivative is ~0.04 per degree; float values (1e-7 relative) over e = 1e-3 give ~2e-4.
  EXPECT_LT(jump_bicubic, 1e-3);
  EXPECT_GT(jump_bilinear, 2e-3);
}

TEST(SampleBicubic, WrapsAroundTheDateLineAndRepeatsThePoles) {
  auto f = [](double lat, double lon) { return std::cos(lon * M_PI / 180) + 0.01 * lat; };
  const auto v = field_of(global, f);
  // The same place as 359.9 and -0.1 degrees, across the last column and the first.
  EXPECT_FLOAT_EQ(sample_bicubic(global, v, 12.0, 359.9), sample_bicubic(global, v, 12.0, -0.1));
  // Smooth across the seam (lon 357.5 .. 360): within the interpolation error of cos (~1e-5).
  EXPECT_NEAR(sample_bicubic(global, v, 12.0, 358.7), f(12.0, 358.7), 1e-4);
  // At the poles the outer row is its own neighbour: finite values there and beyond.
  EXPECT_NEAR(sample_bicubic(global, v, 90.0, 45.0), f(90.0, 45.0), 1e-5);
  EXPECT_TRUE(std::isfinite(sample_bicubic(global, v, -89.0, 200.0)));
}

TEST(SampleBilinear, GlobalRowsShortOfThePolesHoldUpToThem) {
  // A global 1-degree grid with rows at -89.5 .. 89.5 (cell centres): beyond its outer rows,
  // within one spacing of the poles, the outer row holds; a tropical band all the way round in
  // longitude (30 S .. 30 N) has nothing beyond its rows.
  const LatLonGrid centres{180, 360, -89.5, 1.0, 0.5, 1.0};
  auto f = [](double lat, double lon) { return 0.5 * lat + std::cos(lon * M_PI / 180); };
  const auto v = field_of(centres, f);
  EXPECT_FLOAT_EQ(sample_bilinear(centres, v, 90.0, 10.5), static_cast<float>(f(89.5, 10.5)));
  EXPECT_FLOAT_EQ(sample_bilinear(centres, v, -90.0, 10.5), static_cast<float>(f(-89.5, 10.5)));
  EXPECT_TRUE(std::isfinite(sample_bicubic(centres, v, 89.9, 200.0)));
  const LatLonGrid band{61, 360, -30, 1.0, 0, 1.0};
  ASSERT_TRUE(band.wraps());
  const auto b = field_of(band, f);
  EXPECT_TRUE(std::isnan(sample_bilinear(band, b, 31.0, 100.0)));
  EXPECT_TRUE(std::isnan(sample_bicubic(band, b, -31.0, 100.0)));
  EXPECT_NEAR(sample_bilinear(band, b, 30.0, 100.0), f(30.0, 100.0), 1e-5);
}

TEST(SampleBicubic, RegionalGridsAndMissingValues) {
  const LatLonGrid regional{11, 21, 30, 1.0, 10, 1.0};  // 30..40 N, 10..30 E
  auto f = [](double lat, double lon) { return 0.5 * lat + 0.25 * lon; };
  auto v = field_of(regional, f);
  EXPECT_TRUE(std::isnan(sample_bicubic(regional, v, 35, 31)));  // east of the grid
  // North and south of it too: a regional grid's outer rows are not repeated to the poles
  // (which would put a regional file's clouds all the way north).
  for (const double lat : {40.5, 29.5, 89.0, -10.0}) {
    EXPECT_TRUE(std::isnan(sample_bicubic(regional, v, lat, 20))) << lat;
    EXPECT_TRUE(std::isnan(sample_bilinear(regional, v, lat, 20))) << lat;
  }
  EXPECT_NEAR(sample_bilinear(regional, v, 40.0, 20), f(40.0, 20), 1e-5);  // on the outer rows
  EXPECT_NEAR(sample_bilinear(regional, v, 30.0, 20), f(30.0, 20), 1e-5);
  // Linear fields are exact inside (float rounding of values ~ 25: 1e-5).
  EXPECT_NEAR(sample_bicubic(regional, v, 35.5, 15.5), f(35.5, 15.5), 1e-5);
  // In the last cell the outer node stands in for the missing one beyond it, which bends a
  // linear field; the value stays within the cell's corners, f(35, 29) .. f(36, 30).
  const float edge = sample_bicubic(regional, v, 35.5, 29.5);
  EXPECT_GE(edge, f(35, 29));
  EXPECT_LE(edge, f(36, 30));
  // A NaN node among the 16 but not the 4 corners: the bilinear value.
  v[static_cast<std::size_t>(5) * 21 + 4] = std::nanf("");  // (35 N, 14 E)
  EXPECT_FLOAT_EQ(sample_bicubic(regional, v, 36.5, 15.5), sample_bilinear(regional, v, 36.5, 15.5));
}

}  // namespace
}  // namespace nephos::weather
