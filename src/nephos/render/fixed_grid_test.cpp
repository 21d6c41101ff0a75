#include "nephos/render/fixed_grid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "nephos/core/error.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/optics/optics.hpp"
#include "nephos/render/abi_l1b.hpp"
#include "nephos/render/sensor.hpp"

namespace nephos::render {
namespace {

// GOES-R PUG Vol. 3 (L1b), section 5.1.2.8.1's worked example: with the projection origin at
// -75 deg, scan angles x = -0.024052 rad, y = 0.095340 rad see latitude 33.846162 deg, longitude
// -84.690932 deg; section 5.1.2.8.2 the reverse. Tolerances: the example's printed digits (1e-6
// deg, 1e-6 rad). Faults caught: the polar radius for the equatorial one, a sign of x (the
// longitude on the other side), geocentric latitude for geodetic (0.19 deg off).
TEST(FixedGrid, ThePugsWorkedExample) {
  FixedGridProjection p;
  p.lon0_deg = -75.0;
  double lat = 0, lon = 0;
  ASSERT_TRUE(p.to_geodetic(-0.024052, 0.095340, lat, lon));
  EXPECT_NEAR(lat, 33.846162, 1e-6);
  EXPECT_NEAR(lon, -84.690932, 1e-6);
  double x = 0, y = 0;
  ASSERT_TRUE(p.to_scan(33.846162, -84.690932, x, y));
  EXPECT_NEAR(x, -0.024052, 1e-6);
  EXPECT_NEAR(y, 0.095340, 1e-6);
}

// Off the disc: beyond the Earth's angular radius (8.7 deg = 0.152 rad) the line of sight misses,
// and the far side of the Earth is not visible.
TEST(FixedGrid, SpaceAndTheFarSideAreNotOnTheGrid) {
  FixedGridProjection p;
  double lat = 0, lon = 0, x = 0, y = 0;
  EXPECT_FALSE(p.to_geodetic(0.16, 0.0, lat, lon));
  EXPECT_FALSE(p.to_scan(0.0, p.lon0_deg + 180, x, y));
  ASSERT_TRUE(p.to_geodetic(0.0, 0.0, lat, lon));  // the sub-satellite point
  EXPECT_NEAR(lat, 0, 1e-12);
  EXPECT_NEAR(lon, p.lon0_deg, 1e-12);
}

// The sectors' sizes are ABI's (PUG Vol. 3, Table 5.1.2.8-1): full disc 5424 / 10848 / 21696
// pixels at 2 / 1 / 0.5 km, CONUS and PACUS 2500 x 1500 at 2 km, a mesoscale sector 500 x 500
// at 2 km; the first full-disc pixel centre is the x variable's add_offset, -0.151844 rad.
TEST(FixedGrid, SectorSizesAreAbis) {
  FixedGridProjection east, west;
  west.lon0_deg = -137;
  for (auto [res, n] : {std::pair{2.0, 5424}, {1.0, 10848}, {0.5, 21696}}) {
    const FixedGridSector f = fixed_grid_sector(east, "full", res, 1);
    EXPECT_EQ(f.nx, n) << res;
    EXPECT_EQ(f.ny, n) << res;
  }
  const FixedGridSector f = fixed_grid_sector(east, "full", 2, 1);
  EXPECT_NEAR(f.x0_rad, -0.151844, 1e-9);
  EXPECT_NEAR(f.y0_rad, 0.151844, 1e-9);
  for (const auto* p : {&east, &west}) {
    const FixedGridSector c = fixed_grid_sector(*p, "conus", 2, 1);
    EXPECT_EQ(c.nx, 2500);
    EXPECT_EQ(c.ny, 1500);
  }
  EXPECT_NEAR(fixed_grid_sector(east, "conus", 2, 1).x0_rad, -0.101332, 1e-6);
  const FixedGridSector m = fixed_grid_sector(east, "meso:35,-90", 2, 1);
  EXPECT_EQ(m.nx, 500);
  EXPECT_EQ(m.ny, 500);
  const FixedGridSector coarse = fixed_grid_sector(east, "full", 2, 8);
  EXPECT_EQ(coarse.nx, 678);
  EXPECT_NEAR(coarse.dx_rad, 8 * 56e-6, 1e-15);
  EXPECT_THROW(fixed_grid_sector(east, "meso:35,100", 2, 1), ValueError);  // not on the disc
  EXPECT_THROW(fixed_grid_sector(east, "hemisphere", 2, 1), ValueError);
  EXPECT_THROW(fixed_grid_sector(east, "full", 2, 0), ValueError);
}

// abi:LON takes a longitude as geo: and leo: do, and the calibration of the GOES position
// nearer round the globe: 160 E lies 63 deg from GOES-West's 137 W and 125 deg from
// GOES-East's 75 W.
TEST(FixedGrid, AbiLongitudesAndTheirPlatform) {
  EXPECT_EQ(abi_view("abi:-100", "full", 2, 64).platform, "G16");
  EXPECT_EQ(abi_view("abi:-110", "full", 2, 64).platform, "G18");
  EXPECT_EQ(abi_view("abi:160", "full", 2, 64).platform, "G18");
  EXPECT_EQ(abi_view("abi:10", "full", 2, 64).platform, "G16");
  EXPECT_EQ(abi_view("abi:200", "full", 2, 64).platform, "G18");  // GRIB's 0..360: 160 W
  EXPECT_DOUBLE_EQ(abi_view("abi:284.8", "full", 2, 64).projection.lon0_deg, -75.2);
  for (const char* bad : {"abi:400", "abi:-181", "abi:1e6", "abi:nan"}) {
    try {
      abi_view(bad, "full", 2, 64);
      ADD_FAILURE() << bad;
    } catch (const ValueError& e) {
      EXPECT_EQ(e.context().key, "sensor") << bad;
    }
  }
}

// The sensor's rays, found a row at a time from the scan angles' sines and cosines, reach the
// renderer's sphere at each pixel's fixed-grid latitude and longitude as PUG's angles give them
// (within 1 mm: double rounding over 36 000 km), for GOES-East and GOES-West.
TEST(FixedGrid, RaysMeetTheSphereWhereTheGridSays) {
  for (const char* spec : {"abi:east", "abi:west"}) {
    const FixedGridView v = abi_view(spec, "full", 2, 16);
    const Sensor s = Sensor::abi(v);
    EXPECT_EQ(s.width, 339);
    int on_earth = 0;
    std::vector<earth::Vec3> row(static_cast<std::size_t>(s.width));
    for (int j = 0; j < s.height; j += 13) {
      s.row_rays(j, row.data());
      for (int i = 0; i < s.width; i += 13) {
        double lat = 0, lon = 0;
        if (!v.projection.to_geodetic(v.sector.x(i), v.sector.y(j), lat, lon)) continue;
        const earth::Vec3 d = row[static_cast<std::size_t>(i)];
        EXPECT_EQ(d, s.ray(i + 0.5, j + 0.5));  // one pixel's ray is its row's
        const auto hit = earth::ray_sphere(s.position, d, earth::radius_m);
        ASSERT_TRUE(hit);
        const earth::Vec3 p = s.position + hit->t0 * d;
        EXPECT_LT(glm::length(p - earth::radius_m * earth::unit_from_latlon(lat, lon)), 1e-3);
        ++on_earth;
      }
    }
    EXPECT_GT(on_earth, 400);
  }
}

// A sector's cover against to_geodetic() at every pixel: the same Earth pixels and, bit for bit,
// the same extent, for the full discs of GOES-East and GOES-West (across the date line),
// CONUS (its north-west corner beyond the limb), PACUS and mesoscale sectors inside the disc,
// over the northern limb, the western one, and the limb at the date line. Faults caught: the extremes taken from the
// rows' ends alone (latitudes) or from the columns' alone (longitudes), a run's last pixel one short.
TEST(FixedGrid, ASectorsCoverIsEveryPixelsOwn) {
  struct Case {
    std::string spec, scene;
    bool reaches_space;
  };
  const std::vector<Case> cases{{"abi:east", "full", true},          {"abi:west", "full", true},
                                {"abi:east", "conus", true},         {"abi:west", "conus", false},
                                {"abi:east", "meso:35,-100", false}, {"abi:east", "meso:72,-75", true},
                                {"abi:west", "meso:0,-64", true},    {"abi:west", "meso:60,178", true}};
  for (const auto& [spec, scene, reaches_space] : cases) {
    const FixedGridView v = abi_view(spec, scene, 2, scene == "full" ? 8 : 2);
    const FixedGridProjection& p = v.projection;
    const SectorCover c = sector_cover(p, v.sector);
    double south = 90, north = -90, west = 180, east = -180;
    std::size_t k = 0, on = 0;
    for (int j = 0; j < v.sector.ny; ++j)
      for (int i = 0; i < v.sector.nx; ++i, ++k) {
        double lat = 0, lon = 0;
        const bool seen = p.to_geodetic(v.sector.x(i), v.sector.y(j), lat, lon);
        ASSERT_EQ(c.on_earth[k] != 0, seen) << spec << " " << scene << " " << i << " " << j;
        if (!seen) continue;
        ++on;
        const double rel = earth::wrap_lon_180(lon - p.lon0_deg);
        south = std::min(south, lat), north = std::max(north, lat);
        west = std::min(west, rel), east = std::max(east, rel);
      }
    ASSERT_GT(on, 0u) << spec << " " << scene;
    EXPECT_EQ(on < k, reaches_space) << spec << " " << scene;
    EXPECT_EQ(c.south, south) << spec << " " << scene;
    EXPECT_EQ(c.north, north) << spec << " " << scene;
    EXPECT_EQ(c.west, earth::wrap_lon_180(west + p.lon0_deg)) << spec << " " << scene;
    EXPECT_EQ(c.east, earth::wrap_lon_180(east + p.lon0_deg)) << spec << " " << scene;
  }
}

// Where a ray meets the surface of geodetic height h on the GRS80 ellipsoid (its semi-axes
// grown by h: within metres of that surface for h <= 15 km), and that point's geodetic latitude
// and longitude [rad] (Bowring's iteration, converged to 1e-12 rad).
std::optional<std::pair<double, double>> ellipsoid_geodetic(const earth::Vec3& o, const earth::Vec3& d, double h) {
  const double a = FixedGridProjection::semi_major_m + h, b = FixedGridProjection::semi_minor_m + h;
  const earth::Vec3 q{1 / (a * a), 1 / (a * a), 1 / (b * b)};
  const double qa = glm::dot(q * d, d), qb = 2 * glm::dot(q * d, o), qc = glm::dot(q * o, o) - 1;
  const double disc = qb * qb - 4 * qa * qc;
  if (disc < 0) return std::nullopt;
  const earth::Vec3 p = o + d * ((-qb - std::sqrt(disc)) / (2 * qa));
  const double a0 = FixedGridProjection::semi_major_m, b0 = FixedGridProjection::semi_minor_m;
  const double e2 = 1 - b0 * b0 / (a0 * a0), rho = std::hypot(p.x, p.y);
  double lat = std::atan2(p.z, rho * (1 - e2));
  for (int k = 0; k < 20; ++k) {
    const double n = a0 / std::sqrt(1 - e2 * std::sin(lat) * std::sin(lat));
    const double height = rho / std::cos(lat) - n;
    lat = std::atan2(p.z, rho * (1 - e2 * n / (n + height)));
  }
  return std::make_pair(lat, std::atan2(p.y, p.x));
}

// Clouds sit where the ellipsoid puts them. A cloud at geodetic height h seen in a pixel lies,
// on ABI's line of sight, where that line meets the ellipsoid's surface of height h. The
// renderer meets it on its sphere at radius R + h, along its ray. Compare the latitude and
// longitude each assigns to it, over the full disc within 70 deg of nadir, h = 2, 10, 15 km.
// They agree within 0.13 km, against a 2 km pixel; the bound is 0.25 km. Fault seen to fail:
// rays along the scan angles' own line of sight (the sphere taken for the Earth): 42 km.
TEST(FixedGrid, CloudsSitWhereTheEllipsoidPutsThem) {
  const FixedGridView v = abi_view("abi:east", "full", 2, 32);
  const Sensor s = Sensor::abi(v);
  double worst_m = 0;
  int seen = 0;
  for (int j = 0; j < s.height; j += 3)
    for (int i = 0; i < s.width; i += 3) {
      const earth::Vec3 los = v.projection.line_of_sight(v.sector.x(i), v.sector.y(j));
      const auto ground = ellipsoid_geodetic(s.position, los, 0);
      if (!ground) continue;
      const earth::Vec3 up = earth::unit_from_latlon(ground->first / earth::deg, ground->second / earth::deg);
      if (glm::dot(-los, up) < std::cos(70 * earth::deg)) continue;
      const earth::Vec3 d = s.ray(i + 0.5, j + 0.5);
      for (double h : {2e3, 10e3, 15e3}) {
        const auto truth = ellipsoid_geodetic(s.position, los, h);
        const auto hit = earth::ray_sphere(s.position, d, earth::radius_m + h);
        ASSERT_TRUE(truth && hit);
        const earth::Vec3 n = glm::normalize(s.position + hit->t0 * d);
        const double lat = std::asin(n.z), lon = std::atan2(n.y, n.x);
        const double c = std::sin(lat) * std::sin(truth->first) +
                         std::cos(lat) * std::cos(truth->first) * std::cos(lon - truth->second);
        worst_m = std::max(worst_m, earth::radius_m * std::acos(std::clamp(c, -1.0, 1.0)));
      }
      ++seen;
    }
  EXPECT_GT(seen, 1000);
  EXPECT_LT(worst_m, 250.0);
}

// The published GOES-16 Planck coefficients (NOAA's L1b files) against physics and nephos's
// bands, for every thermal band: fk1 = c1 nu^3 at the wavenumber nu = fk2 / c2 that fk2 implies
// (c1, c2 from CODATA; within 0.05 %: the values' printed digits; a mistyped digit is off by
// more), that wavenumber inside nephos's band edges (the bands are ABI's), and the calibration
// inverting itself. GOES-18 has band 13's published.
TEST(AbiL1b, PublishedPlanckCoefficientsAreAbisBands) {
  constexpr double c1 = 1.191042e-5, c2 = 1.4387752;
  int published = 0;
  for (const optics::Band& b : optics::bands()) {
    if (!b.thermal) continue;
    ASSERT_EQ(planck_source("G16", b), PlanckSource::published) << b.name;
    const PlanckCoefficients p = abi_planck_coefficients("G16", b);
    const double nu = p.fk2 / c2;
    EXPECT_NEAR(p.fk1 / (c1 * nu * nu * nu), 1.0, 5e-4) << b.name;
    EXPECT_GT(1e4 / nu, b.lo_um) << b.name;
    EXPECT_LT(1e4 / nu, b.hi_um) << b.name;
    EXPECT_GT(p.bc2, 0.99) << b.name;
    for (double t : {200.0, 250.0, 300.0}) EXPECT_NEAR(p.brightness_temperature(p.radiance(t)), t, 1e-9) << b.name;
    ++published;
  }
  EXPECT_EQ(published, 10);
  EXPECT_EQ(planck_source("G18", optics::band("lwir")), PlanckSource::published);
  EXPECT_NEAR(abi_planck_coefficients("G18", optics::band("lwir")).fk2, 1393.39, 1e-9);
}

// CRTM's central wavenumbers of ABI's bands (NOAA/EMC's listing) against NOAA's L1b files, two
// publications of the same measured responses: c1 nu^3 and c2 nu give every published fk1 and
// fk2, GOES-16's ten and GOES-18's band 13 (measured within 4.5e-6 and 0.0048 K: the printed
// digits, and the frequencies' 0.01 GHz). So GOES-18's other bands take fk1 and fk2 from them,
// with GOES-16's bc1 and bc2 (GOES-18 band 13's differ by 0.0018 K and 1e-5). Fault run:
// GOES-18's band-15 frequency in GOES-16's place puts its fk2 1.5 K off, and the test fails.
TEST(AbiL1b, CentralWavenumbersGiveThePublishedFk) {
  constexpr double c1 = 1.191042e-5, c2 = 1.4387752;
  std::vector<std::pair<std::string, int>> published{{"G18", 13}};
  for (int b = 7; b <= 16; ++b) published.emplace_back("G16", b);
  int checked = 0;
  for (const auto& [platform, b] : published) {
    const optics::Band* band = nullptr;
    for (const optics::Band& x : optics::bands())
      if (x.abi_band == b) band = &x;
    ASSERT_TRUE(band);
    ASSERT_EQ(planck_source(platform, *band), PlanckSource::published);
    const PlanckCoefficients p = abi_planck_coefficients(platform, *band);
    const double nu = abi_central_wavenumber_cm1(platform, b);
    EXPECT_NEAR(c1 * nu * nu * nu / p.fk1, 1.0, 1e-5) << platform << " band " << b;
    EXPECT_NEAR(c2 * nu, p.fk2, 0.01) << platform << " band " << b;
    ++checked;
  }
  EXPECT_EQ(checked, 11);
  for (const optics::Band& b : optics::bands()) {
    if (!b.thermal || b.abi_band == 13) continue;
    ASSERT_EQ(planck_source("G18", b), PlanckSource::central_wavenumber) << b.name;
    const PlanckCoefficients p = abi_planck_coefficients("G18", b), g16 = abi_planck_coefficients("G16", b);
    const double nu = abi_central_wavenumber_cm1("G18", b.abi_band);
    EXPECT_DOUBLE_EQ(p.fk2, c2 * nu) << b.name;
    EXPECT_EQ(p.bc1, g16.bc1) << b.name;
    EXPECT_EQ(p.bc2, g16.bc2) << b.name;
    EXPECT_GT(1e4 / nu, b.lo_um) << b.name;
    EXPECT_LT(1e4 / nu, b.hi_um) << b.name;
    for (double t : {200.0, 250.0, 300.0}) EXPECT_NEAR(p.brightness_temperature(p.radiance(t)), t, 1e-9) << b.name;
  }
}

}  // namespace
}  // namespace nephos::render
