#include "nephos/render/sensor.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <tuple>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"

namespace nephos::render {

TEST(Sensor, GeostationaryFullDisc) {
  const Sensor s = parse_sensor("geo:-75.2", 400, 400);
  const earth::Geodetic g = earth::geodetic(s.position);
  EXPECT_NEAR(g.alt_m, 35786e3, 1e-3);
  EXPECT_NEAR(g.lon_deg, -75.2, 1e-9);
  // The centre ray points at the Earth's centre; the disc fills the frame but its limb
  // (angular radius asin(R / r) = 8.70 deg) lies inside the field of view.
  EXPECT_NEAR(glm::dot(s.ray(200, 200), -glm::normalize(s.position)), 1.0, 1e-12);
  const double limb = std::asin(earth::radius_m / glm::length(s.position)) / earth::deg;
  EXPECT_NEAR(limb, 8.7, 0.01);  // asin(6371.0088 / 42157.0088) = 8.692 deg: "about 8.7 deg"
  EXPECT_GT(s.fov_deg / 2, limb);
  // Count pixels that see the Earth: the disc's area in pixels, pi r^2 with
  // r = 200 tan(limb) / tan(fov/2); 1 % covers the pixelisation of the edge.
  int earth_px = 0;
  for (int y = 0; y < 400; ++y)
    for (int x = 0; x < 400; ++x)
      earth_px += earth::ray_sphere(s.position, s.ray(x + 0.5, y + 0.5), earth::radius_m) ? 1 : 0;
  const double r_px = 200 * std::tan(limb * earth::deg) / std::tan(s.fov_deg / 2 * earth::deg);
  EXPECT_NEAR(earth_px / (M_PI * r_px * r_px), 1.0, 0.01);
  // North is up: the top-centre pixel sees the northern hemisphere.
  const auto hit = earth::ray_sphere(s.position, s.ray(200, 60), earth::radius_m);
  ASSERT_TRUE(hit);
  EXPECT_GT(earth::geodetic(s.position + hit->t0 * s.ray(200, 60)).lat_deg, 30);
}

TEST(Sensor, LeoNadir) {
  const Sensor s = parse_sensor("leo:10,20,700,5", 100, 100);
  const earth::Vec3 d = s.ray(50, 50);
  const auto hit = earth::ray_sphere(s.position, d, earth::radius_m);
  ASSERT_TRUE(hit);
  const earth::Geodetic g = earth::geodetic(s.position + hit->t0 * d);
  EXPECT_NEAR(g.lat_deg, 10, 1e-9);
  EXPECT_NEAR(g.lon_deg, 20, 1e-9);
  EXPECT_NEAR(hit->t0, 700e3, 1e-3);
}

TEST(Sensor, TomlCameraAndErrors) {
  const auto path = test_support::temp_path("camera.toml");
  std::ofstream(path) << "[camera]\nposition_lat_deg = 20.0\nposition_lon_deg = -60.0\nposition_alt_m = 3000.0\n"
                         "look_at_lat_deg = 20.5\nlook_at_lon_deg = -60.0\nlook_at_alt_m = 3000.0\nfov_deg = 60.0\n";
  const Sensor s = parse_sensor(path.string(), 64, 32);
  EXPECT_GT(glm::dot(s.forward, earth::local_north(glm::normalize(s.position))), 0.99);  // looking north
  std::ofstream(path) << "[camera]\nposition_lat_deg = 20.0\nbogus = 1\n";
  EXPECT_THROW(parse_sensor(path.string(), 64, 32), ConfigError);
  // Out of range, or nan (TOML has it): a ConfigError naming the key.
  // So are the camera's own limits: a field of view outside (0, 179) deg, a target on the
  // camera (each with the file and the line). Each case overrides the good file's values.
  const std::vector<std::pair<std::string, std::string>> good = {
      {"position_lat_deg", "20.0"}, {"position_lon_deg", "-60.0"}, {"position_alt_m", "3000.0"},
      {"look_at_lat_deg", "20.5"},  {"look_at_lon_deg", "-60.0"},  {"fov_deg", "60.0"}};
  for (const auto& [key, value, named] :
       {std::tuple{"position_lat_deg", "95.0", "position_lat_deg"},
        std::tuple{"position_lat_deg", "nan", "position_lat_deg"}, std::tuple{"fov_deg", "179.0", "fov_deg"},
        std::tuple{"fov_deg", "0.0", "fov_deg"}, std::tuple{"position_lat_deg", "20.5", "look_at_lat_deg"}}) {
    std::ofstream out(path);
    out << "[camera]\n";
    for (const auto& [k, v] : good) out << k << " = " << (k == key ? value : v) << "\n";
    if (std::string(key) == "position_lat_deg" && std::string(value) == "20.5") out << "look_at_alt_m = 3000.0\n";
    out.close();
    try {
      parse_sensor(path.string(), 64, 32);
      ADD_FAILURE() << key << " = " << value;
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.context().key, std::string("camera.") + named) << key << " = " << value;
      EXPECT_EQ(e.context().file, path.string()) << key << " = " << value;
      EXPECT_GT(e.context().line, 0) << key << " = " << value;
    }
  }
  std::filesystem::remove(path);
  EXPECT_THROW(parse_sensor("geo:abc", 10, 10), ValueError);
  EXPECT_THROW(parse_sensor("geo:nan", 10, 10), ValueError);
  EXPECT_THROW(parse_sensor("leo:91,0,700,10", 10, 10), ValueError);
  EXPECT_THROW(parse_sensor("leo:1,2,3", 10, 10), ValueError);
  EXPECT_THROW(parse_sensor("geo:400", 10, 10), ValueError);  // a typing error, not 40 deg E
  EXPECT_THROW(parse_sensor("leo:10,-200,700,10", 10, 10), ValueError);
  // GRIB's 0..360 convention is a longitude too: 284.8 deg E is 75.2 deg W.
  // Tolerance 1 m: the two differ only by the rounding of 360 deg in radians (~1e-15 relative)
  // at the 42,164 km orbit radius.
  const Sensor east = parse_sensor("geo:284.8", 10, 10), west = parse_sensor("geo:-75.2", 10, 10);
  EXPECT_NEAR(east.position.x, west.position.x, 1.0);
  EXPECT_NEAR(east.position.y, west.position.y, 1.0);
  EXPECT_THROW(parse_sensor("mars:1", 10, 10), ValueError);
}

}  // namespace nephos::render
