#include "nephos/realtime/frame_plan.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "nephos/core/error.hpp"
#include "nephos/realtime/sprite_textures.hpp"

namespace nephos::realtime {
namespace {

// An impostor canvas without a GPU: records what the planner asks for and reports every
// stored image as holding clouds in every column (a span of the whole quad).
struct RecordingCanvas final : ImpostorCanvas {
  struct Render {
    std::size_t count;
    bool clear;
    Frustum frustum;
  };
  std::vector<Render> renders;
  std::vector<std::pair<int, int>> stores;  // (set, sector)
  void render(const Frustum& f, const float*, std::size_t count, bool clear) override {
    renders.push_back({count, clear, f});
  }
  ColumnSpans store(int set, int sector, bool& any) override {
    stores.push_back({set, sector});
    ColumnSpans s;
    s.fill({-1, 1});
    any = true;
    return s;
  }
};

constexpr std::size_t alpha_at = 7, layer_at = 8;  // an instance's alpha and texture layer

const SunLight& noon() {
  static const SunLight s = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  return s;
}

Camera looking_east(const glm::dvec3& at) { return Camera{at, {1, 0, -0.1}, {0, 0, 1}, 60}; }

// The distance from the camera of instance i (positions are relative to the camera).
double distance(const FramePlan& p, std::size_t i) {
  const float* v = p.instances.data() + i * instance_floats;
  return std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
}

}  // namespace

TEST(FramePlan, SpritesBackToFrontWithoutImpostors) {
  // Every sprite of the field drawn once as an instance, at full opacity (formed clouds), in
  // non-increasing distance from the camera within each of the two passes (beyond a layer, then
  // the camera's band). Fault caught: a wrong sort direction or a sprite drawn twice or not at all.
  const CloudField field(recipe_from_code(parse_weather_code("d200")), 3, {0, 0, 2400});
  FramePlanner planner;
  RecordingCanvas canvas;
  const FramePlan p = planner.plan(field, looking_east({0, 0, 2400}), noon(), true, false, 320, 180, canvas);
  EXPECT_TRUE(canvas.renders.empty());
  EXPECT_EQ(p.ring_vertex_count[0] + p.ring_vertex_count[1], 0u);
  const std::size_t sprites = p.instances.size() / instance_floats - p.first_sprite;
  EXPECT_EQ(sprites, field.sprite_count());
  EXPECT_EQ(p.stats.sprites, sprites);
  const std::size_t end = p.instances.size() / instance_floats, band = p.first_sprite + p.beyond;
  for (const auto& [from, to] : {std::pair{p.first_sprite, band}, std::pair{band, end}})
    for (std::size_t i = from + 1; i < to; ++i) EXPECT_GE(distance(p, i - 1), distance(p, i) - 1e-3) << i;
  EXPECT_GT(end - band, 100u);
  for (std::size_t i = p.first_sprite; i < p.instances.size() / instance_floats; ++i)
    EXPECT_EQ(p.instances[i * instance_floats + alpha_at], 1.0f) << i;
}

TEST(FramePlan, ImpostorRingUpkeepAndCrossfade) {
  // The ring's life without a GPU. Frame 0 renders all eight sectors at once (each cleared
  // first) and the clouds it holds are no longer sprites. A camera moved by more than 15 % of
  // the radius starts a new set: rendered a budget of sprites per frame, sector by sector,
  // into set 1, then crossfaded over crossfade_frames frames with the back set's weight k/17
  // on its quads and 1 - k/17 on the front's, after which set 1 is the front. Faults caught: a
  // budget overrun, a crossfade weight off, a set never taking over.
  const glm::dvec3 eye0{0, 0, 2400}, eye1{1300, 0, 2400};
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 9, eye0);
  FramePlanner planner;
  planner.set_impostor_sprites_per_frame(64);
  RecordingCanvas canvas;
  const FramePlan first = planner.plan(field, looking_east(eye0), noon(), true, true, 320, 180, canvas);
  EXPECT_EQ(first.stats.impostor_updates, 8);
  ASSERT_FALSE(canvas.stores.empty());
  for (const auto& [set, sector] : canvas.stores) EXPECT_EQ(set, 0);
  for (const auto& r : canvas.renders) EXPECT_TRUE(r.clear);  // whole sectors in one part each
  EXPECT_GT(first.ring_vertex_count[0], 0u);
  EXPECT_EQ(first.ring_vertex_count[1], 0u);
  EXPECT_LT(first.stats.sprites, field.sprite_count());  // the ring holds the far ones

  canvas = {};
  int frames = 0;
  std::size_t rendered = 0;
  FramePlan p;
  do {
    p = planner.plan(field, looking_east(eye1), noon(), true, true, 320, 180, canvas);
    ++frames;
    rendered += p.stats.impostor_sprites;
    EXPECT_LE(p.stats.impostor_sprites, 64u) << "frame " << frames;
    if (p.stats.impostor_updates > 0) {
      EXPECT_EQ(p.ring_vertex_count[1], 0u) << "the back set is not drawn while it is built";
    }
  } while (p.stats.impostor_updates > 0 && frames < 1000);
  EXPECT_GT(frames, 2);
  std::size_t in_canvas = 0;
  for (const auto& r : canvas.renders) in_canvas += r.count;
  EXPECT_EQ(in_canvas, rendered);
  for (const auto& [set, sector] : canvas.stores) EXPECT_EQ(set, 1);
  // p is the first crossfade frame: back weight 1/17, front 16/17 (the quads' alpha).
  for (int k = 1; k <= FramePlanner::crossfade_frames; ++k) {
    if (k > 1) p = planner.plan(field, looking_east(eye1), noon(), true, true, 320, 180, canvas);
    ASSERT_GT(p.ring_vertex_count[1], 0u) << "crossfade frame " << k;
    const float front_alpha = p.ring_vertices[3 + alpha_at];
    const float back_alpha = p.ring_vertices[p.ring_vertex_count[0] * ring_vertex_floats + 3 + alpha_at];
    EXPECT_FLOAT_EQ(back_alpha, static_cast<float>(k / (FramePlanner::crossfade_frames + 1.0))) << k;
    EXPECT_FLOAT_EQ(front_alpha, static_cast<float>(1 - k / (FramePlanner::crossfade_frames + 1.0))) << k;
    EXPECT_EQ(p.front, 0);
  }
  p = planner.plan(field, looking_east(eye1), noon(), true, true, 320, 180, canvas);
  EXPECT_EQ(p.front, 1);  // the new set took over
  EXPECT_GT(p.ring_vertex_count[0], 0u);
  EXPECT_EQ(p.ring_vertex_count[1], 0u);
  EXPECT_THROW(planner.set_impostor_sprites_per_frame(0), ValueError);
}

TEST(FramePlan, FlatLayerPairIsOneInstanceFirstOverTheSky) {
  // d400's altostratus deck is two sheets of one type above the camera: merged, they are one
  // instance of the pair shader, first, drawn over the sky; with merging off, two instances of
  // the single-sheet shader. Faults caught: the pair not merged, the wrong shader, layers after
  // the sprites.
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 9, {0, 0, 2400});
  ASSERT_GE(field.layers().size(), 2u);
  for (const bool merge : {true, false}) {
    FramePlanner planner;
    planner.options.merge_flat_layers = merge;
    RecordingCanvas canvas;
    const FramePlan p = planner.plan(field, looking_east({0, 0, 2400}), noon(), true, false, 320, 180, canvas);
    std::size_t layers = 0;
    for (const auto& [shading, count] : p.layer_runs) {
      layers += count;
      EXPECT_NE(shading, Shading::bent_normal);
      EXPECT_NE(shading, Shading::plain);
      const bool pair = shading == Shading::layer_pair || shading == Shading::layer_pair_slant;
      EXPECT_EQ(pair, merge) << static_cast<int>(shading);
    }
    EXPECT_EQ(p.first_sprite, layers);
    EXPECT_EQ(layers, merge ? field.layers().size() - 1 : field.layers().size());
    EXPECT_TRUE(p.first_over_sky);
    for (std::size_t i = 0; i < layers; ++i)
      EXPECT_GE(p.instances[i * instance_floats + layer_at], static_cast<float>(first_slab_layer));
  }
}

TEST(FramePlan, FacingLockHoldsWhileTheCameraIsInsideASprite) {
  // A sprite the camera comes within a quarter of its size of keeps the facing it had then:
  // the same fixed facing in the next frame though the camera turned. Fault caught: the lock
  // not kept across frames (the sprite would spin around the camera).
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 9, {0, 0, 2400});
  const SpriteCloud& c = field.clouds().front();
  const glm::dvec3 inside = c.centre + glm::dvec3(c.sprites.front().offset);
  FramePlanner planner;
  RecordingCanvas canvas;
  const FramePlan a = planner.plan(field, looking_east(inside), noon(), true, false, 64, 64, canvas);
  ASSERT_GT(a.stats.locked_sprites, 0u);
  Camera turned = looking_east(inside);
  turned.forward = {0, 1, -0.1};
  const FramePlan b = planner.plan(field, turned, noon(), true, false, 64, 64, canvas);
  EXPECT_EQ(b.stats.locked_sprites, a.stats.locked_sprites);
  auto facings = [](const FramePlan& p) {
    std::vector<glm::vec3> f;
    for (std::size_t i = p.first_sprite; i < p.instances.size() / instance_floats; ++i) {
      const float* v = p.instances.data() + i * instance_floats + 13;
      if (v[0] != 0 || v[1] != 0 || v[2] != 0) f.push_back({v[0], v[1], v[2]});
    }
    return f;
  };
  const auto fa = facings(a), fb = facings(b);
  ASSERT_FALSE(fa.empty());
  for (const auto& f : fb) EXPECT_NEAR(f.y, fa.front().y, 1e-6);  // still facing east-ish, not north
}

TEST(FramePlan, ColumnSpansOfAnImage) {
  // One opaque texel at x = 40, row 100 of a 256 x 256 image. Column c (8 texels wide) looks at
  // texels 8c - 1 .. 8c + 8, one beyond each side for the bilinear footprint, so columns 4
  // (31..40) and 5 (39..48) hold it, from row 99 to row 102 in quad y (a texel and a half
  // below, two above). Fault caught: spans off by a texel or in the wrong column.
  std::vector<std::uint8_t> rgba(4 * impostor_size * impostor_size, 0);
  rgba[4 * (100 * impostor_size + 40) + 3] = 255;
  bool any = false;
  const ColumnSpans s = column_spans(rgba.data(), any);
  EXPECT_TRUE(any);
  for (int c = 0; c < ring_columns; ++c) {
    const bool holds = c == 4 || c == 5;
    EXPECT_EQ(s[static_cast<std::size_t>(c)].bottom <= s[static_cast<std::size_t>(c)].top, holds) << c;
  }
  EXPECT_FLOAT_EQ(s[5].bottom, 2.0f * 99 / impostor_size - 1);
  EXPECT_FLOAT_EQ(s[5].top, 2.0f * 102 / impostor_size - 1);
  std::vector<std::uint8_t> clear(rgba.size(), 0);
  column_spans(clear.data(), any);
  EXPECT_FALSE(any);
}

}  // namespace nephos::realtime
