#include "nephos/realtime/cloud_field.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "nephos/core/error.hpp"

namespace nephos::realtime {
namespace {
CloudField field(const char* code, std::uint64_t seed = 4) {
  return CloudField(recipe_from_code(parse_weather_code(code)), seed, {0, 0, 0});
}
double nearest_neighbour_mean(const CloudField& f) {
  double s = 0;
  for (const auto& a : f.clouds()) {
    double best = 1e30;
    for (const auto& b : f.clouds())
      if (a.id != b.id) best = std::min(best, glm::length(glm::dvec2(a.centre - b.centre)));
    s += best;
  }
  return s / static_cast<double>(f.clouds().size());
}
}  // namespace

TEST(CloudField, CountsAndAltitudeBandsPerCode) {
  const int expected[] = {0, 10, 30, 75, 200};
  for (int c = 0; c <= 4; ++c) {
    const std::string code = "d" + std::to_string(c) + "00";
    const CloudRecipe r = recipe_from_code(parse_weather_code(code));
    const CloudField f(r, 1, {0, 0, 0});
    EXPECT_EQ(static_cast<int>(f.clouds().size()), expected[c]) << code;
    for (const auto& cl : f.clouds()) {
      const auto& layer =
          *std::find_if(r.layers.begin(), r.layers.end(), [&](const auto& l) { return l.type == cl.type; });
      EXPECT_GE(cl.centre.z, layer.base_m);
      EXPECT_LE(cl.centre.z, layer.top_m);
      EXPECT_GT(cl.sprites.size(), 4u);        // several sprites, not one quad
      EXPECT_GE(cl.group_centres.size(), 3u);  // in shading groups
    }
  }
  const CloudField ci = field("d500");
  EXPECT_EQ(ci.clouds().size(), 0u);
  ASSERT_EQ(ci.layers().size(), 2u);  // at most two cirrus layers
  EXPECT_EQ(ci.layers()[0].type, SpriteCloudType::cirrus);
}

TEST(CloudField, SpreadCodesKeepTheirDistanceClusteredOnesGather) {
  // 30 clouds, spread (Appendix B.3); those the camera would have behind it at first were then
  // moved ahead by the relocation rule (thesis 3.3.5), which does not space them.
  const CloudField spread = field("d200");
  double min_d = 1e30;
  for (const auto& a : spread.clouds())
    for (const auto& b : spread.clouds())
      if (a.id != b.id && a.relocations == 0 && b.relocations == 0)
        min_d = std::min(min_d, glm::length(glm::dvec2(a.centre - b.centre)));
  EXPECT_GT(min_d, 0.9 * CloudFieldParams{}.min_spacing_m);  // iterative pushing: within 10 %
  // Clustered clouds (d300) sit much closer to their nearest neighbour than spread ones would
  // at the same count over the same field.
  CloudRecipe r = recipe_from_code(parse_weather_code("d300"));
  const CloudField clustered(r, 4, {0, 0, 0});
  r.clustered = false;
  const CloudField uniform(r, 4, {0, 0, 0});
  EXPECT_LT(nearest_neighbour_mean(clustered), 0.7 * nearest_neighbour_mean(uniform));
}

TEST(CloudField, CloudsBehindTheCameraAreRelocatedAhead) {
  CloudField f = field("d300");
  const double r = CloudFieldParams{}.field_radius_m;
  // Fly 100 km east: everything falls behind and must reappear ahead, in view.
  const glm::dvec3 cam{100000, 0, 1500}, fwd{1, 0, 0};
  EXPECT_EQ(f.follow_camera(cam, fwd), 75);
  for (const auto& c : f.clouds()) {
    EXPECT_GT(c.centre.x - cam.x, 0.3 * r);
    EXPECT_LT(glm::length(glm::dvec2(c.centre - cam)), 1.2 * r);
  }
  EXPECT_EQ(f.follow_camera(cam, fwd), 0);  // nothing left to move
}

TEST(CloudField, RelocatedCloudsFormInsteadOfPopping) {
  // A cloud moved ahead starts at opacity 0 and forms linearly over relocation_fade_s (3 s),
  // independently of the weather's 20 s formation time; one that was dissipating when it fell
  // behind is removed instead of coming back.
  const CloudFieldParams p;
  CloudField f(recipe_from_code(parse_weather_code("d400")), 4, {0, 0, 0}, p);
  f.change_weather(recipe_from_code(parse_weather_code("d300")), 0.0, {0, 0, 0});  // 200 -> 75 clouds
  f.advance_time(1.0);
  std::size_t dissipating = 0;
  for (const auto& c : f.clouds()) dissipating += c.fade_to == 0;
  ASSERT_EQ(dissipating, 125u);
  const glm::dvec3 cam{100000, 0, 1500}, fwd{1, 0, 0};
  EXPECT_EQ(f.follow_camera(cam, fwd), 200);
  for (const auto& c : f.clouds()) {
    EXPECT_EQ(c.opacity, 0.0f);
    EXPECT_TRUE(c.fading() || c.fade_to == 0);
  }
  f.advance_time(1.0 + 0.5 * p.relocation_fade_s);
  ASSERT_EQ(f.clouds().size(), 75u);  // the dissipating ones are gone
  for (const auto& c : f.clouds()) EXPECT_FLOAT_EQ(c.opacity, 0.5f);
  f.advance_time(1.0 + p.relocation_fade_s);
  for (const auto& c : f.clouds()) {
    EXPECT_EQ(c.opacity, 1.0f);
    EXPECT_FALSE(c.fading());
  }
  CloudFieldParams bad;
  bad.relocation_fade_s = 0;
  EXPECT_THROW(CloudField(recipe_from_code(parse_weather_code("d100")), 4, {0, 0, 0}, bad), ValueError);
}

TEST(CloudField, DeterministicFromTheSeedAndLod) {
  const CloudField a = field("d400", 9), b = field("d400", 9), c = field("d400", 10);
  ASSERT_EQ(a.clouds().size(), b.clouds().size());
  for (std::size_t k = 0; k < a.clouds().size(); ++k) {
    EXPECT_EQ(a.clouds()[k].centre, b.clouds()[k].centre);
    EXPECT_EQ(a.clouds()[k].sprites.size(), b.clouds()[k].sprites.size());
  }
  EXPECT_NE(a.clouds()[0].centre, c.clouds()[0].centre);
  const auto& cl = a.clouds()[0];
  EXPECT_EQ(CloudField::sprites_to_draw(cl, 50000, 20000), 1u);
  EXPECT_EQ(CloudField::sprites_to_draw(cl, 5000, 20000), cl.sprites.size());
  EXPECT_EQ(CloudField::sprites_to_draw(cl, 20000, 20000), cl.sprites.size() + 1);  // both, dissolving
  EXPECT_EQ(CloudField::sprites_to_draw(cl, 50000, 0), cl.sprites.size());          // LOD off
}

TEST(CloudField, LevelOfDetailCrossDissolvesOverTwoKilometresAtTwenty) {
  // The single sprite's weight: 0 up to 0.95 L, 1 from 1.05 L, linear between (L = 20 km: 19-21
  // km); continuous, so a cloud never switches at once. Exact up to rounding (1e-12).
  EXPECT_EQ(CloudField::lod_weight(18000, 20000), 0.0);
  EXPECT_EQ(CloudField::lod_weight(19000, 20000), 0.0);
  EXPECT_NEAR(CloudField::lod_weight(19500, 20000), 0.25, 1e-12);
  EXPECT_NEAR(CloudField::lod_weight(20000, 20000), 0.5, 1e-12);
  EXPECT_EQ(CloudField::lod_weight(21000, 20000), 1.0);
  EXPECT_EQ(CloudField::lod_weight(1e6, 20000), 1.0);
  EXPECT_EQ(CloudField::lod_weight(1e6, 0), 0.0);  // off
  for (double d = 18000; d < 22000; d += 10)       // at most a step's worth per 10 m (slope 1 / 2 km)
    EXPECT_LE(CloudField::lod_weight(d + 10, 20000) - CloudField::lod_weight(d, 20000), 10.0 / 2000 + 1e-12);
}

TEST(CloudField, CloudsDriftWithTheWind) {
  // A GFS recipe carries the wind at the aircraft; every cloud moves with it: after t seconds
  // by (u t, v t), exactly (no relocation in between), and the air's offset says the same.
  CloudRecipe r = recipe_from_code(parse_weather_code("d300"));
  r.drift_east_m_s = 5, r.drift_north_m_s = -3;
  CloudField f(r, 2, {0, 0, 0});
  std::vector<glm::dvec3> before;
  for (const SpriteCloud& c : f.clouds()) before.push_back(c.centre);
  f.advance_time(4);
  f.advance_time(10);
  for (std::size_t k = 0; k < before.size(); ++k) {
    // Tolerance: two double additions of tens of metres to kilometre coordinates (1e-9 m).
    EXPECT_NEAR(f.clouds()[k].centre.x - before[k].x, 50.0, 1e-9);
    EXPECT_NEAR(f.clouds()[k].centre.y - before[k].y, -30.0, 1e-9);
    EXPECT_EQ(f.clouds()[k].centre.z, before[k].z);
  }
  EXPECT_NEAR(f.drift_offset_m().x, 50.0, 1e-12);
  EXPECT_NEAR(f.drift_offset_m().y, -30.0, 1e-12);
  // Weather codes carry no wind: the clouds stay.
  CloudField still = field("d300", 2);
  const glm::dvec3 c0 = still.clouds()[0].centre;
  still.advance_time(10);
  EXPECT_EQ(still.clouds()[0].centre, c0);
}

TEST(CloudField, LodSpriteCoversTheWholeCloud) {
  // The single sprite drawn far away stands for every sprite of the cloud: it sits at their
  // centroid and its disc contains each of them (to float rounding, 1e-3 m), and its shading
  // group is centred on it (no directional term).
  const CloudField f = field("d400", 4);
  for (const SpriteCloud& c : f.clouds()) {
    glm::vec3 centroid(0.0f);
    for (const Sprite& s : c.sprites) centroid += s.offset;
    centroid /= static_cast<float>(c.sprites.size());
    EXPECT_LT(glm::length(c.lod.offset - centroid), 1e-3f);
    for (const Sprite& s : c.sprites)
      EXPECT_LE(glm::length(s.offset - c.lod.offset) + 0.5f * s.size_m, 0.5f * c.lod.size_m + 1e-3f);
    ASSERT_LT(static_cast<std::size_t>(c.lod.shading_group), c.group_centres.size());
    EXPECT_EQ(c.group_centres[static_cast<std::size_t>(c.lod.shading_group)], c.lod.offset);
  }
}

}  // namespace nephos::realtime

TEST(CloudField, WeatherChangesFadeCloudsInAndOut) {
  using namespace nephos::realtime;
  const glm::dvec3 cam{0, 0, 2400};
  CloudField field(recipe_from_code(parse_weather_code("d400")), 5, cam);
  const std::size_t before = field.clouds().size();
  ASSERT_EQ(before, 200u);
  field.change_weather(recipe_from_code(parse_weather_code("d200")), 10.0, cam);  // 200 -> 30 clouds
  // Nothing pops: every cloud is still there, those beyond the new count start to dissipate.
  EXPECT_EQ(field.clouds().size(), before);
  std::size_t dissipating = 0;
  for (const auto& c : field.clouds()) dissipating += c.fade_to == 0;
  EXPECT_EQ(dissipating, before - 30);
  // Half-way through the fade (default 20 s) their opacity is 0.5; the flat layers of d400 fade too.
  field.advance_time(20.0);
  for (const auto& c : field.clouds()) EXPECT_FLOAT_EQ(c.opacity, c.fade_to == 0 ? 0.5f : 1.0f);
  for (const auto& l : field.layers()) EXPECT_FLOAT_EQ(l.opacity, 0.5f);
  field.advance_time(30.0);  // fully dissipated: removed
  EXPECT_EQ(field.clouds().size(), 30u);
  EXPECT_TRUE(field.layers().empty());
  // And back: new clouds form from opacity 0.
  field.change_weather(recipe_from_code(parse_weather_code("d300")), 30.0, cam);
  field.advance_time(35.0);
  std::size_t forming = 0;
  for (const auto& c : field.clouds())
    if (c.fade_to == 1 && c.opacity < 1) {
      ++forming;
      EXPECT_FLOAT_EQ(c.opacity, 0.25f);
    }
  EXPECT_EQ(forming, 75u - 30u);
}
