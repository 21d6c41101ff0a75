#include "nephos/realtime/cloud_field.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include <utility>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"

namespace nephos::realtime {
namespace {
double u01(std::uint64_t seed, std::uint64_t a, std::uint64_t b, std::uint64_t c = 0) {
  return uniform01(seed, a, b, c);
}
}  // namespace

glm::dvec3 CloudField::place(const CloudLayerRecipe& layer, std::uint32_t id, std::uint32_t salt,
                             const glm::dvec3& around, const glm::dvec3& forward, bool ahead) const {
  const double r = p_.field_radius_m;
  glm::dvec3 pos;
  if (ahead) {  // thesis 3.3.5: in front of the camera, scattered across the view
    glm::dvec3 f{forward.x, forward.y, 0};
    f = glm::length(f) > 1e-9 ? glm::normalize(f) : glm::dvec3{1, 0, 0};
    const glm::dvec3 right{f.y, -f.x, 0};
    const double dist = r * (0.4 + 0.6 * u01(seed_, id, salt, 1));
    const double side = r * (u01(seed_, id, salt, 2) - 0.5);
    pos = around + dist * f + side * right;
  } else {  // uniform over the disc around the camera
    const double rr = r * std::sqrt(u01(seed_, id, salt, 1)), a = 2 * M_PI * u01(seed_, id, salt, 2);
    pos = around + glm::dvec3{rr * std::cos(a), rr * std::sin(a), 0};
  }
  pos.z = layer.base_m + (layer.top_m - layer.base_m) * 0.3 * u01(seed_, id, salt, 3);  // base low in the band
  return pos;
}

void CloudField::build_sprites(SpriteCloud& c) const {
  // A cloud is a few boxes (shading groups, MSFS 2004) filled with sprites: cumulus heaped up,
  // stratocumulus flat and wide.
  const bool cu = c.type == SpriteCloudType::cumulus;
  const int groups = 3 + static_cast<int>(3 * u01(seed_, c.id, 7, 0));
  const double width = cu ? 1500 : 2500, height = cu ? 1200 : 400;
  c.sprites.clear();
  c.group_centres.clear();
  float radius = 0;
  for (int g = 0; g < groups; ++g) {
    const auto gu = static_cast<std::uint64_t>(g);
    const glm::vec3 centre{static_cast<float>(width * (u01(seed_, c.id, 8, gu) - 0.5)),
                           static_cast<float>(width * 0.6 * (u01(seed_, c.id, 9, gu) - 0.5)),
                           static_cast<float>(height * u01(seed_, c.id, 10, gu) * (cu ? 1.0 : 0.3))};
    c.group_centres.push_back(centre);
    const int n = 4 + static_cast<int>(5 * u01(seed_, c.id, 11, gu));
    for (int s = 0; s < n; ++s) {
      const auto su = static_cast<std::uint64_t>(g * 64 + s);
      const glm::vec3 off = centre + glm::vec3{static_cast<float>(500 * (u01(seed_, c.id, 12, su) - 0.5)),
                                               static_cast<float>(500 * (u01(seed_, c.id, 13, su) - 0.5)),
                                               static_cast<float>((cu ? 300 : 80) * (u01(seed_, c.id, 14, su) - 0.5))};
      const float size = static_cast<float>((cu ? 600 : 700) + 400 * u01(seed_, c.id, 15, su));
      const int layer = (cu ? 0 : 5) + static_cast<int>(5 * u01(seed_, c.id, 16, su));  // 5 view angles per type
      c.sprites.push_back({off, size, layer, g});
      radius = std::max(radius, glm::length(off) + 0.5f * size);
    }
  }
  c.radius_m = radius;
  glm::vec3 centroid(0.0f);
  for (const Sprite& sp : c.sprites) centroid += sp.offset;
  centroid /= static_cast<float>(c.sprites.size());
  float reach = 0;  // the sprites' extent around the centroid
  for (const Sprite& sp : c.sprites) reach = std::max(reach, glm::length(sp.offset - centroid) + 0.5f * sp.size_m);
  c.group_centres.push_back(centroid);
  c.lod = {centroid, 2 * reach, (cu ? 0 : 5) + 2, groups};  // layer 2 of 5: seen from the side (0 deg)
}

CloudField::CloudField(const CloudRecipe& recipe, std::uint64_t seed, const glm::dvec3& camera, CloudFieldParams params)
    : seed_(seed), p_(params), drift_m_s_(recipe.drift_east_m_s, recipe.drift_north_m_s) {
  for (const auto& [value, key] : {std::pair{p_.fade_s, "fade_s"}, {p_.relocation_fade_s, "relocation_fade_s"}})
    if (!(value > 0 && value < 1e9))
      throw ValueError(fmt::format("must be in (0, 1e9) s, got {:g}", value), {.key = key});
  std::uint32_t id = 0;
  layers_ = flat_layers_of(recipe);
  for (const auto& layer : recipe.layers) {
    if (layer.type != SpriteCloudType::cumulus && layer.type != SpriteCloudType::stratocumulus) continue;
    const int clusters = std::max(1, layer.count / 10);
    for (int k = 0; k < layer.count; ++k, ++id) {
      SpriteCloud c{id, layer.type, {}, 0, {}, {}, 0};
      if (recipe.clustered) {  // around one of a few cluster centres (thesis Appendix B.2)
        const auto cl = static_cast<std::uint32_t>(k % clusters);
        const glm::dvec3 centre = place(layer, 100000 + cl, 0, camera, {1, 0, 0}, false);
        const double a = 2 * M_PI * u01(seed_, id, 21),
                     rr = p_.cluster_sigma_m * std::sqrt(-2 * std::log(1 - u01(seed_, id, 22)));
        c.centre = centre + glm::dvec3{rr * std::cos(a), rr * std::sin(a), 0};
        c.centre.z = place(layer, id, 0, camera, {1, 0, 0}, false).z;
      } else {
        c.centre = place(layer, id, 0, camera, {1, 0, 0}, false);
      }
      build_sprites(c);
      clouds_.push_back(std::move(c));
      layer_of_cloud_.push_back(layer);
    }
  }
  next_id_ = id;
  if (!recipe.clustered && clouds_.size() > 1) {
    // Spread codes (d100/d200): push pairs closer than the minimum spacing apart (Appendix B.3),
    // a few sweeps in a fixed order (deterministic).
    for (int sweep = 0; sweep < 8; ++sweep)
      for (std::size_t i = 0; i < clouds_.size(); ++i)
        for (std::size_t j = 0; j < clouds_.size(); ++j) {
          if (i == j) continue;
          glm::dvec2 d{clouds_[i].centre.x - clouds_[j].centre.x, clouds_[i].centre.y - clouds_[j].centre.y};
          const double dist = glm::length(d);
          if (dist >= p_.min_spacing_m) continue;
          if (dist < 1e-6) d = {1, 0};
          const glm::dvec2 push = glm::normalize(d) * (p_.min_spacing_m - dist) * 0.5;
          clouds_[i].centre.x += push.x;
          clouds_[i].centre.y += push.y;
          clouds_[j].centre.x -= push.x;
          clouds_[j].centre.y -= push.y;
        }
  }
  // The field as the camera first sees it (looking east, as the flights start): what lies behind
  // it is moved ahead at once by follow_camera's rule, already formed, since nobody saw it
  // appear.
  relocate(camera, {1, 0, 0}, false);
}

int CloudField::follow_camera(const glm::dvec3& camera, const glm::dvec3& forward) {
  return relocate(camera, forward, true);
}

int CloudField::relocate(const glm::dvec3& camera, const glm::dvec3& forward, bool form) {
  int moved = 0;
  glm::dvec3 f{forward.x, forward.y, 0};
  f = glm::length(f) > 1e-9 ? glm::normalize(f) : glm::dvec3{1, 0, 0};
  for (std::size_t k = 0; k < clouds_.size(); ++k) {
    SpriteCloud& c = clouds_[k];
    const glm::dvec3 rel{c.centre.x - camera.x, c.centre.y - camera.y, 0};
    const bool behind = glm::dot(rel, f) < -0.25 * p_.field_radius_m;
    const bool far = glm::length(rel) > 1.2 * p_.field_radius_m;
    if (!behind && !far) continue;
    ++c.relocations;
    c.centre = place(layer_of_cloud_[k], c.id, c.relocations, camera, f, true);
    ++moved;
    if (!form) continue;
    // It forms there (MSFS 2004's formation fade) rather than popping into view; a dissipating
    // cloud stays at opacity 0 and is removed by the next advance_time.
    c.opacity = c.fade_from = 0;
    c.fade_start_s = now_s_;
    c.fade_time_s = p_.relocation_fade_s;
  }
  return moved;
}

std::vector<FlatLayer> CloudField::flat_layers_of(const CloudRecipe& recipe) const {
  std::vector<FlatLayer> out;
  for (const auto& layer : recipe.layers) {
    if (layer.type == SpriteCloudType::cumulus || layer.type == SpriteCloudType::stratocumulus) continue;
    for (int k = 0; k < std::min(layer.count, 2); ++k)  // at most two flat layers of a type
      out.push_back({layer.type, layer.type == SpriteCloudType::low_stratus ? layer.base_m : layer.base_m + k * 800.0,
                     p_.field_radius_m * 1.5});
  }
  return out;
}

void CloudField::change_weather(const CloudRecipe& recipe, double now_s, const glm::dvec3& camera) {
  advance_time(now_s);
  drift_m_s_ = {recipe.drift_east_m_s, recipe.drift_north_m_s};
  auto fade = [&](auto& x, float to) {
    x.fade_from = x.opacity;
    x.fade_to = to;
    x.fade_start_s = now_s;
    x.fade_time_s = p_.fade_s;
  };
  for (SpriteCloudType type : {SpriteCloudType::cumulus, SpriteCloudType::stratocumulus}) {
    int wanted = 0;
    const CloudLayerRecipe* layer = nullptr;
    for (const auto& l : recipe.layers)
      if (l.type == type) wanted += l.count, layer = &l;
    int have = 0;
    for (auto& c : clouds_) {
      if (c.type != type || c.fade_to == 0) continue;
      if (have < wanted)
        ++have;
      else
        fade(c, 0.0f);  // dissipates
    }
    for (; have < wanted; ++have) {  // forms around the camera
      SpriteCloud c{next_id_++, type, {}, 0, {}, {}, 0};
      c.centre = place(*layer, c.id, 0, camera, {1, 0, 0}, false);
      build_sprites(c);
      c.opacity = 0;
      fade(c, 1.0f);
      clouds_.push_back(std::move(c));
      layer_of_cloud_.push_back(*layer);
    }
  }
  // Flat layers: keep those at the same type and altitude, fade the rest out and the new in.
  std::vector<FlatLayer> next = flat_layers_of(recipe);
  for (auto& l : layers_) {
    const auto same = std::find_if(next.begin(), next.end(), [&](const FlatLayer& n) {
      return n.type == l.type && std::abs(n.altitude_m - l.altitude_m) < 1 && n.opacity > 0;
    });
    if (same != next.end() && l.fade_to > 0) {
      same->opacity = -1;  // matched: not added again
    } else if (l.fade_to > 0) {
      fade(l, 0.0f);
    }
  }
  for (auto& n : next)
    if (n.opacity > 0) {
      n.opacity = 0;
      fade(n, 1.0f);
      layers_.push_back(n);
    }
}

void CloudField::advance_time(double now_s) {
  // The clouds drift with the wind (GFS recipes; zero for weather codes and METAR).
  const glm::dvec2 shift = drift_m_s_ * (now_s - now_s_);
  drift_offset_m_ += shift;
  for (auto& c : clouds_) c.centre += glm::dvec3(shift, 0.0);
  now_s_ = now_s;
  auto update = [&](auto& x) {
    const double t = std::clamp((now_s - x.fade_start_s) / x.fade_time_s, 0.0, 1.0);
    x.opacity = static_cast<float>(x.fade_from + (x.fade_to - x.fade_from) * t);
  };
  for (auto& c : clouds_) update(c);
  for (auto& l : layers_) update(l);
  std::vector<SpriteCloud> keep;
  std::vector<CloudLayerRecipe> keep_layer;
  for (std::size_t k = 0; k < clouds_.size(); ++k)
    if (!(clouds_[k].fade_to == 0 && clouds_[k].opacity == 0)) {
      keep.push_back(std::move(clouds_[k]));
      keep_layer.push_back(layer_of_cloud_[k]);
    }
  clouds_ = std::move(keep);
  layer_of_cloud_ = std::move(keep_layer);
  std::erase_if(layers_, [](const FlatLayer& l) { return l.fade_to == 0 && l.opacity == 0; });
}

std::size_t CloudField::sprite_count() const {
  std::size_t n = 0;
  for (const auto& c : clouds_) n += c.sprites.size();
  return n;
}

double CloudField::lod_weight(double distance_m, double single_sprite_distance_m) {
  if (!(single_sprite_distance_m > 0)) return 0.0;
  constexpr double band = 0.05;  // half-width of the cross-dissolve, as a fraction of the distance
  return std::clamp((distance_m / single_sprite_distance_m - (1 - band)) / (2 * band), 0.0, 1.0);
}

std::size_t CloudField::sprites_to_draw(const SpriteCloud& c, double distance_m, double single_sprite_distance_m) {
  const double w = lod_weight(distance_m, single_sprite_distance_m);
  return (w > 0 ? 1 : 0) + (w < 1 ? c.sprites.size() : 0);
}

}  // namespace nephos::realtime
