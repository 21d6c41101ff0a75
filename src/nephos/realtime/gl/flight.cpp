#include "nephos/realtime/gl/flight.hpp"

namespace nephos::realtime {

StraightFlight::StraightFlight(const CloudRecipe& recipe, std::uint64_t seed, const FlightParams& params)
    : p_(params),
      camera_{{0, 0, params.altitude_m}, {1, 0, -0.05}, {0, 0, 1}, 60},
      field_(recipe, seed, camera_.position) {}

void StraightFlight::change_weather_at(const CloudRecipe& recipe, double at_s) { change_.emplace(recipe, at_s); }

FrameStats StraightFlight::next_frame(SpriteRenderer& renderer, const SunLight& sun) {
  camera_.position.x += p_.speed_m_s / 30.0;  // 30 frames per second of flight
  const double t_s = frame_ / 30.0;
  ++frame_;
  if (change_ && t_s >= change_->second) {
    field_.change_weather(change_->first, t_s, camera_.position);
    change_.reset();
  }
  field_.advance_time(t_s);
  field_.follow_camera(camera_.position, camera_.forward);
  const bool sort = !p_.sort_optimised || policy_.due(camera_.position, camera_.forward);
  return renderer.draw(field_, camera_, sun, sort, p_.impostors);
}

}  // namespace nephos::realtime
