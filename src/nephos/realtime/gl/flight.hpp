#pragma once
// A straight, level flight eastwards through a cloud field at 30 frames per second of flight:
// the thesis's experiment (8000 ft, 250 kt), as nephos fly, its benchmark and the Python module
// fly it. Each frame moves the camera, advances the clouds' fades and drift, relocates those
// that fell behind, re-sorts when due and draws.
#include <cstdint>
#include <optional>
#include <utility>

#include "nephos/realtime/cloud_field.hpp"
#include "nephos/realtime/frame_logic.hpp"
#include "nephos/realtime/gl/sprite_renderer.hpp"
#include "nephos/realtime/weather_input.hpp"

namespace nephos::realtime {

/// The numbers a flight accepts: from the Dead Sea shore to beyond any aircraft's ceiling, up to
/// 5000 kt, a level of detail up to 10 000 km (0: off), an impostor ring radius in (0, 10 000]
/// km and a longitude in [-360, 360] degrees (either sign convention, one turn either way).
inline constexpr double min_altitude_ft = -1500, max_altitude_ft = 100000, max_speed_kt = 5000, max_lod_km = 1e4,
                        max_impostor_radius_km = 1e4, max_abs_longitude_deg = 360;

struct FlightParams {
  double altitude_m = 8000 * metres_per_foot;           ///< above the ground (the thesis's 8000 ft)
  double speed_m_s = 250 * metres_per_second_per_knot;  ///< ground speed, eastwards (250 kt)
  bool sort_optimised = true;                           ///< re-sort only when the view changed enough (ResortPolicy)
  bool impostors = true;                                ///< far clouds through the impostor ring
};

class StraightFlight {
 public:
  /// The camera starts at (0, 0, altitude), looking east 3 degrees down; the clouds of `recipe`
  /// are placed around it from `seed`.
  StraightFlight(const CloudRecipe& recipe, std::uint64_t seed, const FlightParams& params = {});
  /// From `at_s` seconds of flight on, the weather is `recipe`: clouds form and dissipate.
  void change_weather_at(const CloudRecipe& recipe, double at_s);
  /// Flies one frame (1/30 s; frame n is drawn at n/30 s of flight) and draws it.
  FrameStats next_frame(SpriteRenderer& renderer, const SunLight& sun);

  int frames_flown() const { return frame_; }
  const CloudField& field() const { return field_; }
  const Camera& camera() const { return camera_; }

 private:
  FlightParams p_;
  Camera camera_;
  CloudField field_;
  ResortPolicy policy_;
  std::optional<std::pair<CloudRecipe, double>> change_;  ///< the new weather and when [s of flight]
  int frame_ = 0;
};

}  // namespace nephos::realtime
