#pragma once
// A particle-cloud scene: the weather, the particles born from it, their motion, and per frame
// the sprites to draw (positions at the frame's time, level of detail for the camera, grey
// values from the light, back-to-front order). What `nephos particles` and its benchmark run.
#include <cstdint>
#include <optional>

#include <glm/glm.hpp>

#include "nephos/particles/particle_system.hpp"
#include "nephos/realtime/frame_plan.hpp"

namespace nephos::particles {

struct SceneParams {
  GenerationParams generation;
  bool lod = true;
  LodParams lod_params{0.0};  ///< l0_m <= 0: default_l0_m(camera)
  IlluminationParams illumination;
  std::optional<Light> light;  ///< default: the sun at each frame's time over the region's centre
};

struct FrameTimings {
  double motion_ms = 0, lod_ms = 0, light_ms = 0, sort_ms = 0;
  std::size_t drawn = 0;
};

class ParticleScene {
 public:
  /// Generates the particles from the first frame's columns. Throws like generate().
  ParticleScene(ParticleWeather weather, SceneParams params);

  const ParticleWeather& weather() const { return weather_; }
  const Particles& initial() const { return initial_; }
  const SceneParams& params() const { return params_; }
  /// UTC time of t_s seconds after the first frame.
  UtcTime time_at(double t_s) const;
  /// The light at t_s (the sun over the region's centre unless a light was given).
  Light light_at(double t_s) const;
  /// The weather frame whose columns light the particles at t_s (the latest at or before it).
  const WeatherFrame& frame_at(double t_s) const;

  /// Moves the particles to t_s; `current()` then holds them.
  void move_to(double t_s);
  const Particles& current() const { return current_; }
  /// Grey values of all current particles (for the PLY output).
  std::vector<float> shade_all(double t_s) const;
  /// Sprites for the camera at the current time: LOD-thinned, lit, sorted back to front.
  realtime::PointSprites sprites(double t_s, const glm::dvec3& camera, FrameTimings* timings = nullptr) const;

  /// Eq. 13's L0 when none is given: 60 % of the camera's distance to the region's centre, so the
  /// near half of the scene keeps every particle.
  double default_l0_m(const glm::dvec3& camera) const;
  /// A camera south of the region, looking north-down at its centre, seeing all of it.
  realtime::Camera default_camera() const;

 private:
  ParticleWeather weather_;
  SceneParams params_;
  Particles initial_, current_;
  Motion motion_;
};

/// Indices that order `keys` descending (LSD radix sort on the IEEE bits of non-negative floats:
/// stable, O(n), the same result as a stable comparison sort).
std::vector<std::uint32_t> order_descending(const std::vector<float>& keys);

}  // namespace nephos::particles
