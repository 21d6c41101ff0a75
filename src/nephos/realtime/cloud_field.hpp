#pragma once
// The cloud field around an aircraft (thesis sections 3.3-3.3.5; MSFS 2004 cloud model):
// sprite clouds built from several sprites in shading groups, placed in their altitude bands,
// clustered or spread by the weather code's rules, and relocated ahead of the camera when they
// fall behind so the sky never empties; flat altostratus/cirrus/fog layers. Deterministic from
// the seed (counter-based hashing). Coordinates: local east-north-up metres, z up.
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "nephos/realtime/weather_input.hpp"

namespace nephos::realtime {

struct Sprite {
  glm::vec3 offset;   ///< from the cloud centre [m]
  float size_m;       ///< billboard edge length
  int texture_layer;  ///< index into the sprite texture array (type x view angle)
  int shading_group;  ///< clump the directional shading is computed for
};

struct SpriteCloud {
  std::uint32_t id;
  SpriteCloudType type;
  glm::dvec3 centre;  ///< [m]
  float radius_m;     ///< bounding radius of its sprites
  std::vector<Sprite> sprites;
  std::vector<glm::vec3> group_centres;  ///< per shading group, offsets from the centre
  std::uint32_t relocations = 0;
  /// Formation and dissipation (MSFS 2004): opacity ramps linearly from fade_from to fade_to
  /// over fade_time_s from fade_start_s; the renderer multiplies alpha by it.
  float opacity = 1, fade_from = 1, fade_to = 1;
  double fade_start_s = -1e300;
  double fade_time_s = 20;  ///< the field's fade_s, or relocation_fade_s after a relocation
  /// The whole cloud as one sprite, for the single-sprite level of detail far away (MSFS 2004:
  /// "a degenerate case of the model"): at the sprites' centroid, as wide as the cloud, in a
  /// shading group of its own centred on it (no directional term), the side view's texture.
  Sprite lod{};
  bool fading() const { return opacity != fade_to; }
};

struct FlatLayer {
  SpriteCloudType type;  ///< altostratus, cirrus or low stratus
  double altitude_m;
  double extent_m;  ///< half-width of the square it covers around the camera
  float opacity = 1, fade_from = 1, fade_to = 1;
  double fade_start_s = -1e300;
  double fade_time_s = 20;  ///< the field's fade_s
};

struct CloudFieldParams {
  double field_radius_m = 30000;  ///< clouds live within this distance of the camera
  double min_spacing_m = 3000;    ///< spread codes (d100/d200): minimum distance between clouds (B.3)
  double cluster_sigma_m = 2500;  ///< clustered codes: spread of clouds around a cluster centre (B.2)
  double fade_s = 20;             ///< formation / dissipation time of a cloud or layer
  /// A cloud relocated ahead forms over this time [s] instead of appearing from nothing: 3 s,
  /// 90 frames, long enough to read as a distant cloud coming into view rather than a pop.
  double relocation_fade_s = 3;
};

class CloudField {
 public:
  /// The clouds around `camera`, which is taken to look east (+x) at first: those that would lie
  /// behind it are placed ahead at once (follow_camera's rule), formed.
  CloudField(const CloudRecipe& recipe, std::uint64_t seed, const glm::dvec3& camera, CloudFieldParams params = {});
  /// Moves clouds that fell behind the camera (or out of the field) to new places ahead of it
  /// (12-30 km away, beyond the impostor ring), where they form from opacity 0 over
  /// relocation_fade_s (a dissipating one is removed instead). Returns how many were relocated.
  int follow_camera(const glm::dvec3& camera, const glm::dvec3& forward);
  /// New weather at time now_s [s]: per sprite type, clouds beyond the new count dissipate
  /// (fade out, then are removed) and missing ones form around the camera (fade in); flat layers
  /// that go away fade out, new ones fade in. Nothing pops.
  void change_weather(const CloudRecipe& recipe, double now_s, const glm::dvec3& camera);
  /// Advances fades to now_s, moves every cloud with the recipe's wind (drift) over the time
  /// since the last call, and removes clouds and layers that have fully dissipated.
  void advance_time(double now_s);
  /// How far the air (and with it the flat layers' pattern) has drifted since the start [m,
  /// east and north].
  glm::dvec2 drift_offset_m() const { return drift_offset_m_; }
  double time_s() const { return now_s_; }
  const std::vector<SpriteCloud>& clouds() const { return clouds_; }
  const std::vector<FlatLayer>& layers() const { return layers_; }
  std::size_t sprite_count() const;
  /// Level of detail: the weight of a cloud's single sprite at `distance_m`, its sprites' being
  /// 1 minus it: 0 within 0.95 `single_sprite_distance_m`, 1 beyond 1.05 of it, linear between
  /// (a cross-dissolve over 2 km at 20 km instead of a switch); 0 everywhere if that is 0 (off).
  static double lod_weight(double distance_m, double single_sprite_distance_m);
  /// The sprites a cloud draws at `distance_m`: its single sprite where lod_weight > 0 and all its
  /// sprites where lod_weight < 1 (both across the level-of-detail distance).
  static std::size_t sprites_to_draw(const SpriteCloud& c, double distance_m, double single_sprite_distance_m);

 private:
  void build_sprites(SpriteCloud& c) const;
  // follow_camera's rule; `form`: the moved clouds form from opacity 0 (else they are there).
  int relocate(const glm::dvec3& camera, const glm::dvec3& forward, bool form);
  std::vector<FlatLayer> flat_layers_of(const CloudRecipe& recipe) const;
  glm::dvec3 place(const CloudLayerRecipe& layer, std::uint32_t id, std::uint32_t salt, const glm::dvec3& around,
                   const glm::dvec3& forward, bool ahead) const;
  std::uint64_t seed_;
  CloudFieldParams p_;
  std::vector<SpriteCloud> clouds_;
  std::vector<CloudLayerRecipe> layer_of_cloud_;
  std::vector<FlatLayer> layers_;
  std::uint32_t next_id_ = 0;
  double now_s_ = 0;
  glm::dvec2 drift_m_s_{0.0}, drift_offset_m_{0.0};  // wind [m/s] and the displacement it caused
};

}  // namespace nephos::realtime
