#include "nephos/render/sensor.hpp"

#include <fmt/format.h>
#include <cmath>
#include <filesystem>
#include <vector>

#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/earth/earth.hpp"

namespace nephos::render {
namespace {
Sensor oriented(const earth::Vec3& pos, const earth::Vec3& forward, const earth::Vec3& up_hint, double fov_deg,
                int width, int height) {
  if (!fov_in_range(fov_deg))
    throw ValueError(fmt::format("field of view {} deg must be in (0, {:g})", fov_deg, max_fov_deg), {.key = "fov"});
  if (width < 1 || height < 1) throw ValueError("image size must be positive", {.key = "size"});
  Sensor s;
  s.position = pos;
  s.forward = glm::normalize(forward);
  earth::Vec3 right = glm::cross(s.forward, up_hint);
  if (glm::length(right) < 1e-9) right = glm::cross(s.forward, earth::Vec3{0, 0, 1});
  if (glm::length(right) < 1e-9) right = glm::cross(s.forward, earth::Vec3{1, 0, 0});
  s.right = glm::normalize(right);
  s.up = glm::cross(s.right, s.forward);
  s.fov_deg = fov_deg;
  s.width = width;
  s.height = height;
  return s;
}

// Longitudes east in either convention, [-180, 180] or GRIB's [0, 360]; beyond, a typing error.
void check_longitude(double lon_deg, const char* sensor) {
  if (!(lon_deg >= -180 && lon_deg <= 360))
    throw ValueError(fmt::format("{} longitude must be in [-180, 360] deg east, got {:g}", sensor, lon_deg),
                     {.key = "sensor"});
}
}  // namespace

Sensor Sensor::geostationary(double lon_deg, int width, int height) {
  const earth::Vec3 pos = earth::ecef({0, lon_deg, geostationary_altitude_m});
  const double fov = 2 * std::asin((earth::radius_m + 100e3) / glm::length(pos)) / earth::deg;
  Sensor s = oriented(pos, -pos, {0, 0, 1}, fov, width, height);
  s.description = fmt::format("geostationary over {:g} deg, full disc ({:.2f} deg)", lon_deg, fov);
  return s;
}

Sensor Sensor::nadir(double lat_deg, double lon_deg, double altitude_m, double fov_deg, int width, int height) {
  const earth::Vec3 pos = earth::ecef({lat_deg, lon_deg, altitude_m});
  const earth::Vec3 up = glm::normalize(pos);
  Sensor s = oriented(pos, -up, earth::local_north(up), fov_deg, width, height);
  s.description = fmt::format("nadir from {:g} deg, {:g} deg, {:g} km, {:g} deg field of view", lat_deg, lon_deg,
                              altitude_m / 1e3, fov_deg);
  return s;
}

Sensor Sensor::look_at(const earth::Geodetic& from, const earth::Geodetic& target, double fov_deg, int width,
                       int height, const earth::Vec3* up_hint) {
  const earth::Vec3 pos = earth::ecef(from), tgt = earth::ecef(target);
  if (glm::length(tgt - pos) < min_look_at_distance_m)
    throw ValueError("camera position and look-at target coincide", {.key = "camera"});
  Sensor s = oriented(pos, tgt - pos, up_hint ? *up_hint : glm::normalize(pos), fov_deg, width, height);
  s.description = fmt::format("camera at ({:g}, {:g}, {:g} m) looking at ({:g}, {:g}, {:g} m)", from.lat_deg,
                              from.lon_deg, from.alt_m, target.lat_deg, target.lon_deg, target.alt_m);
  return s;
}

Sensor sensor_from(const ParamDict& c, int width, int height) {
  auto need = [&](const char* key, double lo, double hi) {
    if (!c.has(key)) throw ConfigError("missing camera key", {.file = c.source(), .key = std::string("camera.") + key});
    return c.get_in(key, 0.0, lo, hi);
  };
  constexpr double big = 1e12;  // [deg] or [m]: any finite value
  const earth::Geodetic from{need("position_lat_deg", -90, 90), need("position_lon_deg", -big, big),
                             need("position_alt_m", -earth::radius_m + 1, big)};
  const earth::Geodetic to{need("look_at_lat_deg", -90, 90), need("look_at_lon_deg", -big, big),
                           c.get_in("look_at_alt_m", 0.0, -earth::radius_m + 1, big)};
  // The limits Sensor::look_at() checks, here named as the file's keys.
  const double fov = need("fov_deg", -big, big);
  if (!fov_in_range(fov)) c.fail("fov_deg", fmt::format("must be in (0, {:g}), got {:g}", max_fov_deg, fov));
  if (glm::length(earth::ecef(to) - earth::ecef(from)) < min_look_at_distance_m)
    c.fail("look_at_lat_deg",
           fmt::format("the look-at target lies within {:g} m of the camera's position", min_look_at_distance_m));
  const std::vector<double> up = c.get("up", std::vector<double>{});
  if (!up.empty() && up.size() != 3) throw ConfigError("expected [x, y, z]", {.file = c.source(), .key = "camera.up"});
  for (double u : up)
    if (!std::isfinite(u)) throw ConfigError("expected finite numbers", {.file = c.source(), .key = "camera.up"});
  const earth::Vec3 hint = up.empty() ? earth::Vec3{} : earth::Vec3{up[0], up[1], up[2]};
  return Sensor::look_at(from, to, fov, width, height, up.empty() ? nullptr : &hint);
}

earth::Vec3 FixedGridView::ray(const earth::Vec3& position, double x, double y) const {
  earth::Vec3 d;
  row_rays(position, y, x, 1, &d);
  return d;
}

void FixedGridView::row_rays(const earth::Vec3& position, double y, double dx, int width, earth::Vec3* out) const {
  const double ys = sector.y0_rad + (y - 0.5) * sector.dy_rad, sin_y = std::sin(ys), cos_y = std::cos(ys);
  const double cl = std::cos(projection.lon0_deg * earth::deg), sl = std::sin(projection.lon0_deg * earth::deg);
  for (int i = 0; i < width; ++i) {
    const double xs = sector.x0_rad + (i + dx - 0.5) * sector.dx_rad;
    earth::Vec3 up;
    if (!projection.geodetic_up_at_origin(std::sin(xs), std::cos(xs), sin_y, cos_y, up)) {
      out[i] = projection.line_of_sight(xs, ys);
      continue;
    }
    const earth::Vec3 e{up.x * cl - up.y * sl, up.x * sl + up.y * cl, up.z};  // turned to the origin's longitude
    out[i] = glm::normalize(earth::radius_m * e - position);
  }
}

Sensor Sensor::abi(const FixedGridView& view) {
  Sensor s;
  s.position = view.projection.satellite_ecef();
  s.forward = -glm::normalize(s.position);
  s.up = earth::Vec3{0, 0, 1};
  s.right = glm::normalize(glm::cross(s.forward, s.up));
  s.width = view.sector.nx, s.height = view.sector.ny;
  s.fov_deg = 2 * std::atan(0.5 * view.sector.dx_rad * view.sector.nx) / earth::deg;
  s.fixed_grid = std::make_shared<const FixedGridView>(view);
  s.description = fmt::format("ABI fixed grid ({}, projection origin {:.1f} deg), {} sector, {:g} km x {} = {}x{} px",
                              view.platform, view.projection.lon0_deg, view.sector.scene, view.sector.resolution_km,
                              view.sector.step, view.sector.nx, view.sector.ny);
  return s;
}

FixedGridView abi_view(const std::string& spec, const std::string& scene, double resolution_km, int step) {
  FixedGridView v;
  const std::string which = spec.substr(4);
  if (which == "east") {
    v.projection.lon0_deg = -75.0, v.nominal_subpoint_lon_deg = -75.2, v.platform = "G16";
  } else if (which == "west") {
    v.projection.lon0_deg = -137.0, v.nominal_subpoint_lon_deg = -137.2, v.platform = "G18";
  } else {
    const double lon_east = parse_numbers(which, 1, "sensor", "abi:east, abi:west or abi:LON")[0];
    check_longitude(lon_east, "ABI");
    const double lon = earth::wrap_lon_180(lon_east);
    v.projection.lon0_deg = v.nominal_subpoint_lon_deg = lon;
    // The nearer GOES position's (its calibration), the longitudes' difference taken round the globe.
    v.platform = std::abs(earth::wrap_lon_180(lon + 75)) <= std::abs(earth::wrap_lon_180(lon + 137)) ? "G16" : "G18";
  }
  v.sector = fixed_grid_sector(v.projection, scene, resolution_km, step);
  if (v.sector.nx < 1 || v.sector.ny < 1)
    throw ValueError(fmt::format("abi_step {} leaves no pixel of the {} sector", step, v.sector.scene),
                     {.key = "abi_step"});
  return v;
}

Sensor parse_sensor(const std::string& spec, int width, int height, const std::string& scene, double resolution_km,
                    int abi_step) {
  if (spec.rfind("abi:", 0) == 0) return Sensor::abi(abi_view(spec, scene, resolution_km, abi_step));
  if (spec.rfind("geo:", 0) == 0) {
    const double lon_deg = parse_numbers(spec.substr(4), 1, "sensor", "geo:LON")[0];
    check_longitude(lon_deg, "GEO");
    return Sensor::geostationary(lon_deg, width, height);
  }
  if (spec.rfind("leo:", 0) == 0) {
    const auto v = parse_numbers(spec.substr(4), 4, "sensor", "leo:LAT,LON,ALT_KM,FOV_DEG");
    if (!(v[0] >= -90 && v[0] <= 90))
      throw ValueError(fmt::format("LEO latitude must be in [-90, 90] deg, got {:g}", v[0]), {.key = "sensor"});
    check_longitude(v[1], "LEO");
    if (v[2] <= 0) throw ValueError("LEO altitude must be > 0 km", {.key = "sensor"});
    return Sensor::nadir(v[0], v[1], v[2] * 1e3, v[3], width, height);
  }
  if (std::filesystem::exists(spec)) {
    const ParamDict d = ParamDict::from_file(spec);
    Sensor s = sensor_from(d.table("camera"), width, height);
    d.check_unused();
    return s;
  }
  throw ValueError("sensor '" + spec +
                       "' is neither geo:LON, leo:LAT,LON,ALT_KM,FOV_DEG, abi:east|west|LON nor an existing TOML file",
                   {.key = "sensor"});
}

}  // namespace nephos::render
