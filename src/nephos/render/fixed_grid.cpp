#include "nephos/render/fixed_grid.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/earth/earth.hpp"

namespace nephos::render {

namespace {
constexpr double r_eq = FixedGridProjection::semi_major_m, r_pol = FixedGridProjection::semi_minor_m;
constexpr double eq_over_pol2 = (r_eq * r_eq) / (r_pol * r_pol);
constexpr double full_disc_edge_rad = 0.151872;  // the full disc's outer edge, +-x and +-y (PUG)

// Pixel spacing [rad] at ABI's 0.5, 1 and 2 km: 14, 28, 56 microradians (PUG Vol. 3, Table
// 5.1.2.8-1: the x/y variables' scale factors).
double spacing_rad(double resolution_km) {
  if (resolution_km == 0.5) return 14e-6;
  if (resolution_km == 1.0) return 28e-6;
  if (resolution_km == 2.0) return 56e-6;
  throw ValueError(fmt::format("ABI resolution {:g} km: 0.5, 1 or 2", resolution_km), {.key = "resolution"});
}

// A sector from its outer edges [rad] (west, north; east, south), at a spacing, coarsened.
FixedGridSector sector(const std::string& scene, char abbreviation, double res_km, int step, double x_west,
                       double y_north, double x_east, double y_south) {
  FixedGridSector s;
  s.scene = scene, s.abbreviation = abbreviation, s.resolution_km = res_km, s.step = step;
  s.dx_rad = spacing_rad(res_km) * step, s.dy_rad = -s.dx_rad;
  s.nx = static_cast<int>(std::floor((x_east - x_west) / s.dx_rad + 1e-6));
  s.ny = static_cast<int>(std::floor((y_north - y_south) / s.dx_rad + 1e-6));
  s.x0_rad = x_west + 0.5 * s.dx_rad, s.y0_rad = y_north - 0.5 * s.dx_rad;
  return s;
}
}  // namespace

earth::Vec3 FixedGridProjection::satellite_ecef() const {
  return satellite_distance_m() * earth::unit_from_latlon(0, lon0_deg);
}

namespace {
// PUG Vol. 3, section 5.1.2.8.1: where the line of sight at scan angles with sines and cosines
// (sx, cx), (sy, cy) meets the ellipsoid, in the satellite's frame (s_x towards the Earth's
// centre, s_y west, s_z north) [m]; false where it misses.
bool ellipsoid_hit(double H, double sx, double cx, double sy, double cy, double& s_x, double& s_y, double& s_z) {
  const double a = sx * sx + cx * cx * (cy * cy + eq_over_pol2 * sy * sy);
  const double b = -2 * H * cx * cy, c = H * H - r_eq * r_eq;
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return false;
  const double rs = (-b - std::sqrt(disc)) / (2 * a);
  s_x = rs * cx * cy, s_y = -rs * sx, s_z = rs * cx * sy;
  return true;
}
}  // namespace

bool FixedGridProjection::to_geodetic(double x, double y, double& lat_deg, double& lon_deg) const {
  const double H = satellite_distance_m();
  double s_x, s_y, s_z;
  if (!ellipsoid_hit(H, std::sin(x), std::cos(x), std::sin(y), std::cos(y), s_x, s_y, s_z)) return false;
  lat_deg = std::atan(eq_over_pol2 * s_z / std::hypot(H - s_x, s_y)) / earth::deg;
  lon_deg = lon0_deg - std::atan(s_y / (H - s_x)) / earth::deg;
  return true;
}

bool FixedGridProjection::geodetic_up_at_origin(double sin_x, double cos_x, double sin_y, double cos_y,
                                                earth::Vec3& up) const {
  // The ellipsoid's normal at the point (H - s_x, -s_y, s_z) of the origin's frame, its
  // coordinates over (a^2, a^2, b^2): the direction of to_geodetic's latitude and longitude.
  const double H = satellite_distance_m();
  double s_x, s_y, s_z;
  if (!ellipsoid_hit(H, sin_x, cos_x, sin_y, cos_y, s_x, s_y, s_z)) return false;
  up = glm::normalize(earth::Vec3{H - s_x, -s_y, eq_over_pol2 * s_z});
  return true;
}

bool FixedGridProjection::to_scan(double lat_deg, double lon_deg, double& x, double& y) const {
  // PUG Vol. 3, section 5.1.2.8.2: geocentric latitude, the radius there, the satellite's view.
  const double H = satellite_distance_m();
  const double phi_c = std::atan(std::tan(lat_deg * earth::deg) / eq_over_pol2);
  const double e2 = 1 - 1 / eq_over_pol2;
  const double rc = r_pol / std::sqrt(1 - e2 * std::cos(phi_c) * std::cos(phi_c));
  const double dl = (lon_deg - lon0_deg) * earth::deg;
  const double s_x = H - rc * std::cos(phi_c) * std::cos(dl), s_y = -rc * std::cos(phi_c) * std::sin(dl);
  const double s_z = rc * std::sin(phi_c);
  if (H * (H - s_x) < s_y * s_y + eq_over_pol2 * s_z * s_z) return false;  // beyond the limb
  y = std::atan(s_z / s_x);
  x = std::asin(-s_y / std::sqrt(s_x * s_x + s_y * s_y + s_z * s_z));
  return true;
}

earth::Vec3 FixedGridProjection::line_of_sight(double x, double y) const {
  // In the satellite's frame (X to the sub-satellite point's zenith, Y east, Z north) the view
  // is (-cos x cos y, sin x, cos x sin y); rotated about Z by the projection's longitude.
  const double dx = -std::cos(x) * std::cos(y), dy = std::sin(x), dz = std::cos(x) * std::sin(y);
  const double cl = std::cos(lon0_deg * earth::deg), sl = std::sin(lon0_deg * earth::deg);
  return {dx * cl - dy * sl, dx * sl + dy * cl, dz};
}

FixedGridSector fixed_grid_sector(const FixedGridProjection& p, const std::string& scene, double resolution_km,
                                  int step) {
  if (step < 1 || step > 10000) throw ValueError("must be 1..10000", {.key = "abi_step"});
  const double h = FixedGridProjection::perspective_height_m;
  // Outer edges [rad] of the sectors (the extents of satpy's area definitions, in metres on the
  // fixed grid over h, from the PUG's x/y offsets): full disc +-0.151872; GOES-East CONUS x
  // -0.101360..0.038640, y 0.044240..0.128240; GOES-West PACUS x +-0.070, y as CONUS.
  constexpr double e = full_disc_edge_rad;
  if (scene == "full") return sector(scene, 'F', resolution_km, step, -e, e, e, -e);
  if (scene == "conus") {
    const bool west = earth::wrap_lon_180(p.lon0_deg) < -105;
    const double y_south = 1583173.65752 / h, y_north = 4589199.58952 / h;
    if (west) return sector(scene, 'C', resolution_km, step, -2505021.61 / h, y_north, 2505021.61 / h, y_south);
    return sector(scene, 'C', resolution_km, step, -3627271.29128 / h, y_north, 1382771.92872 / h, y_south);
  }
  if (scene.rfind("meso:", 0) == 0) {
    const auto c = parse_numbers(scene.substr(5), 2, "scene", "meso:LAT,LON");
    double xc = 0, yc = 0;
    if (!(c[0] >= -90 && c[0] <= 90) || !p.to_scan(c[0], c[1], xc, yc))
      throw ValueError(fmt::format("mesoscale centre {:g}, {:g} is not on the visible disc", c[0], c[1]),
                       {.key = "scene"});
    // 1000 km at the sub-satellite point: 500 pixels of 2 km, on the full disc's pixel lattice.
    const double d = spacing_rad(resolution_km), half = 0.5 * (1000.0 / resolution_km) * d;
    const double x_west = -e + std::round((xc - half + e) / d) * d;
    const double y_north = e - std::round((e - (yc + half)) / d) * d;
    return sector("meso", 'M', resolution_km, step, x_west, y_north, x_west + 2 * half, y_north - 2 * half);
  }
  throw ValueError("scene '" + scene + "': full, conus or meso:LAT,LON", {.key = "scene"});
}

SectorCover sector_cover(const FixedGridProjection& p, const FixedGridSector& s) {
  const auto nx = static_cast<std::size_t>(s.nx), ny = static_cast<std::size_t>(s.ny);
  std::vector<double> sx(nx), cx(nx), sy(ny), cy(ny);  // the scan angles' sines and cosines
  for (std::size_t i = 0; i < nx; ++i)
    sx[i] = std::sin(s.x(static_cast<int>(i))), cx[i] = std::cos(s.x(static_cast<int>(i)));
  for (std::size_t j = 0; j < ny; ++j)
    sy[j] = std::sin(s.y(static_cast<int>(j))), cy[j] = std::cos(s.y(static_cast<int>(j)));
  SectorCover c;
  c.on_earth.resize(nx * ny);
  const double H = p.satellite_distance_m();
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t j = 0; j < static_cast<std::ptrdiff_t>(ny); ++j)
    for (std::size_t i = 0; i < nx; ++i) {
      double s_x, s_y, s_z;
      const auto row = static_cast<std::size_t>(j);
      c.on_earth[row * nx + i] = ellipsoid_hit(H, sx[i], cx[i], sy[row], cy[row], s_x, s_y, s_z);
    }
  // The runs' ends: the longitudes at each row's, the latitudes at each column's.
  double south = 90, north = -90, west = 180, east = -180;  // longitudes relative to lon0
  auto ends = [&](std::size_t n, auto on, auto take) {      // the first and last k < n with on(k)
    std::size_t k0 = 0, k1 = n;
    while (k0 < n && !on(k0)) ++k0;
    if (k0 == n) return;
    while (!on(k1 - 1)) --k1;
    take(k0), take(k1 - 1);
  };
  double lat = 0, lon = 0;
  for (std::size_t j = 0; j < ny; ++j)
    ends(
        nx, [&](std::size_t i) { return c.on_earth[j * nx + i] != 0; },
        [&](std::size_t i) {
          p.to_geodetic(s.x(static_cast<int>(i)), s.y(static_cast<int>(j)), lat, lon);
          const double rel = earth::wrap_lon_180(lon - p.lon0_deg);
          west = std::min(west, rel), east = std::max(east, rel);
        });
  for (std::size_t i = 0; i < nx; ++i)
    ends(
        ny, [&](std::size_t j) { return c.on_earth[j * nx + i] != 0; },
        [&](std::size_t j) {
          p.to_geodetic(s.x(static_cast<int>(i)), s.y(static_cast<int>(j)), lat, lon);
          south = std::min(south, lat), north = std::max(north, lat);
        });
  if (north >= south)
    c.south = south, c.north = north, c.west = earth::wrap_lon_180(west + p.lon0_deg),
    c.east = earth::wrap_lon_180(east + p.lon0_deg);
  return c;
}

double abi_native_resolution_km(int abi_band) {
  if (abi_band == 2) return 0.5;
  if (abi_band == 1 || abi_band == 3 || abi_band == 5) return 1.0;
  return 2.0;
}

}  // namespace nephos::render
