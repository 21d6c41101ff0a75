#include "nephos/realtime/gl/sprite_renderer.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>

#include "nephos/core/error.hpp"
#include "nephos/realtime/gl/gl_program.hpp"
#include "nephos/realtime/weather_input.hpp"

namespace nephos::realtime {
namespace {

// How RGBA8 frame b differs from frame a: the largest channel difference, the number of
// channels more than `level` apart, and b's largest difference from the clear sky.
struct FrameDiff {
  int max = 0;
  std::size_t over = 0;
  int from_sky = 0;
};
FrameDiff frame_diff(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b, int level) {
  FrameDiff f;
  const auto sky = SpriteRenderer::sky_colour();
  for (std::size_t i = 0; i < a.size(); ++i) {
    const int d = std::abs(int{a[i]} - int{b[i]});
    f.max = std::max(f.max, d);
    f.over += d > level;
    f.from_sky = std::max(f.from_sky, std::abs(int{b[i]} - int{sky[i % 4]}));
  }
  return f;
}

// The frames of one view drawn with one of the renderer's comparison switches on ([1], drawn
// first) and off ([0]); the switch is left off.
std::array<std::vector<std::uint8_t>, 2> frames_both_ways(SpriteRenderer& renderer, bool RenderOptions::*option,
                                                          const CloudField& field, const Camera& cam,
                                                          const SunLight& sun, bool impostors) {
  std::array<std::vector<std::uint8_t>, 2> frames;
  for (const bool on : {true, false}) {
    renderer.options().*option = on;
    renderer.draw(field, cam, sun, true, impostors);
    frames[on] = renderer.read_pixels();
  }
  return frames;
}

}  // namespace

TEST(SpriteRendererGl, NamesItsContext) {
  // What draws is reported (benchmarks print it beside their figures): on the CI machine
  // Mesa's llvmpipe, on a GPU its driver's name; the version is an OpenGL ES 3.x or desktop
  // 3.3+ context as asked for.
  SpriteRenderer es(16, 16, 1, GlApi::gles30);
  EXPECT_FALSE(es.gl_renderer().empty());
  EXPECT_NE(es.gl_version().find("OpenGL ES 3."), std::string::npos) << es.gl_version();
}

TEST(GlProgram, ReportsWhichShaderFailedWithTheCompilersLog) {
  // A shader that does not compile is an IoError naming the shader and carrying the
  // compiler's log (here: the undeclared identifier); a valid pair links to a program.
  SpriteRenderer context(16, 16, 1);
  context.make_current();
  const std::string vertex = "#version 300 es\nvoid main() { gl_Position = vec4(0.0); }\n";
  const std::string fragment =
      "#version 300 es\nprecision highp float;\nout vec4 frag;\nvoid main() { frag = vec4(1.0); }\n";
  EXPECT_NE(link_program(vertex, fragment), 0u);
  const std::string broken =
      "#version 300 es\nprecision highp float;\nout vec4 frag;\nvoid main() { frag = not_declared; }\n";
  try {
    link_program(vertex, broken);
    ADD_FAILURE() << "a fragment shader using an undeclared name compiled";
  } catch (const IoError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("fragment shader compilation failed"), std::string::npos) << what;
    EXPECT_NE(what.find("not_declared"), std::string::npos) << what;
  }
  try {
    link_program(broken, fragment);  // the same error in the vertex shader
    ADD_FAILURE() << "a vertex shader using an undeclared name compiled";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("vertex shader compilation failed"), std::string::npos) << e.what();
  }
  // Both compile, but the fragment shader reads an input the vertex shader does not write: a
  // link error in GLSL ES 3.00, reported with the linker's log.
  const std::string unmatched =
      "#version 300 es\nprecision highp float;\nin vec2 uv;\nout vec4 frag;\n"
      "void main() { frag = vec4(uv, 0.0, 1.0); }\n";
  try {
    link_program(vertex, unmatched);
    ADD_FAILURE() << "a fragment input without a vertex output linked";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("does not link"), std::string::npos) << e.what();
  }
}

TEST(SpriteRendererGl, HeadlessRenderersTakeTurnsInOneThread) {
  // Two renderers in one thread (the paired benchmark): each draw preceded by its renderer's
  // make_current() gives the frames each would draw alone, and destroying one leaves the other
  // working (they share the EGL display, which only the last one terminates).
  const CloudField field(recipe_from_code(parse_weather_code("d300")), 4, {0, 0, 2400});
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const Camera a_cam{{0, 0, 2400}, {1, 0, -0.05}, {0, 0, 1}, 60}, b_cam{{0, 0, 2400}, {0, 1, 0.2}, {0, 0, 1}, 60};
  std::vector<std::uint8_t> alone;
  {
    SpriteRenderer a(96, 64, 4);
    a.draw(field, a_cam, sun, true, true);
    alone = a.read_pixels();
  }
  SpriteRenderer a(96, 64, 4);
  std::vector<std::uint8_t> turns[2];
  {
    SpriteRenderer b(96, 64, 4);
    for (int k = 0; k < 2; ++k) {
      a.make_current();
      a.draw(field, a_cam, sun, true, true);
      turns[k] = a.read_pixels();
      b.make_current();
      b.draw(field, b_cam, sun, true, false);
      EXPECT_GT(frame_diff(turns[k], b.read_pixels(), 20).over, 100u) << "b draws its own view";
    }
  }  // b destroyed while a lives
  a.make_current();
  a.draw(field, a_cam, sun, true, true);
  EXPECT_EQ(frame_diff(alone, turns[0], 0).max, 0);
  EXPECT_EQ(frame_diff(alone, turns[1], 0).max, 0);
  EXPECT_EQ(frame_diff(alone, a.read_pixels(), 0).max, 0);
  EXPECT_GT(frame_diff(alone, alone, 0).from_sky, 20) << "clouds in view";
}

TEST(SpriteRendererGl, FacingLocksWithinHalfASpritesRadiusAndReleasesOutside) {
  // Seed 004 (MSFS 2004): a sprite whose centre the camera is within half its radius of stops
  // turning to face the camera. Headless EGL (Mesa llvmpipe), 64 x 64 frames.
  const CloudField field(recipe_from_code(parse_weather_code("d300")), 3, {0, 0, 2000});
  // How many sprites of the field have their centre within half their radius of p.
  auto inside_count = [&](const glm::dvec3& p) {
    std::size_t n = 0;
    for (const SpriteCloud& c : field.clouds())
      for (const Sprite& s : c.sprites) n += glm::length(p - (c.centre + glm::dvec3(s.offset))) < 0.25 * s.size_m;
    return n;
  };
  // A sprite and a direction from its centre along which the camera meets no other sprite's
  // lock zone between 0.45 and 0.55 of its radius (sprites of a cloud overlap).
  glm::dvec3 centre{0}, dir{0};
  double r = 0;
  for (const SpriteCloud& c : field.clouds()) {
    for (const Sprite& s : c.sprites) {
      for (const glm::dvec3 d : {glm::dvec3(1, 0, 0), glm::dvec3(-1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, -1, 0),
                                 glm::dvec3(0, 0, 1), glm::dvec3(0, 0, -1)}) {
        const glm::dvec3 p = c.centre + glm::dvec3(s.offset);
        const double rs = 0.5 * s.size_m;
        if (inside_count(p + 0.45 * rs * d) == 1 && inside_count(p + 0.55 * rs * d) == 0) {
          centre = p, dir = d, r = rs;
          break;
        }
      }
      if (r > 0) break;
    }
    if (r > 0) break;
  }
  ASSERT_GT(r, 0) << "no isolated sprite in this field";
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  SpriteRenderer renderer(64, 64, 3);
  auto locked_at = [&](double fraction_of_radius, const glm::dvec3& forward) {
    const Camera cam{centre + fraction_of_radius * r * dir, forward, {0, 0, 1}, 60};
    return renderer.draw(field, cam, sun, true, false).locked_sprites;
  };
  EXPECT_EQ(locked_at(30, {1, 0, 0}), 0u);    // far away: every sprite faces the camera
  EXPECT_EQ(locked_at(0.45, {1, 0, 0}), 1u);  // just inside half the radius: locked
  EXPECT_EQ(locked_at(0.45, {0, 1, 0}), 1u);  // turning the camera inside keeps the lock
  EXPECT_EQ(locked_at(0.55, {0, 1, 0}), 0u);  // just outside: released
}

TEST(SpriteRendererGl, SingleSpriteLevelOfDetailFarAway) {
  // Seed 004: beyond the LOD distance a cloud is one sprite. Without the impostor ring, the
  // sprites drawn are each near cloud's sprites plus one per far cloud, counted from the field;
  // distance 0 draws every sprite. Far clouds still show: the frame differs from the sky.
  const glm::dvec3 eye{0, 0, 2400};
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 5, eye);
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const Camera cam{eye, {1, 0, -0.05}, {0, 0, 1}, 60};
  SpriteRenderer renderer(96, 64, 5);
  const double lod_m = 12000;
  std::size_t expected = 0, far = 0;
  for (const SpriteCloud& c : field.clouds()) {
    const double d = glm::length(c.centre - eye);
    far += d > lod_m;
    expected += CloudField::sprites_to_draw(c, d, lod_m);  // both across 11.4-12.6 km
  }
  ASSERT_GT(far, 10u);
  EXPECT_EQ(renderer.draw(field, cam, sun, true, false).sprites, field.sprite_count());  // default: off
  renderer.set_single_sprite_distance(lod_m);
  EXPECT_EQ(renderer.draw(field, cam, sun, true, false).sprites, expected);
  const auto px = renderer.read_pixels();
  const auto sky = SpriteRenderer::sky_colour();
  std::size_t cloudy = 0;
  for (std::size_t i = 0; i < px.size(); i += 4)
    cloudy += px[i] != sky[0] || px[i + 1] != sky[1] || px[i + 2] != sky[2];
  EXPECT_GT(cloudy, 100u);
  renderer.set_single_sprite_distance(0);
  EXPECT_EQ(renderer.draw(field, cam, sun, true, false).sprites, field.sprite_count());
  EXPECT_THROW(renderer.set_single_sprite_distance(-1), ValueError);
}

TEST(SpriteRendererGl, LevelOfDetailDissolvesWithoutAPop) {
  // A cloud ahead at distance D: with the LOD distance at D / 1.1 it is its single sprite, at D
  // / 0.9 its sprites, and the two frames differ (by more than 30 levels somewhere). Across D a
  // 10 m change of the LOD distance changes the cloud's two weights by 10 m / (0.1 D), at most
  // 0.01 (D > 10 km), so no channel may move by more than 0.01 x 255 for each of the two, plus
  // one level of rounding: allowed 6. Fault caught: a switch at D (up to 57 levels at this step).
  const glm::dvec3 eye{0, 0, 2400};
  const CloudField field(recipe_from_code(parse_weather_code("d300")), 5, eye);
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const Camera cam{eye, {1, 0, -0.05}, {0, 0, 1}, 60};
  double dist = 0;  // the nearest cloud ahead beyond 10 km, within 20 degrees of the view's axis
  for (const SpriteCloud& c : field.clouds()) {
    const glm::dvec3 r = c.centre - eye;
    const double d = glm::length(r);
    if (d > 10000 && std::abs(std::atan2(r.y, r.x)) < 20 * M_PI / 180 && (dist == 0 || d < dist)) dist = d;
  }
  ASSERT_GT(dist, 0) << "no cloud ahead";
  SpriteRenderer renderer(320, 180, 5);
  auto frame_at = [&](double lod_m) {
    renderer.set_single_sprite_distance(lod_m);
    renderer.draw(field, cam, sun, true, false);
    return renderer.read_pixels();
  };
  EXPECT_GT(frame_diff(frame_at(dist / 1.1), frame_at(dist / 0.9), 30).over, 0u) << "the cloud is in view";
  const FrameDiff step = frame_diff(frame_at(dist - 5), frame_at(dist + 5), 6);
  EXPECT_EQ(step.over, 0u) << "largest difference " << step.max;
}

TEST(SpriteRendererGl, ImpostorsHoldTheSpritesBeyondTheRingNotWholeClouds) {
  // MSFS 2004 renders "only the sections beyond the radius into impostors": a sprite goes into
  // the ring when the sphere its billboard turns within (radius size / sqrt 2) lies wholly
  // beyond the ring radius and within 10,000 ft vertically; the rest are drawn as sprites. The
  // first frame builds the ring, so the sprites drawn are counted from the field's geometry.
  const glm::dvec3 eye{0, 0, 2400};
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 5, eye);
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const Camera cam{eye, {1, 0, -0.05}, {0, 0, 1}, 60};
  ImpostorRing ring;  // the renderer's defaults: 8 km, 10,000 ft
  std::size_t near = 0, split_clouds = 0;
  for (const SpriteCloud& c : field.clouds()) {
    std::size_t held = 0;
    for (const Sprite& s : c.sprites)
      held += ring.in_impostor(c.centre + glm::dvec3(s.offset), 0.5 * std::sqrt(2.0) * s.size_m, eye);
    near += c.sprites.size() - held;
    split_clouds += held > 0 && held < c.sprites.size();
  }
  ASSERT_GT(split_clouds, 0u) << "no cloud across the ring in this field";
  ASSERT_LT(near, field.sprite_count() / 2);
  SpriteRenderer renderer(96, 64, 5);
  const FrameStats first = renderer.draw(field, cam, sun, true, true);
  EXPECT_EQ(first.impostor_updates, 8);
  EXPECT_EQ(first.sprites, near);
  EXPECT_EQ(renderer.draw(field, cam, sun, true, false).sprites, field.sprite_count());  // ring off: every sprite
}

TEST(SpriteRendererGl, FormingCloudsGoIntoTheRingDissipatingOnesStaySprites) {
  // A forming cloud (new weather, or relocated ahead) is held by a ring made while it forms, at
  // the opacity it then has; a dissipating one stays sprites, so that it goes. Counted from the
  // field's geometry as above: d300 -> d400 (125 clouds forming, half-way), then d400 -> d200
  // (170 dissipating, half-way).
  const glm::dvec3 eye{0, 0, 2400};
  CloudField field(recipe_from_code(parse_weather_code("d300")), 5, eye);
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const Camera cam{eye, {1, 0, -0.05}, {0, 0, 1}, 60};
  const ImpostorRing ring;  // the renderer's defaults
  auto expected_sprites = [&] {
    std::size_t n = 0;
    for (const SpriteCloud& c : field.clouds())
      for (const Sprite& s : c.sprites)
        n += c.fade_to == 0 || !ring.in_impostor(c.centre + glm::dvec3(s.offset), 0.5 * std::sqrt(2.0) * s.size_m, eye);
    return n;
  };
  field.change_weather(recipe_from_code(parse_weather_code("d400")), 0.0, eye);
  field.advance_time(10.0);
  std::size_t forming = 0;
  for (const SpriteCloud& c : field.clouds()) forming += c.fading() && c.fade_to == 1;
  ASSERT_EQ(forming, 125u);
  SpriteRenderer a(96, 64, 5);
  EXPECT_EQ(a.draw(field, cam, sun, true, true).sprites, expected_sprites());
  field.change_weather(recipe_from_code(parse_weather_code("d200")), 10.0, eye);
  field.advance_time(20.0);
  std::size_t dissipating = 0;
  for (const SpriteCloud& c : field.clouds()) dissipating += c.fade_to == 0 && c.opacity > 0;
  ASSERT_EQ(dissipating, 170u);
  SpriteRenderer b(96, 64, 5);
  EXPECT_EQ(b.draw(field, cam, sun, true, true).sprites, expected_sprites());
}

TEST(SpriteRendererGl, CrossfadeDrawsTheSpritesNotHeldByBothSets) {
  // After the camera moves past the 15 % threshold, the new set is rendered over the next
  // frames while the old one alone stands for its sprites; then the two crossfade and a sprite
  // is drawn as a sprite unless both sets hold it. Counted from the geometry of the two ring
  // centres with the per-sprite rule.
  const glm::dvec3 eye0{0, 0, 2400}, eye1{1300, 0, 2400};  // 1300 m > 15 % of 8 km
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 9, eye0);
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  ImpostorRing ring;
  std::size_t not_front = 0, not_both = 0;
  for (const SpriteCloud& c : field.clouds())
    for (const Sprite& s : c.sprites) {
      const glm::dvec3 p = c.centre + glm::dvec3(s.offset);
      const double r = 0.5 * std::sqrt(2.0) * s.size_m;
      const bool front = ring.in_impostor(p, r, eye0), back = ring.in_impostor(p, r, eye1);
      not_front += !front;
      not_both += !(front && back);
    }
  ASSERT_GT(not_both, not_front);  // the sets differ
  SpriteRenderer renderer(64, 48, 9);
  EXPECT_EQ(renderer.draw(field, Camera{eye0, {1, 0, 0}, {0, 0, 1}, 60}, sun, true, true).impostor_updates, 8);
  const Camera moved{eye1, {1, 0, 0}, {0, 0, 1}, 60};
  FrameStats st = renderer.draw(field, moved, sun, true, true);
  for (int f = 1; st.impostor_updates > 0; ++f) {  // the new set, over several frames
    ASSERT_LT(f, 100) << "the new set is never finished";
    EXPECT_EQ(st.sprites, not_front) << "frame " << f;
    st = renderer.draw(field, moved, sun, true, true);
  }
  EXPECT_EQ(st.sprites, not_both);  // the first crossfade frame
}

TEST(SpriteRendererGl, CrossfadeChangesTheFrameInSmallEvenSteps) {
  // The camera climbs 200 m (past the 2 % threshold: 160 m of 8 km) and then holds still, so
  // that only the ring changes the frame. Both sets hold the same sprites (a climb moves no
  // cloud across the ring radius or the 10,000 ft rule), so the two sets' images are the only
  // fading layers: old A at weight 1 - w under new B at w, w = k / (N + 1). Over a background D
  // the pixel is F(w) = w B + (1 - w b) G, G = (1 - w) A + (1 - (1 - w) a) D (premultiplied,
  // values in [0, 1]), and |dF/dw| = |B - b G + (1 - w b)(a D - A)| <= 1 + 1; the near sprites
  // drawn over it only scale the change down. So a step changes a channel by at most
  // 2 * 255 / (N + 1) levels, plus the rounding of llvmpipe's 8-bit blends (a level each way
  // per blend, two blends).
  const glm::dvec3 eye0{0, 0, 2400}, eye1{0, 0, 2600};
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 9, eye0);
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  SpriteRenderer renderer(160, 96, 9);
  const FrameStats first = renderer.draw(field, Camera{eye0, {1, 0, -0.1}, {0, 0, 1}, 60}, sun, true, true);
  const Camera climbed{eye1, {1, 0, -0.1}, {0, 0, 1}, 60};
  constexpr int n = SpriteRenderer::crossfade_frames;
  const int bound = 2 * 255 / (n + 1) + 2;
  std::vector<std::uint8_t> previous;
  int changed = 0, largest = 0, building = 0;
  for (int f = 1; f <= building + n + 8; ++f) {
    const FrameStats st = renderer.draw(field, climbed, sun, true, true);
    if (st.impostor_updates > 0) building = f;  // the new set is rendered in frames 1 .. building
    EXPECT_EQ(st.sprites, first.sprites) << "frame " << f << ": the sets hold the same sprites";
    auto pixels = renderer.read_pixels();
    if (f > 1) {
      const FrameDiff d = frame_diff(previous, pixels, 0);
      // The old set alone while the new one is rendered, then N crossfade frames and the frame
      // the new set takes over, then the new set alone.
      const bool crossfading = building > 0 && f > building && f <= building + n + 1;
      if (crossfading) {
        EXPECT_GT(d.max, 0) << "frame " << f;
        EXPECT_LE(d.max, bound) << "frame " << f;
      } else {
        EXPECT_EQ(d.max, 0) << "frame " << f;
      }
      changed += d.max > 0, largest = std::max(largest, d.max);
    }
    previous = std::move(pixels);
  }
  EXPECT_EQ(changed, n + 1);
  EXPECT_GT(largest, 2) << "the two sets' images differ";
}

TEST(SpriteRendererGl, ImpostorSpriteBudgetSpreadsTheWorkNotTheImage) {
  // A new set rendered a few sprites per frame is spread over more frames, each within the
  // budget, and gives the same impostors, bit for bit, as one rendered whole: each part blends
  // over the parts before it in the same target, in the same back-to-front order.
  const glm::dvec3 eye0{0, 0, 2400}, eye1{1300, 0, 2400};
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 9, eye0);
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const Camera start{eye0, {1, 0, -0.1}, {0, 0, 1}, 60}, moved{eye1, {1, 0, -0.1}, {0, 0, 1}, 60};
  struct Build {
    int frames = 0;
    std::size_t sprites = 0, most = 0;
    std::vector<std::uint8_t> after;  // a frame once the new set has taken over
  };
  auto build = [&](std::size_t budget) {
    SpriteRenderer r(160, 96, 9);
    r.set_impostor_sprites_per_frame(budget);
    r.draw(field, start, sun, true, true);
    Build b;
    for (FrameStats st = r.draw(field, moved, sun, true, true); st.impostor_updates > 0;
         st = r.draw(field, moved, sun, true, true)) {
      ++b.frames, b.sprites += st.impostor_sprites, b.most = std::max(b.most, st.impostor_sprites);
      if (b.frames > 1000) break;
    }
    for (int f = 0; f <= SpriteRenderer::crossfade_frames; ++f) r.draw(field, moved, sun, true, true);
    b.after = r.read_pixels();
    return b;
  };
  const Build whole = build(SIZE_MAX), parts = build(64);
  EXPECT_EQ(whole.frames, 1);
  EXPECT_GT(whole.sprites, 8 * 64u) << "too few sprites to spread";
  EXPECT_EQ(parts.sprites, whole.sprites);
  EXPECT_LE(parts.most, 64u);
  EXPECT_GE(parts.frames, static_cast<int>((whole.sprites + 63) / 64));
  EXPECT_EQ(frame_diff(whole.after, parts.after, 0).max, 0);
  SpriteRenderer r(16, 16, 9);
  EXPECT_THROW(r.set_impostor_sprites_per_frame(0), ValueError);
}

TEST(SpriteRendererGl, NewRingRadiusDropsTheSetBeingBuilt) {
  // A new radius rebuilds the whole ring at once; a set that was being built for the old ring
  // is dropped, not finished and crossfaded in over the new one.
  const glm::dvec3 eye0{0, 0, 2400}, eye1{1300, 0, 2400};
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 9, eye0);
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const Camera moved{eye1, {1, 0, 0}, {0, 0, 1}, 60};
  SpriteRenderer renderer(64, 48, 9);
  renderer.set_impostor_sprites_per_frame(16);
  renderer.draw(field, Camera{eye0, {1, 0, 0}, {0, 0, 1}, 60}, sun, true, true);
  ASSERT_GT(renderer.draw(field, moved, sun, true, true).impostor_updates, 0);  // building
  renderer.set_impostor_radius(6000);
  EXPECT_EQ(renderer.draw(field, moved, sun, true, true).impostor_updates, 8);
  const auto rebuilt = renderer.read_pixels();
  for (int f = 0; f < 40; ++f) {
    EXPECT_EQ(renderer.draw(field, moved, sun, true, true).impostor_updates, 0) << "frame " << f;
    EXPECT_EQ(frame_diff(rebuilt, renderer.read_pixels(), 0).max, 0) << "frame " << f;
  }
}

TEST(SpriteRendererGl, FlatLayerPatternIsFixedToTheAir) {
  // An altostratus sheet is drawn around the camera, but its pattern must not travel with the
  // aircraft: moving the camera by one texture tile (3 km) gives the same frame (the tiling is
  // periodic), by half a tile a different one; drifting the air by a tile while the camera
  // stays gives the same frame again.
  CloudRecipe r;
  r.layers.push_back({SpriteCloudType::altostratus, 1, 4000, 5000, 8});
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  SpriteRenderer renderer(96, 64, 7);
  auto frame = [&](const CloudField& field, double x) {
    renderer.draw(field, Camera{{x, 0, 1000}, {1, 0, 0.3}, {0, 0, 1}, 60}, sun, true, false);
    return renderer.read_pixels();
  };
  // Largest difference of any channel between two frames.
  auto max_diff = [](const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
    return frame_diff(a, b, 0).max;
  };
  const CloudField still(r, 7, {0, 0, 1000});
  const auto at0 = frame(still, 0), at_tile = frame(still, 3000), at_half = frame(still, 1500);
  // A tile's move changes the texture coordinates by exactly 1 in float arithmetic of values
  // near 15: at most one 8-bit level from rounding.
  EXPECT_LE(max_diff(at0, at_tile), 1);
  EXPECT_GT(max_diff(at0, at_half), 20);
  r.drift_east_m_s = 300;  // 3 km in 10 s
  CloudField windy(r, 7, {0, 0, 1000});
  windy.advance_time(10);
  EXPECT_LE(max_diff(at0, frame(windy, 0)), 1);
  windy.advance_time(15);  // half a tile more
  EXPECT_GT(max_diff(at0, frame(windy, 0)), 20);
}

TEST(SpriteRendererGl, LayerPairInOnePassMatchesTwoPasses) {
  // Two altostratus sheets (4000 and 4800 m) drawn as one quad whose shader composites the
  // farther sheet behind the nearer one must give the frame of two separately blended sheets:
  // "over" is associative, so only rounding differs: llvmpipe's 8-bit fixed-point blend is
  // within one level per operation, the two-pass frame rounds the farther sheet's blend and
  // then the nearer one's, the one-pass frame converts the composited fragment and blends once:
  // at most three levels, and rarely more than one (under 5 % of the channels: towards the
  // horizon both sheets fade to their partly opaque mean, so there every pixel takes both
  // roundings). Seen from below (both above the camera, horizon and both sheets' edges in
  // view), from above, and from between (no pair).
  CloudRecipe r;
  r.layers.push_back({SpriteCloudType::altostratus, 2, 4000, 5000, 8});
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  SpriteRenderer renderer(160, 96, 7);
  for (const double z : {1000.0, 7000.0, 4400.0}) {
    const CloudField field(r, 7, {0, 0, z});
    ASSERT_EQ(field.layers().size(), 2u);
    const Camera cam{{0, 0, z}, {1, 0, z < 4400 ? 0.05 : -0.05}, {0, 0, 1}, 60};
    const auto frames = frames_both_ways(renderer, &RenderOptions::merge_flat_layers, field, cam, sun, false);
    const FrameDiff d = frame_diff(frames[0], frames[1], 1);  // over: channels more than one level apart
    EXPECT_LE(d.max, 3) << "camera at " << z << " m";
    EXPECT_LT(d.over, frames[0].size() / 20) << "camera at " << z << " m";
    EXPECT_GT(d.from_sky, 20) << "the sheets are drawn (camera at " << z << " m)";
  }
}

TEST(SpriteRendererGl, FirstLayerOverTheSkyMatchesBlending) {
  // The frame's first flat layer is composited with the sky colour in its shader and written
  // without blending; "over" a uniform sky gives what blending gives, up to rounding: the
  // shader rounds the composited colour once, llvmpipe's 8-bit fixed-point blend rounds the
  // fragment and then the blend (within one level each), so at most two levels apart. Layers
  // on both sides of the camera (cirrus and an altostratus pair above, fog below), seen from
  // between them, between the altostratus and the cirrus, and above all.
  CloudRecipe r;
  r.layers.push_back({SpriteCloudType::altostratus, 2, 4000, 5000, 8});
  r.layers.push_back({SpriteCloudType::cirrus, 1, 9000, 10000, 8});
  r.layers.push_back({SpriteCloudType::low_stratus, 1, 300, 400, 8});
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  SpriteRenderer renderer(160, 96, 7);
  for (const double z : {1000.0, 6000.0, 12000.0}) {
    const CloudField field(r, 7, {0, 0, z});
    ASSERT_EQ(field.layers().size(), 4u);
    const Camera cam{{0, 0, z}, {1, 0, z < 6000 ? 0.05 : -0.05}, {0, 0, 1}, 60};
    const auto frames = frames_both_ways(renderer, &RenderOptions::first_layer_over_sky, field, cam, sun, false);
    const FrameDiff d = frame_diff(frames[0], frames[1], 1);
    EXPECT_LE(d.max, 2) << "camera at " << z << " m";
    EXPECT_GT(d.from_sky, 20) << "the layers are drawn (camera at " << z << " m)";
  }
}

TEST(SpriteRendererGl, TransparentFramesOverTheSkyAreTheSkyFrames) {
  // With nothing behind the clouds a frame holds their premultiplied colour C and coverage A;
  // "over" is associative, so C + (1 - A) sky must be the frame drawn over the sky, up to the
  // rounding of the two ways: each way rounds every 8-bit blend (and the fragment blended) to
  // the nearest level, and a pixel here sees up to six layers (the deck, the ring, sprites),
  // so allowed: 6 levels, one per layer; measured: at most 4, mean 0.12-0.20 (allowed 0.25).
  // Test E's flight (d400: sprites, an impostor ring, an overcast altostratus pair), with and
  // without impostors; and a clear sky (d000) is transparent.
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const auto sky = SpriteRenderer::sky_colour();
  for (const bool impostors : {true, false}) {
    Camera cam{{0, 0, 2438}, {1, 0, -0.05}, {0, 0, 1}, 60};
    CloudField field(recipe_from_code(parse_weather_code("d400")), 5, cam.position);
    SpriteRenderer over_sky(320, 180, 5), clear(320, 180, 5);
    clear.set_background(SpriteRenderer::Background::transparent);
    for (int f = 0; f < 12; ++f) {
      // 4 s per frame: the clouds relocated in one frame (drawn at opacity 0) have formed by
      // the next (relocation_fade_s = 3 s), so no pixel sees a stack of translucent forming
      // sprites, each blend of which would round once more.
      cam.position.x += 500;
      field.advance_time(4.0 * f);
      field.follow_camera(cam.position, cam.forward);
      over_sky.make_current();
      over_sky.draw(field, cam, sun, true, impostors);
      const auto a = over_sky.read_pixels();
      clear.make_current();
      clear.draw(field, cam, sun, true, impostors);
      const auto b = clear.read_pixels();
      double sum = 0, worst = 0;
      std::size_t covered = 0;
      for (std::size_t p = 0; p < a.size(); p += 4) {
        const double alpha = b[p + 3] / 255.0;
        covered += b[p + 3] > 0;
        for (std::size_t c = 0; c < 3; ++c) {
          const double d = std::abs(b[p + c] + (1 - alpha) * sky[c] - a[p + c]);
          sum += d, worst = std::max(worst, d);
        }
        EXPECT_EQ(a[p + 3], 255);
      }
      EXPECT_LE(worst, 6.0) << "frame " << f << (impostors ? " with" : " without") << " impostors";
      EXPECT_LT(sum / (0.75 * static_cast<double>(a.size())), 0.25) << "mean, frame " << f;
      const std::size_t pixels = a.size() / 4;
      EXPECT_GT(covered, pixels * 4 / 10) << "the deck and the clouds cover much of the frame (measured 59-75 %)";
      EXPECT_LT(covered, pixels * 95 / 100) << "and leave sky";
    }
  }
  const Camera cam{{0, 0, 2438}, {1, 0, -0.05}, {0, 0, 1}, 60};
  const CloudField none(recipe_from_code(parse_weather_code("d000")), 5, cam.position);
  SpriteRenderer clear(64, 36, 5);
  clear.set_background(SpriteRenderer::Background::transparent);
  clear.draw(none, cam, sun, true, true);
  for (std::uint8_t v : clear.read_pixels()) ASSERT_EQ(v, 0);
}

TEST(StraightAlpha, DividesColourByAlpha) {
  // PNG stores straight alpha: c = round(255 c' / a) for premultiplied c'.
  const auto s = straight_alpha({128, 64, 0, 128, 0, 0, 0, 0, 255, 10, 3, 255, 7, 1, 2, 3, 200, 0, 0, 100});
  const std::vector<std::uint8_t> want{255, 128, 0, 128, 0, 0, 0, 0, 255, 10, 3, 255, 255, 85, 170, 3, 255, 0, 0, 100};
  EXPECT_EQ(s, want);  // (7, 1, 2) / 3: 595, 85, 170 (clamped to 255); 200 / 100 clamped
}

TEST(SpriteRendererGl, FlatLayerFadesToItsMeanWhereItsTexelsAreSmallerThanAPixel) {
  // A sheet at dh = 3000 m above the camera, seen level: a pixel row at elevation e meets it at
  // D = dh / tan(e), where one pixel (theta = 2 tan 30 / 180 rad) spans D^2 theta / dh metres
  // along the view, or that / (3000 m / 64) texels: more than 4 below e = 17.8 deg (row 40 of
  // 180), about 1.2 at the top row (30 deg). Where a pixel spans several texels the unfiltered
  // texture aliases (neighbouring pixels jump between unrelated texels); faded to its mean it
  // varies only with the smooth edge fade (from 13.5 km, row 55, to the 45 km edge, row 80).
  CloudRecipe r;
  r.layers.push_back({SpriteCloudType::altostratus, 1, 4000, 5000, 8});
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  constexpr int w = 320, h = 180;
  SpriteRenderer renderer(w, h, 7);
  const CloudField field(r, 7, {0, 0, 1000});
  ASSERT_EQ(field.layers().size(), 1u);
  renderer.draw(field, Camera{{0, 0, 1000}, {1, 0, 0}, {0, 0, 1}, 60}, sun, true, false);
  const auto px = renderer.read_pixels();
  // Mean difference between horizontal neighbours [levels] and largest difference from the sky
  // over rows [y0, y1).
  auto rows = [&](int y0, int y1, int& from_sky) {
    double sum = 0;
    std::size_t n = 0;
    from_sky = 0;
    const auto sky = SpriteRenderer::sky_colour();
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x + 1 < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const std::size_t i = (static_cast<std::size_t>(y) * w + x) * 4 + c;
          sum += std::abs(px[i + 4] - px[i]), ++n;
          from_sky = std::max(from_sky, std::abs(px[i] - sky[c]));
        }
    return sum / static_cast<double>(n);
  };
  int top_sky = 0, far_sky = 0;
  const double top = rows(0, 8, top_sky), far = rows(42, 76, far_sky);
  // Measured: 0.13 levels far out with the fade, 5.9 without it; 2.1 at the top rows.
  EXPECT_LT(far, 0.5) << "aliasing far out on the sheet";
  EXPECT_GT(far_sky, 20) << "the faded sheet is drawn there";
  EXPECT_GT(top, 1.0) << "the texture's pattern where a pixel spans about a texel";
  EXPECT_GT(top_sky, 20);
}

TEST(SpriteRendererGl, FlatLayerViewsFollowTheElevation) {
  // A flat layer's texture holds two views of its slab (sprite_textures.hpp): a pixel shows the
  // vertical one straight overhead, blended into the 45-degree one by sin^2 of its zenith
  // angle, and the 45-degree one from 45 degrees to the horizon. Cirrus (optical depth ~1.2,
  // where the two views' opacities differ most) 4.6 km above the camera.
  CloudRecipe r;
  r.layers.push_back({SpriteCloudType::cirrus, 1, 7000, 8000, 8});
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const CloudField field(r, 7, {0, 0, 2400});
  constexpr int w = 160, h = 160;
  SpriteRenderer renderer(w, h, 7);
  auto frame = [&](const Camera& cam, SpriteRenderer::LayerViews views) {
    renderer.options().layer_views = views;
    renderer.draw(field, cam, sun, true, false);
    return renderer.read_pixels();
  };
  using V = SpriteRenderer::LayerViews;
  // Level (every ray below 34 degrees): the 45-degree view everywhere; the automatic choice of
  // the shader that reads it alone changes nothing (mix(a, b, 1) is b).
  const Camera level{{0, 0, 2400}, {1, 0, 0.05}, {0, 0, 1}, 60};
  const auto automatic = frame(level, V::automatic);
  EXPECT_EQ(frame_diff(automatic, frame(level, V::blended), 0).max, 0);
  EXPECT_EQ(frame_diff(automatic, frame(level, V::slant), 0).max, 0);
  EXPECT_GT(frame_diff(automatic, automatic, 0).from_sky, 20) << "the layer is in view";
  {  // the same for d400's altostratus pair from 8000 ft (test E)
    CloudRecipe deck = recipe_from_code(parse_weather_code("d400"));
    std::erase_if(deck.layers, [](const CloudLayerRecipe& l) { return l.type != SpriteCloudType::altostratus; });
    const CloudField pair(deck, 7, {0, 0, 2438});
    SpriteRenderer r2(w, h, 7);
    const Camera ahead{{0, 0, 2438}, {1, 0, -0.05}, {0, 0, 1}, 60};
    std::vector<std::uint8_t> f[2];
    for (const auto views : {V::automatic, V::blended}) {
      r2.options().layer_views = views;
      r2.draw(pair, ahead, sun, true, false);
      f[views == V::blended] = r2.read_pixels();
    }
    EXPECT_EQ(frame_diff(f[0], f[1], 0).max, 0);
    EXPECT_GT(frame_diff(f[0], f[0], 0).from_sky, 20) << "the deck is in view";
  }
  renderer.make_current();
  // Straight up: within 3 degrees of the zenith the 45-degree view weighs at most 2 sin^2 3 =
  // 0.55 %, 1.4 levels of a full-range difference; the vertical view differs from the 45-degree
  // one there by its thinner column (Beer-Lambert along a path 1 / sqrt 2 as long).
  const Camera up{{0, 0, 2400}, {0, 0, 1}, {1, 0, 0}, 60};
  const auto a = frame(up, V::automatic), v = frame(up, V::vertical), s = frame(up, V::slant);
  const double pixel = 2 * std::tan(M_PI / 6) / h;  // tangent per pixel
  const int reach = static_cast<int>(std::tan(3 * M_PI / 180) / pixel);
  int to_vertical = 0;
  double to_slant = 0;
  std::size_t n = 0;
  for (int y = h / 2 - reach; y < h / 2 + reach; ++y)
    for (int x = w / 2 - reach; x < w / 2 + reach; ++x)
      for (int c = 0; c < 3; ++c) {
        const std::size_t i = (static_cast<std::size_t>(y) * w + x) * 4 + c;
        to_vertical = std::max(to_vertical, std::abs(a[i] - v[i]));
        to_slant += std::abs(a[i] - s[i]), ++n;
      }
  EXPECT_LE(to_vertical, 2);
  EXPECT_GT(to_slant / static_cast<double>(n), 3.0) << "the views differ overhead";
}

TEST(SpriteRendererGl, ImpostorRingIsInFrontOfTheFlatLayersLikeTheSprites) {
  // The ring holds sprite clouds, and sprite clouds are drawn in front of the flat layers (a
  // distant cumulus top rises in front of an overcast deck). Every draw is composited "over"
  // what is behind it, so a flat layer adds (1 - alpha_front) (L - alpha_L sky) to a pixel,
  // alpha_front being the opacity of the clouds in front of it. Where the sprites hide the deck
  // (it adds under 2 levels), the ring's impostors of the same clouds must hide it too; drawn
  // behind the deck, an impostor lets it add alpha_L (L' - R) over the impostor's colour R, the
  // texture's contrast (up to ~15 levels here). Camera at 900 m under the d400 altostratus deck:
  // the cumulus beyond the 8 km ring reach above the horizon.
  CloudRecipe with_deck = recipe_from_code(parse_weather_code("d400")), no_deck = with_deck;
  std::erase_if(no_deck.layers, [](const CloudLayerRecipe& l) { return l.type == SpriteCloudType::altostratus; });
  ASSERT_LT(no_deck.layers.size(), with_deck.layers.size());
  const glm::dvec3 eye{0, 0, 900};
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  const Camera cam{eye, {1, 0, -0.05}, {0, 0, 1}, 60};
  constexpr int w = 320, h = 180;
  std::vector<int> added[2];  // what the deck adds to each channel, sprites [0] and ring [1]
  std::size_t ring_sprites = 0;
  for (const bool impostors : {false, true}) {
    std::vector<std::uint8_t> frames[2];
    for (const bool deck : {false, true}) {
      SpriteRenderer renderer(w, h, 1);  // a fresh ring for each
      CloudField field(deck ? with_deck : no_deck, 1, eye);
      field.advance_time(0);  // the clouds formed (forming clouds stay out of the ring)
      field.follow_camera(eye, cam.forward);
      const FrameStats st = renderer.draw(field, cam, sun, true, impostors);
      if (impostors) ring_sprites = field.sprite_count() - st.sprites;
      frames[deck] = renderer.read_pixels();
    }
    for (std::size_t i = 0; i < frames[0].size(); ++i) added[impostors].push_back(frames[1][i] - frames[0][i]);
  }
  ASSERT_GT(ring_sprites, 0u);
  std::size_t hidden = 0, shown_through = 0;
  for (std::size_t i = 0; i < added[0].size(); ++i) {
    if (i % 4 == 3 || std::abs(added[0][i]) >= 2 || i / (4 * w) > h / 2) continue;  // colour, hidden, above the horizon
    ++hidden;
    // The impostors' own approximation of the sprites' opacity moved the correctly ordered
    // frame by at most 3 levels here (measured); the wrong order by up to 15, in ~1 % of them.
    shown_through += std::abs(added[1][i]) > 5;
  }
  ASSERT_GT(hidden, 10000u) << "clouds hide the deck in this view";
  EXPECT_LT(shown_through, hidden / 1000) << "of " << hidden;
}

TEST(SpriteTrim, BilinearSamplesOutsideTheOctagonAreTransparent) {
  // OpenGL's bilinear filter (GL_LINEAR, GL_REPEAT) at texture coordinate s reads the four texel
  // centres around s * size - 0.5; the octagon must hold every point where one of them is
  // non-zero. Textures: one opaque texel (the octagon is its one-texel neighbourhood, known in
  // closed form), a disc, an ellipse off the centre, an opaque and a transparent texture.
  constexpr int n = 16;
  const double pitch = 2.0 / n;  // texel size in quad units (corners at -1, 1)
  auto texture = [&](auto opaque) {
    std::vector<std::uint8_t> t(n * n * 4, 0);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        if (opaque((x + 0.5) * pitch - 1, 1 - (y + 0.5) * pitch)) t[(y * n + x) * 4 + 3] = 200;
    return t;
  };
  // One texel, the fifth column (u = -0.4375) and the third row from the top (v = 0.6875).
  const auto one =
      texture([](double u, double v) { return std::abs(u + 0.4375) < 1e-9 && std::abs(v - 0.6875) < 1e-9; });
  const SpriteTrim t1 = sprite_trim(one.data(), n);
  EXPECT_FLOAT_EQ(t1.a, 0.4375f + 0.125f);  // |u| + one pitch (exact in binary)
  EXPECT_FLOAT_EQ(t1.b, 0.6875f + 0.125f);
  EXPECT_FLOAT_EQ(t1.c, 0.4375f + 0.6875f + 0.25f);
  const auto none = texture([](double, double) { return false; });
  const SpriteTrim t0 = sprite_trim(none.data(), n);
  EXPECT_EQ(t0.a, 0.0f);
  EXPECT_EQ(t0.c, 0.0f);
  const auto full = texture([](double, double) { return true; });
  const SpriteTrim tf = sprite_trim(full.data(), n);
  EXPECT_EQ(tf.a, 1.0f);
  EXPECT_EQ(tf.b, 1.0f);
  EXPECT_EQ(tf.c, 2.0f);
  for (const auto& tex : {one, texture([](double u, double v) { return u * u + v * v < 0.5; }),
                          texture([](double u, double v) { return (u - 0.2) * (u - 0.2) / 0.3 + v * v / 0.1 < 1; })}) {
    const SpriteTrim t = sprite_trim(tex.data(), n);
    int outside = 0;
    for (int i = 0; i <= 400; ++i)
      for (int j = 0; j <= 400; ++j) {
        const double u = -1 + i * 0.005, v = -1 + j * 0.005;  // quad coordinates
        if (std::abs(u) <= t.a && std::abs(v) <= t.b && std::abs(u) + std::abs(v) <= t.c) continue;
        ++outside;
        // The bilinear footprint: texel coordinates (s, t) in [0, n), rows from the top.
        const double sx = (u + 1) / 2 * n - 0.5, sy = (1 - v) / 2 * n - 0.5;
        const int x0 = static_cast<int>(std::floor(sx)), y0 = static_cast<int>(std::floor(sy));
        const double fx = sx - x0, fy = sy - y0;
        double alpha = 0;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const int x = ((x0 + dx) % n + n) % n, y = ((y0 + dy) % n + n) % n;  // GL_REPEAT
            alpha += (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * tex[(y * n + x) * 4 + 3];
          }
        ASSERT_EQ(alpha, 0.0) << "at (" << u << ", " << v << ")";
      }
    EXPECT_GT(outside, 20000) << "the octagon trims a part of the quad";
  }
}

TEST(SpriteRendererGl, TrimmedSpritesMatchWholeQuads) {
  // Drawing each sprite over its texture's octagon instead of the whole quad leaves out only
  // fragments whose texture sample is transparent (blending (0, 0, 0, 0) leaves the frame
  // unchanged), and the attributes interpolate the same affine functions over either triangle
  // set: the frames differ by rounding only. llvmpipe interpolates and filters in float: at
  // most one level in a few channels. A GPU filters with fixed-point weights (8 bits of
  // sub-texel position on NVIDIA), so the interpolated coordinate's rounding, which differs
  // between the two triangle sets, can move each bilinear weight by one step (1/256 of a texel
  // difference: at most one level per fetch) in each of the sprites blended over a pixel; up to
  // 4 levels, in up to 2 % of the channels (an NVIDIA H200 gave 3 levels in 0.65 %). A cloudy
  // scene from inside the layer and from above, with and without the impostor ring.
  const CloudField field(recipe_from_code(parse_weather_code("d400")), 5, {0, 0, 2400});
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  SpriteRenderer renderer(192, 108, 5);
  const bool llvmpipe = renderer.gl_renderer().find("llvmpipe") != std::string::npos;
  const int max_levels = llvmpipe ? 1 : 4;
  for (const double z : {2400.0, 4500.0})
    for (const bool impostors : {false, true}) {
      const Camera cam{{0, 0, z}, {1, 0.2, z > 3000 ? -0.3 : -0.05}, {0, 0, 1}, 60};
      const auto frames = frames_both_ways(renderer, &RenderOptions::trim_sprites, field, cam, sun, impostors);
      const FrameDiff d = frame_diff(frames[0], frames[1], 0);  // over: channels that differ at all
      EXPECT_LE(d.max, max_levels) << "camera at " << z << " m, impostors " << impostors;
      EXPECT_LT(d.over, frames[0].size() / (llvmpipe ? 200 : 50)) << "camera at " << z << " m, impostors " << impostors;
      EXPECT_GT(d.from_sky, 20) << "clouds are drawn (camera at " << z << " m)";
    }
}

TEST(SpriteRendererGl, FromTheRingCentreTheImpostorsShowWhatTheSpritesShow) {
  // Each impostor is rendered from the ring's centre through a frustum fitted to its sector's
  // sprites, and its quad is placed so that from the centre it covers exactly that frustum: on
  // the first frame (camera at the centre) the ring's frame must match the frame of every
  // sprite, all around the horizon, seams between sectors included. What may differ: the
  // billboards face the sector's axis instead of the view, the bent normal follows that axis,
  // and the premultiplied impostor texels are 8-bit. Measured at 640 x 360 for eight headings:
  // at most 195 of 921 600 channels more than 32 levels apart; allowed: 1 in 2000 (a frustum
  // that cuts sprites off moves a distant cloud's whole edge by its contrast with the sky, up to
  // ~130 levels: with each sector's top 0.05 in tangent below its highest sprite's, it fails).
  const glm::dvec3 eye{0, 0, 2400};
  CloudField field(recipe_from_code(parse_weather_code("d400")), 9, eye);
  field.advance_time(0);  // the clouds formed (forming clouds stay out of the ring)
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  for (int k = 0; k < 8; ++k) {
    const double a = (22.5 + 45 * k) * M_PI / 180;  // a seam between two sectors in the middle
    const Camera cam{eye, {std::cos(a), std::sin(a), -0.05}, {0, 0, 1}, 60};
    SpriteRenderer renderer(640, 360, 1);
    renderer.draw(field, cam, sun, true, false);
    const auto every = renderer.read_pixels();
    ASSERT_EQ(renderer.draw(field, cam, sun, true, true).impostor_updates, 8);
    const FrameDiff d = frame_diff(every, renderer.read_pixels(), 32);
    EXPECT_LT(d.over, every.size() / 2000) << "heading " << 22.5 + 45 * k << " deg";
    EXPECT_GT(d.from_sky, 64) << "clouds in view";
  }
}

TEST(SpriteRendererGl, TrimmedRingMatchesTheWholeQuads) {
  // Each impostor is drawn over only the columns of its texture that hold clouds; the pixels
  // left out would have blended a fully transparent texel, so the frame must be what the whole
  // quads give. What may differ: the texture coordinates are interpolated over other triangles,
  // so a bilinear weight may round differently (one level), and where two impostors meet (their
  // quads share an edge line but not its end points) a pixel centre on the seam may fall in a
  // sliver between them either way: one pixel at two of these eight views (sky through a
  // distant cloud: ~60-100 levels), with or without trimming. So at most 8 channels (two
  // pixels) more than one level apart: a crack between columns of one impostor (edges that
  // did not meet) would open along the column's height. Test E's clouds, spread and clustered,
  // at four headings; the trimmed ring must also cover well under the quads' area.
  const glm::dvec3 eye{0, 0, 2400};
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  for (const bool clustered : {false, true}) {
    CloudRecipe r = recipe_from_code(parse_weather_code("d400"));
    r.clustered = clustered;
    CloudField field(r, 9, eye);
    field.advance_time(0);
    SpriteRenderer renderer(320, 180, 1);
    for (int k = 0; k < 4; ++k) {
      const double a = (10 + 90 * k) * M_PI / 180;
      const Camera cam{eye, {std::cos(a), std::sin(a), -0.05}, {0, 0, 1}, 60};
      renderer.options().trim_ring = false;
      EXPECT_DOUBLE_EQ(renderer.draw(field, cam, sun, true, true).ring_coverage, 1.0);
      const auto whole = renderer.read_pixels();
      renderer.options().trim_ring = true;
      const FrameStats trimmed = renderer.draw(field, cam, sun, true, true);
      EXPECT_EQ(trimmed.impostor_updates, 0);  // the same impostors, drawn both ways
      EXPECT_LT(trimmed.ring_coverage, 0.6) << "clustered " << clustered << ", heading " << 10 + 90 * k;
      const FrameDiff d = frame_diff(whole, renderer.read_pixels(), 1);
      EXPECT_LE(d.over, 8u) << "clustered " << clustered << ", heading " << 10 + 90 * k;
      EXPECT_GT(d.from_sky, 64) << "clouds in view";
    }
  }
}

TEST(SpriteRendererGl, CloudsBeyondAFlatLayerAreBehindIt) {
  // Seen from above a deck, clouds below it are behind it: every ray from the camera to them
  // crosses the deck's plane. An opaque low stratus deck at 2800 m over d300's cumulus and
  // stratocumulus (<= 2500 m), camera at 3500 m looking down: where the sprites alone would
  // show, the whole scene may differ from the deck alone only through the deck's breaks (a
  // few per cent of its area), with the impostor ring and without. Fault caught: sprites drawn
  // after the deck (they show wherever they are).
  CloudRecipe clouds = recipe_from_code(parse_weather_code("d300")), deck, both = clouds;
  deck.layers.push_back({SpriteCloudType::low_stratus, 1, 2800, 3000, 8});
  both.layers.push_back(deck.layers.back());
  const glm::dvec3 eye{0, 0, 3500};
  const Camera cam{eye, {1, 0, -0.35}, {0, 0, 1}, 60};
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  for (const bool impostors : {false, true}) {
    std::vector<std::uint8_t> frame[3];  // clouds alone, deck alone, both
    const CloudRecipe* recipes[3] = {&clouds, &deck, &both};
    std::size_t ring_sprites = 0;
    for (int k = 0; k < 3; ++k) {
      SpriteRenderer renderer(320, 180, 3);
      CloudField field(*recipes[k], 3, eye);
      field.advance_time(0);
      field.follow_camera(eye, cam.forward);
      const FrameStats st = renderer.draw(field, cam, sun, true, impostors);
      if (k == 0) ring_sprites = field.sprite_count() - st.sprites;
      if (k == 2) {
        EXPECT_EQ(st.sprites, field.sprite_count()) << "no sprite beyond the deck in the ring";
      }
      frame[k] = renderer.read_pixels();
    }
    if (impostors) {
      EXPECT_GT(ring_sprites, 100u) << "without the deck the ring holds clouds";
    }
    const auto sky = SpriteRenderer::sky_colour();
    std::size_t sprite_px = 0, shown = 0;
    for (std::size_t i = 0; i < frame[0].size(); i += 4) {
      bool sprite = false, differs = false;
      for (std::size_t c = 0; c < 3; ++c) {
        sprite |= std::abs(frame[0][i + c] - sky[c]) > 8;
        differs |= std::abs(frame[2][i + c] - frame[1][i + c]) > 8;
      }
      sprite_px += sprite, shown += sprite && differs;
    }
    ASSERT_GT(sprite_px, 2000u) << "clouds below the camera in view";
    EXPECT_LT(shown, sprite_px / 10) << "impostors " << impostors << ": of " << sprite_px;
  }
  // Crossing the deck changes which sprites may be in the impostors: the ring is made again.
  CloudField field(both, 3, {0, 0, 2400});
  field.advance_time(0);
  SpriteRenderer renderer(160, 90, 3);
  EXPECT_EQ(renderer.draw(field, {{0, 0, 2400}, {1, 0, 0}, {0, 0, 1}, 60}, sun, true, true).impostor_updates, 8);
  EXPECT_EQ(renderer.draw(field, {{0, 0, 2420}, {1, 0, 0}, {0, 0, 1}, 60}, sun, true, true).impostor_updates, 0);
  EXPECT_EQ(renderer.draw(field, {{0, 0, 2900}, {1, 0, 0}, {0, 0, 1}, 60}, sun, true, true).impostor_updates, 8);
}

TEST(SpriteRendererGl, ImpostorRingLivesInTheDriftingAir) {
  // The ring's thresholds (15 % of its radius horizontally) are measured in the frame of the air
  // the clouds drift with: an aircraft drifting with a 100 m/s wind sees no re-render in 30 s
  // (3 km of drift, more than the 1.2 km threshold); a camera held still in the same wind does,
  // once the air has moved 1.2 km past it (after 12 s).
  CloudRecipe r = recipe_from_code(parse_weather_code("d300"));
  r.drift_east_m_s = 100;
  const SunLight sun = sun_light(UtcTime::from_civil(2024, 6, 21, 10), 48, 11);
  for (const bool with_air : {true, false}) {
    SpriteRenderer renderer(64, 48, 3);
    CloudField field(r, 3, {0, 0, 2400});
    int updates_after_first = 0;
    double first_update_s = -1;
    for (int f = 0; f <= 30; ++f) {  // one frame per second
      field.advance_time(f);
      const Camera cam{{with_air ? 100.0 * f : 0.0, 0, 2400}, {1, 0, 0}, {0, 0, 1}, 60};
      const int u = renderer.draw(field, cam, sun, true, true).impostor_updates;
      if (f == 0) {
        EXPECT_EQ(u, 8);
        continue;
      }
      updates_after_first += u;
      if (u > 0 && first_update_s < 0) first_update_s = f;
    }
    if (with_air) {
      EXPECT_EQ(updates_after_first, 0);
    } else {
      EXPECT_GT(updates_after_first, 0);
      EXPECT_EQ(first_update_s, 13);  // 1300 m > 1200 m; 1200 m is not yet past the threshold
    }
  }
}

}  // namespace nephos::realtime
