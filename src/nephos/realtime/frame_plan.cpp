#include "nephos/realtime/frame_plan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "nephos/core/error.hpp"
#include "nephos/realtime/sprite_textures.hpp"

namespace nephos::realtime {

SpriteTrim sprite_trim(const std::uint8_t* rgba, int size) {
  // A bilinear fetch at p is non-zero only if a non-zero texel centre q lies within one texel
  // pitch of p along each axis: |p.x| < |q.x| + pitch, |p.x| + |p.y| < |q.x| + |q.y| + 2 pitch.
  const double pitch = 2.0 / size;  // quad corners at -1 and 1
  double a = -1, b = -1, c = -1;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      if (rgba[(static_cast<std::size_t>(y) * size + x) * 4 + 3] == 0) continue;
      const double u = std::abs((x + 0.5) * pitch - 1), v = std::abs((y + 0.5) * pitch - 1);
      a = std::max(a, u), b = std::max(b, v), c = std::max(c, u + v);
    }
  if (a < 0) return {0, 0, 0};  // transparent: nothing to draw
  return {static_cast<float>(std::min(a + pitch, 1.0)), static_cast<float>(std::min(b + pitch, 1.0)),
          static_cast<float>(std::min(c + 2 * pitch, 2.0))};
}

ColumnSpans column_spans(const std::uint8_t* rgba, bool& any) {
  ColumnSpans spans{};
  constexpr int column = impostor_size / ring_columns;
  any = false;
  for (int c = 0; c < ring_columns; ++c) {
    int lo = impostor_size, hi = -1;
    const int x0 = std::max(0, c * column - 1), x1 = std::min(impostor_size, (c + 1) * column + 1);
    for (int y = 0; y < impostor_size; ++y) {
      const std::uint8_t* row = rgba + 4 * static_cast<std::size_t>(y) * impostor_size;
      for (int x = x0; x < x1; ++x)
        if (row[4 * x + 3] != 0) {
          lo = std::min(lo, y), hi = y;
          break;
        }
    }
    if (hi < lo) continue;
    any = true;
    // Texel row r spans quad y 2 r / size - 1 .. 2 (r + 1) / size - 1; the bilinear reach adds
    // half a texel each way, and another half keeps clear of the rounding of interpolation.
    auto quad_y = [](double row) { return static_cast<float>(std::clamp(2 * row / impostor_size - 1, -1.0, 1.0)); };
    spans[static_cast<std::size_t>(c)] = {quad_y(lo - 1), quad_y(hi + 2)};
  }
  return spans;
}

namespace {

constexpr std::uint32_t lod_index = 0xfffff;  // sprite index of a cloud's LOD sprite (facing-lock key)

std::uint64_t cloud_key(const SpriteCloud& c) { return (static_cast<std::uint64_t>(c.id) << 32) | c.relocations; }

// Radius of the sphere a sprite's billboard stays inside whichever way it faces [m].
double sprite_radius(const Sprite& s) { return 0.5 * M_SQRT2 * s.size_m; }

// Shading of one sprite (MSFS 2004): five colour levels by height within the cloud (dark base,
// white top) times a time-of-day ambient factor, plus a directional term per shading group; the
// bent-normal diffuse term (thesis B.7) is added per fragment.
struct Shade {
  glm::dvec3 colour, diffuse;
};
Shade shade_sprite(const SpriteCloud& cloud, const Sprite& sprite, const SunLight& sun) {
  static const glm::dvec3 levels[5] = {
      {0.45, 0.48, 0.55}, {0.58, 0.61, 0.67}, {0.72, 0.74, 0.78}, {0.86, 0.87, 0.89}, {0.97, 0.97, 0.98}};
  const double ambient = 0.35 + 0.65 * std::clamp(sun.elevation_deg / 30.0, 0.0, 1.0);
  const double h = std::clamp((sprite.offset.z + 300.0) / 1500.0, 0.0, 0.999) * 4;
  const int lo = static_cast<int>(h);
  const glm::dvec3 level = levels[lo] + (h - lo) * (levels[std::min(lo + 1, 4)] - levels[lo]);
  const glm::dvec3 g = glm::dvec3(sprite.offset - cloud.group_centres[static_cast<std::size_t>(sprite.shading_group)]);
  const double dir = glm::length(g) > 1e-6 ? std::max(0.0, glm::dot(glm::normalize(g), sun.direction)) : 0.0;
  return {glm::min(glm::dvec3(1.0), 0.85 * ambient * level + 0.3 * dir * sun.colour), 0.25 * sun.colour};
}

void push_instance(std::vector<float>& b, const glm::dvec3& rel, double size, const glm::dvec3& colour, double alpha,
                   double layer, double tiles, const glm::dvec3& diffuse, const glm::dvec3& facing, double aspect) {
  const float v[instance_floats] = {
      static_cast<float>(rel.x),     static_cast<float>(rel.y),     static_cast<float>(rel.z),
      static_cast<float>(size),      static_cast<float>(colour.r),  static_cast<float>(colour.g),
      static_cast<float>(colour.b),  static_cast<float>(alpha),     static_cast<float>(layer),
      static_cast<float>(tiles),     static_cast<float>(diffuse.r), static_cast<float>(diffuse.g),
      static_cast<float>(diffuse.b), static_cast<float>(facing.x),  static_cast<float>(facing.y),
      static_cast<float>(facing.z),  static_cast<float>(aspect)};
  b.insert(b.end(), v, v + instance_floats);
}

double sprite_layer(const SpriteCloud& c, const Sprite& s) {
  return (c.type == SpriteCloudType::cumulus ? 0 : sprite_views_per_type) + s.texture_layer % sprite_views_per_type;
}

// Vertical half-angle of an impostor: clouds up to max_vertical_offset above or below, seen
// from the ring's radius.
double impostor_half_height(const ImpostorRing& ring) { return std::atan(ring.max_vertical_offset_m / ring.radius_m); }

// A sphere of radius r [m] at p seen from a ring centred at `centre`: its horizontal direction
// and angular radius [rad].
struct Bearing {
  double angle, reach;
};
Bearing bearing(const glm::dvec3& p, double r, const glm::dvec3& centre) {
  const glm::dvec2 d{p.x - centre.x, p.y - centre.y};
  return {std::atan2(d.y, d.x), std::asin(std::min(1.0, r / std::max(glm::length(d), 1.0)))};
}
// Whether the sphere may show in impostor sector `sector` (0 = east, CCW): its direction within
// the sector's 45 degrees widened by its angular radius.
bool overlaps_sector(const Bearing& b, int sector) {
  double off = std::fmod(std::abs(b.angle - sector * M_PI / 4), 2 * M_PI);
  off = std::min(off, 2 * M_PI - off);  // angle to the sector's axis
  return off <= M_PI / 8 + b.reach;
}
bool overlaps_sector(const glm::dvec3& p, double r, const glm::dvec3& centre, int sector) {
  return overlaps_sector(bearing(p, r, centre), sector);
}

// The frustum of a `width` x `height` image from `cam`.
Frustum screen_frustum(const Camera& cam, const SunLight& sun, int width, int height) {
  Frustum t;
  t.camera = cam;
  t.tan_y_high = std::tan(0.5 * cam.fov_deg * M_PI / 180);
  t.tan_y_low = -t.tan_y_high;
  t.tan_half_x = t.tan_y_high * width / height;
  t.sun = sun.direction;
  return t;
}

}  // namespace

void FramePlanner::set_impostor_radius(double radius_m) {
  if (!(radius_m > 0)) throw ValueError("the impostor ring radius must be > 0 m", {.key = "impostor_radius_m"});
  ring_.radius_m = radius_m;
  ring_.valid = false;
}

void FramePlanner::set_single_sprite_distance(double distance_m) {
  if (!(distance_m >= 0))
    throw ValueError("the single-sprite distance must be >= 0 m (0: off)", {.key = "single_sprite_distance_m"});
  single_sprite_distance_m_ = distance_m;
}

void FramePlanner::set_impostor_sprites_per_frame(std::size_t sprites) {
  if (sprites < 1)
    throw ValueError("the impostors' sprites per frame must be >= 1", {.key = "impostor_sprites_per_frame"});
  impostor_sprite_budget_ = sprites;
}

// The sprites an impostor set holds, and the vertical extent of its images. MSFS 2004 "renders
// only the sections beyond the radius into impostors"; nephos decides per sprite, so a cloud
// across the ring has its far sprites in the impostor and its near ones drawn as sprites (in
// front, being nearer). MSFS moves the impostors up or down to where the clouds are; nephos
// fits an off-centre frustum to them per sector (within the +-10,000 ft rule's angle), so
// their texels and fill cover clouds, not sky. In an impostor a sprite is a billboard parallel
// to the image plane, at its centre's depth along the sector's axis, so the tangents of its
// bottom and top edges are exact: (z -+ size / 2) / depth.
void FramePlanner::capture(int set, const glm::dvec3& centre, const CloudField& field, const Band& band) {
  band_[set] = band;
  std::vector<SpriteKey> keys;
  std::array<double, 8> lo, hi;
  lo.fill(1e9), hi.fill(-1e9);
  // Forming clouds (relocated ahead, or new weather) go in at the opacity they have when their
  // sector is rendered and keep it until the ring is made again (MSFS 2004: an impostor stands
  // for its clouds as they were); dissipating ones stay sprites, so that they go.
  for (const auto& c : field.clouds()) {
    if (c.fade_to != 1 || !(c.opacity > 0)) continue;
    for (std::uint32_t k = 0; k < c.sprites.size(); ++k) {
      const Sprite& sp = c.sprites[k];
      const glm::dvec3 p = c.centre + glm::dvec3(sp.offset);
      const double r = sprite_radius(sp);
      if (!ring_.in_impostor(p, r, centre) || !band.contains(p.z)) continue;
      keys.push_back({cloud_key(c), k});
      const Bearing b = bearing(p, r, centre);  // once, not per sector
      for (std::size_t s = 0; s < 8; ++s) {
        const int sector = static_cast<int>(s);
        if (!overlaps_sector(b, sector)) continue;
        const double a = sector * M_PI / 4;
        const double depth = (p.x - centre.x) * std::cos(a) + (p.y - centre.y) * std::sin(a);  // > 0.9 radius
        lo[s] = std::min(lo[s], (p.z - 0.5 * sp.size_m - centre.z) / depth);
        hi[s] = std::max(hi[s], (p.z + 0.5 * sp.size_m - centre.z) / depth);
      }
    }
  }
  std::sort(keys.begin(), keys.end());
  captured_[set] = std::move(keys);
  // A margin of 0.02 (a few texels) keeps the bilinear footprint of the edge texels inside.
  const double limit = std::tan(impostor_half_height(ring_));
  for (std::size_t s = 0; s < 8; ++s) {
    tan_low_[set][s] = hi[s] > lo[s] ? std::max(-limit, lo[s] - 0.02) : -limit;
    tan_high_[set][s] = hi[s] > lo[s] ? std::min(limit, hi[s] + 0.02) : limit;
  }
}

namespace {
// The sprites of cloud `c` an impostor set holds: one flag per sprite, by a merge against the
// set's sorted keys (the cloud's keys are contiguous there). Returns whether any is held.
template <class Key>
bool captured_sprites(const std::vector<Key>& set, const SpriteCloud& c, std::vector<char>& held) {
  held.assign(c.sprites.size(), 0);
  const std::uint64_t key = cloud_key(c);
  bool any = false;
  for (auto it = std::lower_bound(set.begin(), set.end(), Key{key, 0}); it != set.end() && it->cloud == key; ++it)
    if (it->sprite < held.size()) held[it->sprite] = 1, any = true;
  return any;
}
}  // namespace

void FramePlanner::begin_impostor(int set, int sector, const glm::dvec3& centre, const CloudField& field,
                                  const SunLight& sun) {
  // The captured sprites that overlap this 45-degree sector, back to front from the ring centre,
  // shaded now: the parts drawn in later frames show the clouds as they were at this frame (the
  // clouds drift with the air, as the ring's centre does, so their offsets from it hold).
  std::vector<glm::dvec3> pos;
  std::vector<std::pair<const SpriteCloud*, const Sprite*>> items;
  std::vector<char> held;
  for (const auto& c : field.clouds()) {
    if (!captured_sprites(captured_[set], c, held) || !overlaps_sector(c.centre, c.radius_m, centre, sector)) continue;
    for (std::size_t k = 0; k < c.sprites.size(); ++k) {
      const glm::dvec3 p = c.centre + glm::dvec3(c.sprites[k].offset);
      if (!held[k] || !overlaps_sector(p, sprite_radius(c.sprites[k]), centre, sector)) continue;
      pos.push_back(p);
      items.push_back({&c, &c.sprites[k]});
    }
  }
  const auto order = back_to_front(pos, centre);
  sector_instances_.clear();
  for (std::size_t k : order) {
    const Shade sh = shade_sprite(*items[k].first, *items[k].second, sun);
    push_instance(sector_instances_, pos[k] - centre, items[k].second->size_m, sh.colour, items[k].first->opacity,
                  sprite_layer(*items[k].first, *items[k].second), 0.0, sh.diffuse, glm::dvec3(0.0), 1.0);
  }
  sector_drawn_ = 0;
}

std::size_t FramePlanner::continue_impostor(int set, int sector, std::size_t budget, const Camera& cam,
                                            const SunLight& sun, ImpostorCanvas& canvas, bool& complete) {
  const std::size_t total = sector_instances_.size() / instance_floats;
  const std::size_t count = std::min(budget, total - sector_drawn_);
  if (count > 0) {
    // Each part blends over the parts before it in the scratch image, which keeps what they
    // drew between frames: the image is the one a single draw of every sprite would give. The
    // frustum looks along the sector's axis from the ring centre, the instances' origin.
    const double a = sector * M_PI / 4;  // 0 = east, counter-clockwise (ImpostorRing::sector)
    Frustum f;
    f.camera.position = glm::dvec3(0.0);
    f.camera.forward = {std::cos(a), std::sin(a), 0};
    f.camera.up = {0, 0, 1};
    f.camera.far_m = cam.far_m;
    f.tan_half_x = std::tan(M_PI / 8);
    f.tan_y_low = tan_low_[set][static_cast<std::size_t>(sector)];
    f.tan_y_high = tan_high_[set][static_cast<std::size_t>(sector)];
    f.sun = sun.direction;
    canvas.render(f, sector_instances_.data() + instance_floats * sector_drawn_, count, sector_drawn_ == 0);
    sector_drawn_ += count;
  }
  complete = sector_drawn_ == total;
  if (!complete) return count;
  auto& spans = spans_[set][static_cast<std::size_t>(sector)];
  spans.fill({});
  sector_empty_[set][static_cast<std::size_t>(sector)] = true;
  if (total == 0) return count;
  bool any = false;
  spans = canvas.store(set, sector, any);
  sector_empty_[set][static_cast<std::size_t>(sector)] = !any;
  return count;
}

double FramePlanner::ring_upkeep(const CloudField& field, const Camera& cam, const SunLight& sun, bool impostors,
                                 const Band& band, ImpostorCanvas& canvas, FrameStats& stats) {
  // The impostor ring lives in the frame of the (drifting) air, like the clouds it holds: its
  // centre and the re-render thresholds are measured there, and its quads drift with the wind.
  const glm::dvec3 air(field.drift_offset_m(), 0.0), cam_air = cam.position - air;
  double back_weight = 0;  // crossfade weight of the back set
  if (impostors && ring_.valid && band_[front_] != band) {
    // The camera crossed a flat layer (or one formed or went): the sprites the impostors hold
    // are no longer those it may draw after the layers; all eight are made again now.
    ring_.valid = false;
  }
  if (!impostors) {
    if (ring_.valid) ++generation_;
    ring_.valid = false;
    next_sector_ = crossfade_ = -1;
    return 0;
  }
  if (!ring_.valid) {
    // The first frame, a new radius or a flat layer crossed: the whole front set at once; a set
    // being built for the old ring is dropped.
    next_sector_ = crossfade_ = -1;
    capture(front_, cam.position, field, band);
    for (int k = 0; k < 8; ++k) {
      begin_impostor(front_, k, cam.position, field, sun);
      bool complete = false;
      stats.impostor_sprites += continue_impostor(front_, k, SIZE_MAX, cam, sun, canvas, complete);
    }
    stats.impostor_updates = 8;
    ring_.rebuilt_at(cam_air);
    ++generation_;
    return 0;
  }
  const int back = 1 - front_;
  if (next_sector_ < 0 && crossfade_ < 0 && ring_.needs_update(cam_air)) {
    back_centre_ = cam_air;
    capture(back, cam.position, field, band);
    next_sector_ = 0;
    sector_begun_ = false;
  }
  if (next_sector_ >= 0) {
    // The new set's sprites go into its impostors a budget of them per frame (MSFS 2004's
    // software path: "one 16-square-kilometer cloud block per frame"), a sector ahead full of
    // clouds over several frames, a few nearly empty ones in one.
    std::size_t budget = impostor_sprite_budget_;
    while (next_sector_ >= 0) {
      if (!sector_begun_) {
        begin_impostor(back, next_sector_, back_centre_ + air, field, sun);
        sector_begun_ = true;
      }
      bool complete = false;
      const std::size_t drawn = continue_impostor(back, next_sector_, budget, cam, sun, canvas, complete);
      ++stats.impostor_updates;
      stats.impostor_sprites += drawn;
      budget -= drawn;
      if (!complete) break;
      sector_begun_ = false;
      if (++next_sector_ == 8) next_sector_ = -1, crossfade_ = 0;
      if (budget == 0) break;
    }
  } else if (crossfade_ >= 0) {
    back_weight = (crossfade_ + 1.0) / (crossfade_frames + 1.0);  // 1 / (N + 1) ... N / (N + 1)
    ++generation_;
    if (++crossfade_ > crossfade_frames) {  // the new set takes over
      front_ = back;
      ring_.rebuilt_at(back_centre_);
      crossfade_ = -1;
      back_weight = 0;
    }
  }
  return back_weight;
}

// Each impostor is a quad on its sector's image plane at the ring radius, facing the ring's
// centre, so that from the centre it shows exactly what was rendered into it; it is drawn over
// the columns of its texture that hold clouds (options.trim_ring), two triangles each from the
// column's left to its right edge. At an edge shared by two columns the bottom is the lower and
// the top the higher of their spans, the same two vertices for both, so the columns meet
// without cracks or overlaps, and each column's trapezoid contains its span.
void FramePlanner::ring_triangles(FramePlan& plan, const glm::dvec3& air, double back_weight) const {
  const Camera& cam = plan.screen.camera;
  const double w = 2 * ring_.radius_m * std::tan(M_PI / 8);
  double ring_area = 0, quad_area = 0;  // in quad units (4 per impostor)
  std::vector<float> quad;              // one impostor's instance floats
  for (int which = 0; which < 2; ++which) {
    const double weight = which == 0 ? 1 - back_weight : back_weight;
    if (weight <= 0) continue;
    const int set = which == 0 ? front_ : 1 - front_;
    const glm::dvec3 centre = which == 0 ? ring_.centre : back_centre_;
    const std::size_t before = plan.ring_vertices.size();
    for (int k = 0; k < 8; ++k) {
      const auto s = static_cast<std::size_t>(k);
      if (sector_empty_[set][s]) continue;  // no fill for empty sky
      const double aspect = (tan_high_[set][s] - tan_low_[set][s]) / (2 * std::tan(M_PI / 8));
      const double lift = 0.5 * (tan_high_[set][s] + tan_low_[set][s]) * ring_.radius_m;
      const double a = k * M_PI / 4;
      const glm::dvec3 d{std::cos(a), std::sin(a), 0};
      quad.clear();
      push_instance(quad, centre + air + ring_.radius_m * d + glm::dvec3{0, 0, lift} - cam.position, w, glm::dvec3(1.0),
                    weight, k, -1.0, glm::dvec3(0.0), d, aspect);
      auto vertex = [&](float x, float y) {
        plan.ring_vertices.insert(plan.ring_vertices.end(), {x, y, 0.0f});
        plan.ring_vertices.insert(plan.ring_vertices.end(), quad.begin(), quad.end());
      };
      auto trapezoid = [&](float x0, float x1, float b0, float top0, float b1, float top1) {
        vertex(x0, b0), vertex(x1, b1), vertex(x0, top0);
        vertex(x0, top0), vertex(x1, b1), vertex(x1, top1);
        ring_area += 0.5 * ((top0 - b0) + (top1 - b1)) * (x1 - x0);
      };
      quad_area += 4;
      if (!options.trim_ring) {
        trapezoid(-1, 1, -1, 1, -1, 1);
        continue;
      }
      const auto& spans = spans_[set][s];
      // Bottom and top at the edge between columns c - 1 and c (c = 0 .. ring_columns).
      auto edge = [&](int c) {
        ColumnSpan e;
        for (int n : {c - 1, c})
          if (n >= 0 && n < ring_columns &&
              spans[static_cast<std::size_t>(n)].bottom <= spans[static_cast<std::size_t>(n)].top)
            e.bottom = std::min(e.bottom, spans[static_cast<std::size_t>(n)].bottom),
            e.top = std::max(e.top, spans[static_cast<std::size_t>(n)].top);
        return e;
      };
      for (int c = 0; c < ring_columns; ++c) {
        const ColumnSpan& span = spans[static_cast<std::size_t>(c)];
        if (span.bottom > span.top) continue;  // no clouds in this column
        const ColumnSpan e0 = edge(c), e1 = edge(c + 1);
        const float x0 = 2.0f * static_cast<float>(c) / ring_columns - 1,
                    x1 = 2.0f * static_cast<float>(c + 1) / ring_columns - 1;
        trapezoid(x0, x1, e0.bottom, e0.top, e1.bottom, e1.top);
      }
    }
    plan.ring_vertex_count[which] = (plan.ring_vertices.size() - before) / ring_vertex_floats;
  }
  plan.stats.ring_coverage = quad_area > 0 ? ring_area / quad_area : 0.0;
}

// Flat layers (altostratus, cirrus, fog), farthest altitude first: wide horizontal sheets
// centred under/over the camera, drawn behind the sprite clouds. Two layers of one type next to
// each other on the same side of the camera are one quad, the nearer sheet's, whose shader
// composites the farther sheet behind it (LAYER_PAIR): a frame on a software rasteriser costs
// its fill, and an overcast deck of two altostratus sheets would otherwise fill the upper half
// of the frame twice. Layers above and below the camera cover disjoint parts of the frame, so
// only the order within a side matters.
void FramePlanner::plan_layers(FramePlan& plan, const CloudField& field, const Camera& cam, const SunLight& sun,
                               const glm::dvec3& cam_air, int height) const {
  const double ambient = 0.35 + 0.65 * std::clamp(sun.elevation_deg / 30.0, 0.0, 1.0);
  // A layer's texture holds its slab's radiance (relative to the light falling on it) and
  // opacity, seen from the camera's side (sprite_textures.hpp); the light is the sprites'
  // time-of-day ambient plus a sun term, the opacity is scaled by the layer's formation fade.
  struct LayerStyle {
    glm::dvec3 light;
    double alpha, tile_m;
    int type;  // slab type: altostratus, cirrus, low stratus
  };
  auto style = [&](const FlatLayer& l) {
    const int type = l.type == SpriteCloudType::cirrus ? 1 : l.type == SpriteCloudType::low_stratus ? 2 : 0;
    const glm::dvec3 light = glm::min(glm::dvec3(1.0), ambient + 0.15 * std::max(0.0, sun.direction.z) * sun.colour);
    return LayerStyle{light, double{l.opacity}, type == 1 ? 6000.0 : 3000.0, type};
  };
  // Whether a ray of the frame comes within 45 degrees (plus a margin) of the nadir or the
  // zenith: only then does a layer on that side show its vertical view (its shader's weight of
  // the 45-degree view is 1 for every ray further from the vertical). The frustum's extreme
  // elevations lie on its boundary; it is sampled densely, with a degree to spare.
  bool steep_view[2] = {false, false};  // below, above
  {
    const Frustum& t = plan.screen;
    const glm::dvec3 f = glm::normalize(cam.forward), r = glm::normalize(glm::cross(f, cam.up)), u = glm::cross(r, f);
    const double limit = std::sin(44.0 * M_PI / 180);
    for (int k = 0; k < 4 * 64; ++k) {
      const double e = (k % 64) / 63.0 * 2 - 1;  // along an edge
      const double x = k < 64 ? e : k < 128 ? -e : k < 192 ? -1 : 1, y = k < 64 ? 1 : k < 128 ? -1 : e;
      const glm::dvec3 d = glm::normalize(
          f + x * t.tan_half_x * r + (0.5 * (t.tan_y_high + t.tan_y_low) + 0.5 * y * (t.tan_y_high - t.tan_y_low)) * u);
      steep_view[0] = steep_view[0] || d.z < -limit;
      steep_view[1] = steep_view[1] || d.z > limit;
    }
  }
  bool first_layer_above = false;  // the first layer drawn is above the camera
  using LayerViews = RenderOptions::LayerViews;
  for (const bool above : {true, false}) {
    std::vector<const FlatLayer*> side;
    for (const auto& l : field.layers())
      if ((l.altitude_m > cam.position.z) == above) side.push_back(&l);
    std::sort(side.begin(), side.end(), [&](const FlatLayer* a, const FlatLayer* b) {
      return std::abs(a->altitude_m - cam.position.z) > std::abs(b->altitude_m - cam.position.z);
    });
    for (std::size_t i = 0; i < side.size(); ++i) {
      const FlatLayer* l = side[i];
      const FlatLayer* behind = nullptr;  // the farther layer of a pair
      const double dh = l->altitude_m - cam.position.z;
      // A pair needs equal extents: the shader masks the farther sheet at k times the nearer
      // one's half-width.
      if (options.merge_flat_layers && i + 1 < side.size() && side[i + 1]->type == l->type &&
          side[i + 1]->extent_m == l->extent_m) {
        const double dh_near = side[i + 1]->altitude_m - cam.position.z;
        // Ratio of heights above the camera; a nearer sheet almost edge-on (more than 64 times
        // closer to the camera's altitude) is drawn alone, to keep the float texture coordinates.
        if (std::abs(dh) <= 64 * std::abs(dh_near)) behind = l, l = side[++i];
      }
      const LayerStyle st = style(*l);
      const double size = 2 * l->extent_m;
      // The sheet is centred on the camera but its pattern belongs to the air: the texture is
      // offset by where the camera is relative to the drifting air (in tiles; texture v runs
      // south), so that flying under a layer moves its pattern past, as it moves sprite clouds.
      const double u = cam_air.x / st.tile_m, v = -cam_air.y / st.tile_m;
      const double far_alpha = behind ? style(*behind).alpha : 0.0;
      const double far_ratio = behind ? (behind->altitude_m - cam.position.z) / (l->altitude_m - cam.position.z) : 0.0;
      // Distance fade (fragment shader): a pixel's footprint along the view on a sheet dh below
      // or above the camera, at horizontal distance D, is D^2 theta / |dh| (theta: the pixel's
      // angle) or D_tiles^2 tile_m theta / |dh| in tiles; in texels times sprite_texture_size.
      // The texel fades to the mean from fade_from to fade_to texels per pixel: fade =
      // D_tiles^2 scale - offset.
      constexpr double fade_from = 1, fade_to = 4;
      const double theta = 2 * std::tan(0.5 * cam.fov_deg * M_PI / 180) / height;
      const double scale = st.tile_m * sprite_texture_size * theta /
                           (std::max(std::abs(l->altitude_m - cam.position.z), 1.0) * (fade_to - fade_from));
      // The slab seen from below (the camera under the layer) or from above.
      const int layer = first_slab_layer + 2 * st.type + (above ? 0 : 1);
      push_instance(plan.instances, {0, 0, l->altitude_m - cam.position.z}, size, st.light, st.alpha, layer,
                    size / st.tile_m, {u - std::floor(u), v - std::floor(v), far_alpha},
                    {far_ratio, scale, fade_from / (fade_to - fade_from)}, 1.0);
      const bool slant = options.layer_views == LayerViews::slant ||
                         (options.layer_views == LayerViews::automatic && !steep_view[above ? 1 : 0]);
      const Shading shading = behind ? (slant ? Shading::layer_pair_slant : Shading::layer_pair)
                                     : (slant ? Shading::sheet_slant : Shading::sheet);
      if (plan.layer_runs.empty()) first_layer_above = above;
      if (plan.layer_runs.empty() || plan.layer_runs.back().first != shading) plan.layer_runs.push_back({shading, 0});
      ++plan.layer_runs.back().second;
    }
  }
  // Whether the first layer lies over nothing but the uniform sky: plan_sprites() clears this
  // if sprites beyond it were drawn on its side of the horizon.
  plan.first_over_sky = options.first_layer_over_sky && !plan.layer_runs.empty();
  plan.first_layer_above = first_layer_above;
}

// Sprites not in an impostor; during a crossfade a sprite in only one set is also drawn as a
// sprite, fading against that set. Back to front, those beyond a flat layer first.
void FramePlanner::plan_sprites(FramePlan& plan, const CloudField& field, const Camera& cam, const SunLight& sun,
                                bool sort, bool impostors, const Band& band, double back_weight) {
  const bool fading_sets = back_weight > 0;
  const int back = 1 - front_;
  std::vector<glm::dvec3> pos;
  struct Item {
    const SpriteCloud* cloud;
    const Sprite* sprite;
    std::uint32_t index;
    double alpha;
  };
  std::vector<Item> items;
  std::uint64_t lod_signature = 0;  // which clouds draw their LOD sprite, and which also their sprites
  std::vector<char> in_front, in_back;
  for (const auto& c : field.clouds()) {
    if (c.opacity <= 0) continue;
    bool held = false;  // some of its sprites are in an impostor set
    if (impostors && ring_.valid) {
      held = captured_sprites(captured_[front_], c, in_front);
      if (fading_sets) held = captured_sprites(captured_[back], c, in_back) || held;
    }
    // Opacity of sprite k drawn as a sprite: zero while an impostor set shows it alone; during a
    // crossfade a sprite in only one set fades against that set.
    auto alpha_of = [&](std::size_t k) {
      if (!held) return double{c.opacity};
      const bool f = in_front[k];
      if (!fading_sets) return f ? 0.0 : double{c.opacity};
      const bool b = in_back[k];
      if (f && b) return 0.0;
      return c.opacity * (f ? back_weight : 1.0) * (b ? 1 - back_weight : 1.0);
    };
    // Level of detail: across its distance the cloud's one sprite and its sprites cross-dissolve
    // (CloudField::lod_weight), so that a cloud does not change at once from one to the other.
    const double w_lod =
        held ? 0.0 : CloudField::lod_weight(glm::length(c.centre - cam.position), single_sprite_distance_m_);
    if (w_lod > 0) {
      pos.push_back(c.centre + glm::dvec3(c.lod.offset));
      items.push_back({&c, &c.lod, lod_index, c.opacity * w_lod});
      lod_signature += (static_cast<std::uint64_t>(c.id) + 1) * 0x9e3779b97f4a7c15ull;
      if (w_lod >= 1) continue;
      lod_signature += (static_cast<std::uint64_t>(c.id) + 1) * 0xc2b2ae3d27d4eb4full;  // and its sprites
    }
    for (std::uint32_t k = 0; k < c.sprites.size(); ++k) {
      const double alpha = alpha_of(k) * (1 - w_lod);
      if (alpha <= 0) continue;
      pos.push_back(c.centre + glm::dvec3(c.sprites[k].offset));
      items.push_back({&c, &c.sprites[k], k, alpha});
    }
  }
  if (lod_signature != lod_signature_) ++generation_, lod_signature_ = lod_signature;
  if (sort || order_.size() != items.size() || order_generation_ != generation_) {
    order_ = back_to_front(pos, cam.position);
    order_generation_ = generation_;
  }
  // Facing lock (MSFS 2004): a sprite the camera is within half its radius of keeps the
  // orientation it had when the camera came that close, instead of spinning around the camera.
  std::unordered_map<std::uint64_t, glm::vec3> locked;
  const glm::dvec3 front = glm::normalize(cam.forward);
  plan.first_sprite = plan.instances.size() / instance_floats;
  bool beyond_on_side[2] = {false, false};  // below, above the camera
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t k : order_) {
      if (band.contains(pos[k].z) == (pass == 0)) continue;
      if (pass == 0) ++plan.beyond, beyond_on_side[pos[k].z > cam.position.z] = true;
      const Item& it = items[k];
      const Shade sh = shade_sprite(*it.cloud, *it.sprite, sun);
      const glm::dvec3 rel = pos[k] - cam.position;
      glm::dvec3 facing(0.0);
      if (glm::length(rel) < 0.25 * it.sprite->size_m) {
        const std::uint64_t key = (static_cast<std::uint64_t>(it.cloud->id) << 20) | it.index;
        const auto old = locked_.find(key);
        const glm::vec3 f = old != locked_.end() ? old->second : glm::vec3(front);
        locked.emplace(key, f);
        facing = glm::dvec3(f);
      }
      push_instance(plan.instances, rel, it.sprite->size_m, sh.colour, it.alpha, sprite_layer(*it.cloud, *it.sprite),
                    0.0, sh.diffuse, facing, 1.0);
    }
  locked_ = std::move(locked);
  plan.stats.locked_sprites = locked_.size();
  plan.stats.sprites = items.size();
  // The first flat layer is over the sky only if no sprite beyond it was drawn on its side.
  if (beyond_on_side[plan.first_layer_above ? 1 : 0]) plan.first_over_sky = false;
}

FramePlan FramePlanner::plan(const CloudField& field, const Camera& cam, const SunLight& sun, bool sort, bool impostors,
                             int width, int height, ImpostorCanvas& canvas) {
  FramePlan plan;
  // The camera's band: between the nearest flat layers below and above it. A sprite beyond one
  // of them is hidden by it wherever the layer covers it (every ray from the camera to the
  // sprite crosses the layer's plane), so it is drawn before the flat layers, and it stays out
  // of the impostors, which are drawn after them.
  Band band{-1e300, 1e300};
  for (const auto& l : field.layers()) {
    if (!(l.opacity > 0)) continue;
    if (l.altitude_m > cam.position.z)
      band.hi = std::min(band.hi, l.altitude_m);
    else
      band.lo = std::max(band.lo, l.altitude_m);
  }
  const double back_weight = ring_upkeep(field, cam, sun, impostors, band, canvas, plan.stats);
  plan.front = front_, plan.back = 1 - front_;
  plan.screen = screen_frustum(cam, sun, width, height);
  const glm::dvec3 air(field.drift_offset_m(), 0.0);
  if (impostors && ring_.valid) ring_triangles(plan, air, back_weight);
  plan_layers(plan, field, cam, sun, cam.position - air, height);
  plan_sprites(plan, field, cam, sun, sort, impostors, band, back_weight);
  return plan;
}

}  // namespace nephos::realtime
