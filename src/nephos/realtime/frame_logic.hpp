#pragma once
// Per-frame decisions of the real-time renderer that need no GPU: back-to-front order and when
// to re-sort (thesis section 3.5.3), the impostor ring's re-render thresholds and which clouds
// go into it (MSFS 2004), and the sun's direction and colour for a date, time and place.
#include <cstddef>
#include <glm/glm.hpp>
#include <vector>

#include "nephos/core/time.hpp"
#include "nephos/realtime/cloud_field.hpp"
#include "nephos/realtime/weather_input.hpp"  // metres_per_foot

namespace nephos::realtime {

/// Indices of `positions` ordered from farthest to nearest to `camera` (ties by index), the
/// order alpha blending needs.
std::vector<std::size_t> back_to_front(const std::vector<glm::dvec3>& positions, const glm::dvec3& camera);

/// The sort-optimised mode re-sorts only when the view changed enough since the last sort.
struct ResortPolicy {
  double move_m = 200;  ///< camera travel since the last sort
  double turn_deg = 5;  ///< change of viewing direction since the last sort
  glm::dvec3 last_camera{0}, last_forward{1, 0, 0};
  bool sorted_once = false;
  /// True (and remembers the view) when a re-sort is due.
  bool due(const glm::dvec3& camera, const glm::dvec3& forward);
};

/// The octagonal impostor ring around the camera (MSFS 2004): 8 impostors of 45 degrees each,
/// re-rendered when the camera has moved more than 15 % of the ring radius horizontally or 2 %
/// vertically since they were made; clouds beyond the radius go into impostors unless they are
/// more than 10,000 ft above or below the camera.
struct ImpostorRing {
  double radius_m = 8000;
  double horizontal_fraction = 0.15, vertical_fraction = 0.02;
  double max_vertical_offset_m = 10000 * metres_per_foot;
  glm::dvec3 centre{0};  ///< camera position when the impostors were made, in the air's frame
                         ///< (world minus the clouds' drift, CloudField::drift_offset_m)
  bool valid = false;

  bool needs_update(const glm::dvec3& camera) const;
  void rebuilt_at(const glm::dvec3& camera) {
    centre = camera;
    valid = true;
  }
  /// True if a cloud at `position` (bounding radius r) is drawn into an impostor rather than
  /// as sprites.
  bool in_impostor(const glm::dvec3& position, double r, const glm::dvec3& camera) const;
  /// Which of the 8 impostors (0 = east, counter-clockwise, 45 degrees each) holds it.
  int sector(const glm::dvec3& position) const;
};

/// The sun seen from (lat, lon) at `time`: direction in local east-north-up coordinates and an
/// RGB colour reddened by the air mass (Rayleigh optical depth 0.0364, 0.0940, 0.2380 at 700,
/// 546, 435 nm; Kasten & Young 1989 air mass), zero below the horizon.
struct SunLight {
  glm::dvec3 direction;  ///< unit, towards the sun
  glm::dvec3 colour;     ///< relative to the zenith sun's, each channel in [0, 1]
  double elevation_deg;
};
SunLight sun_light(const UtcTime& time, double lat_deg, double lon_deg);

/// What the pilot is pressing this frame (nephos view): each axis in [-1, 1].
struct ControlInput {
  double turn = 0;                              ///< +1: turn right (arrow right / D)
  double climb = 0;                             ///< +1: pitch up (arrow up)
  double throttle = 0;                          ///< +1: faster (W), -1: slower (S)
  double look_yaw_deg = 0, look_pitch_deg = 0;  ///< mouse look this frame (drag), added to the view offset
};

/// Simple flight for the window view: a heading, a flight-path angle and a ground speed, with
/// rates and limits a light aircraft or airliner can fly; the view can look around the nose.
/// East-north-up metres, heading 0 = east, counter-clockwise positive (as the cloud field).
struct FlightControls {
  double heading_deg = 0, path_deg = 0, speed_m_s = 128.6;  ///< 128.6 m/s = 250 kt
  double look_yaw_deg = 0, look_pitch_deg = -3;             ///< view offset from the nose
  double turn_rate_deg_s = 3;                               ///< standard rate turn
  double pitch_rate_deg_s = 5;                              ///< flight-path change rate at full stick
  double max_path_deg = 20;                                 ///< climb/descent angle limit
  double accel_m_s2 = 5;                                    ///< throttle response
  double min_speed_m_s = 30, max_speed_m_s = 260;
  double min_altitude_m = 50;  ///< the aircraft does not fly into the ground
  /// Moves `position` and updates the state by `dt_s` seconds of input.
  void step(const ControlInput& in, double dt_s, glm::dvec3& position);
  /// The viewing direction (unit): nose direction turned by the look offset.
  glm::dvec3 view_direction() const;
};

}  // namespace nephos::realtime
