#include "nephos/realtime/frame_logic.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "nephos/earth/sun.hpp"

namespace nephos::realtime {

std::vector<std::size_t> back_to_front(const std::vector<glm::dvec3>& positions, const glm::dvec3& camera) {
  std::vector<double> d2(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const glm::dvec3 d = positions[i] - camera;
    d2[i] = glm::dot(d, d);
  }
  std::vector<std::size_t> order(positions.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return d2[a] > d2[b]; });
  return order;
}

bool ResortPolicy::due(const glm::dvec3& camera, const glm::dvec3& forward) {
  const glm::dvec3 f = glm::normalize(forward);
  const double turn = std::acos(std::clamp(glm::dot(f, last_forward), -1.0, 1.0)) * 180 / M_PI;
  if (sorted_once && glm::length(camera - last_camera) <= move_m && turn <= turn_deg) return false;
  last_camera = camera;
  last_forward = f;
  sorted_once = true;
  return true;
}

bool ImpostorRing::needs_update(const glm::dvec3& camera) const {
  if (!valid) return true;
  const double dh = glm::length(glm::dvec2(camera.x - centre.x, camera.y - centre.y));
  const double dv = std::abs(camera.z - centre.z);
  return dh > horizontal_fraction * radius_m || dv > vertical_fraction * radius_m;
}

bool ImpostorRing::in_impostor(const glm::dvec3& position, double r, const glm::dvec3& camera) const {
  const double dh = glm::length(glm::dvec2(position.x - camera.x, position.y - camera.y));
  if (std::abs(position.z - camera.z) > max_vertical_offset_m) return false;  // view too steep
  return dh - r > radius_m;                                                   // wholly beyond the ring
}

int ImpostorRing::sector(const glm::dvec3& position) const {
  double a = std::atan2(position.y - centre.y, position.x - centre.x) * 180 / M_PI;  // 0 = east
  if (a < 0) a += 360;
  return static_cast<int>(std::floor((a + 22.5) / 45.0)) % 8;
}

SunLight sun_light(const UtcTime& time, double lat_deg, double lon_deg) {
  const earth::SunPosition s = earth::sun_position(time);
  const earth::Vec3 up = earth::unit_from_latlon(lat_deg, lon_deg);
  const earth::Vec3 e = earth::local_east(up), n = earth::local_north(up);
  const glm::dvec3 dir{glm::dot(s.direction_ecef, e), glm::dot(s.direction_ecef, n), glm::dot(s.direction_ecef, up)};
  SunLight l;
  l.direction = glm::normalize(dir);
  l.elevation_deg = std::asin(std::clamp(l.direction.z, -1.0, 1.0)) * 180 / M_PI;
  if (l.elevation_deg <= -0.833) {  // below the horizon (refraction and the Sun's radius)
    l.colour = {0, 0, 0};
    return l;
  }
  // Kasten & Young (1989) relative air mass; Rayleigh optical depths of a standard atmosphere.
  const double h = std::max(l.elevation_deg, -0.8);
  const double m = 1.0 / (std::sin(h * M_PI / 180) + 0.50572 * std::pow(h + 6.07995, -1.6364));
  const double tau[3] = {0.0364, 0.0940, 0.2380};                           // R 700 nm, G 546 nm, B 435 nm
  for (int c = 0; c < 3; ++c) l.colour[c] = std::exp(-tau[c] * (m - 1.0));  // relative to the zenith (m = 1)
  return l;
}

void FlightControls::step(const ControlInput& in, double dt_s, glm::dvec3& position) {
  const double turn = std::clamp(in.turn, -1.0, 1.0), climb = std::clamp(in.climb, -1.0, 1.0);
  heading_deg = std::fmod(heading_deg - turn * turn_rate_deg_s * dt_s + 360.0, 360.0);  // right = clockwise
  path_deg = std::clamp(path_deg + climb * pitch_rate_deg_s * dt_s, -max_path_deg, max_path_deg);
  speed_m_s =
      std::clamp(speed_m_s + std::clamp(in.throttle, -1.0, 1.0) * accel_m_s2 * dt_s, min_speed_m_s, max_speed_m_s);
  look_yaw_deg = std::clamp(look_yaw_deg + in.look_yaw_deg, -180.0, 180.0);
  look_pitch_deg = std::clamp(look_pitch_deg + in.look_pitch_deg, -80.0, 80.0);
  const double h = glm::radians(heading_deg), g = glm::radians(path_deg);
  position += speed_m_s * dt_s * glm::dvec3(std::cos(g) * std::cos(h), std::cos(g) * std::sin(h), std::sin(g));
  if (position.z < min_altitude_m) {
    position.z = min_altitude_m;
    path_deg = std::max(path_deg, 0.0);
  }
}

glm::dvec3 FlightControls::view_direction() const {
  const double h = glm::radians(heading_deg - look_yaw_deg), p = glm::radians(path_deg + look_pitch_deg);
  return {std::cos(p) * std::cos(h), std::cos(p) * std::sin(h), std::sin(p)};
}

}  // namespace nephos::realtime
