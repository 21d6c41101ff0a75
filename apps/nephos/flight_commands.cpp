// nephos fly (a straight, level flight through sprite clouds, headless) and nephos view (the
// same in a window), from a weather code, METAR, Foreca JSON or GRIB file (docs/realtime.md).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <memory>

#include <fstream>
#include <optional>
#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/progress.hpp"

#include "nephos/realtime/cloud_field.hpp"
#include "nephos/realtime/flight.hpp"
#include "nephos/realtime/frame_logic.hpp"
#include "nephos/realtime/gl_renderer.hpp"
#include "nephos/realtime/weather_input.hpp"
#include "nephos/weather/masks.hpp"
#include "nephos/weather/reader.hpp"
#include "view.hpp"

namespace fs = std::filesystem;

namespace nephos::app {

namespace {

struct FlyOptions {
  std::string code, metar, foreca, weather;
  std::string position = "48.0,11.0";  // latitude, longitude [deg]
  int frames = 60;
  std::string size = "1280x720";
  double speed_kt = 250, altitude_ft = 8000;
  std::string time = "2024-06-21T10:00:00Z";
  bool no_sort_opt = false;
  bool no_impostors = false;
  double impostor_radius_km = 8;   // MSFS 2004's ring radius
  double lod_km = 20;              // single-sprite level of detail beyond this (0: off)
  std::string change;              // CODE@SECONDS: the weather changes to CODE at that time of the flight
  std::string gl = "gles3";        // OpenGL ES 3.0 or desktop OpenGL 3.3 core
  std::string background = "sky";  // or "transparent": RGBA frames to composite over a map
  std::string weather_time;        // with --weather: a valid time of a file that holds several
  std::string out = "out/fly";
};

// The options nephos fly and nephos view share: weather source, place, time, aircraft, GL API.
void add_flight_options(CLI::App* c, FlyOptions& o) {
  c->add_option("--code", o.code, "Foreca weather symbol, e.g. d300 (default)");
  c->add_option("--metar", o.metar, "METAR report (its cloud groups)");
  c->add_option("--foreca", o.foreca, "Foreca hourly or daily JSON");
  c->add_option("--weather", o.weather, "GRIB weather file (masks and winds at --position)");
  c->add_option("--weather-time", o.weather_time,
                "With --weather: which valid time (ISO 8601 UTC) of a file that holds several (default: its first)");
  c->add_option("--position", o.position, "LAT,LON of the aircraft [deg]")->capture_default_str();
  c->add_option("--size", o.size, "Frame WIDTHxHEIGHT")->capture_default_str();
  c->add_option("--speed", o.speed_kt, "Ground speed [kt]")->capture_default_str();
  c->add_option("--altitude", o.altitude_ft, "Altitude [ft]")->capture_default_str();
  c->add_option("--time", o.time, "UTC time for the sun (ISO 8601)")->capture_default_str();
  c->add_flag("--no-impostors", o.no_impostors, "Draw every cloud as sprites (no impostor ring)");
  c->add_option("--impostor-radius-km", o.impostor_radius_km, "Radius of the impostor ring [km]")
      ->capture_default_str();
  c->add_option("--lod-km", o.lod_km,
                "Clouds drawn as sprites farther than this are drawn as one sprite (level of detail) [km]; 0: "
                "every sprite")
      ->capture_default_str();
  c->add_option("--gl", o.gl, "OpenGL API: gles3 (OpenGL ES 3.0) or gl33 (OpenGL 3.3 core)")->capture_default_str();
}

// The aircraft's place, checked with the other numbers nephos fly and nephos view share.
std::pair<double, double> checked_flight(const FlyOptions& o) {
  const auto pos = parse_numbers(o.position, 2, "--position", "LAT,LON in degrees");
  require_range(pos[0], -90, 90, "--position", "the latitude [deg]");
  require_range(pos[1], -realtime::max_abs_longitude_deg, realtime::max_abs_longitude_deg, "--position",
                "the longitude [deg]");
  require_range(o.altitude_ft, realtime::min_altitude_ft, realtime::max_altitude_ft, "--altitude", "the altitude [ft]");
  require_range(o.speed_kt, 0, realtime::max_speed_kt, "--speed", "the ground speed [kt]");
  require_range(o.lod_km, 0, realtime::max_lod_km, "--lod-km", "the level-of-detail distance [km] (0: off)");
  require_range_above(o.impostor_radius_km, 0, realtime::max_impostor_radius_km, "--impostor-radius-km",
                      "the impostor ring radius [km]");
  return {pos[0], pos[1]};
}

// The clouds around the aircraft from whichever weather source the options name.
realtime::CloudRecipe flight_recipe(const FlyOptions& o, const UtcTime& time, double lat, double lon) {
  const int sources = !o.code.empty() + !o.metar.empty() + !o.foreca.empty() + !o.weather.empty();
  if (sources > 1) throw ValueError("give one of --code, --metar, --foreca, --weather", {.key = "--code"});
  if (!o.metar.empty()) return realtime::recipe_from_metar(o.metar);
  if (!o.foreca.empty()) return realtime::recipe_from_code(realtime::code_from_foreca_json(o.foreca, time));
  if (!o.weather.empty()) {
    const weather::WeatherGrid w = open_weather_file(o.weather, o.weather_time);
    return realtime::recipe_from_weather(weather::compute_masks(w, weather::MaskParams{}), w, lat, lon);
  }
  return realtime::recipe_from_code(realtime::parse_weather_code(o.code.empty() ? "d300" : o.code));
}

int run_view_command(const FlyOptions& o, const std::string& screenshot, const GlobalOptions& g) {
  ViewOptions v;
  std::tie(v.width, v.height) = parse_size(o.size);
  std::tie(v.lat_deg, v.lon_deg) = checked_flight(o);
  const UtcTime time = parse_time(o.time, "--time");
  if (o.frames < 0) throw ValueError("must be >= 0 (0: until the window is closed)", {.key = "--frames"});
  v.time = time;
  v.api = realtime::gl_api_from_name(o.gl);
  v.recipe = flight_recipe(o, time, v.lat_deg, v.lon_deg);
  v.frames = o.frames;
  v.altitude_m = o.altitude_ft * realtime::metres_per_foot;
  v.speed_m_s = o.speed_kt * realtime::metres_per_second_per_knot;
  v.impostor_radius_m = o.impostor_radius_km * 1000;
  v.single_sprite_distance_m = o.lod_km * 1000;
  v.impostors = !o.no_impostors;
  v.screenshot = screenshot;
  v.seed = g.seed;
  return run_view(v);
}

int run_fly(const FlyOptions& o, const GlobalOptions& g) {
  const auto [width, height] = parse_size(o.size);
  const auto [lat, lon] = checked_flight(o);
  const UtcTime time = parse_time(o.time, "--time");
  if (o.frames < 1) throw ValueError("must be >= 1", {.key = "--frames"});
  std::optional<std::pair<realtime::CloudRecipe, double>> change;
  if (!o.change.empty()) {
    const auto at = o.change.find('@');
    if (at == std::string::npos)
      throw ValueError("expected CODE@SECONDS, e.g. d400@1.5, got '" + o.change + "'", {.key = "--change"});
    const auto secs = parse_numbers(o.change.substr(at + 1), 1, "--change", "CODE@SECONDS");
    require_range(secs[0], 0, 1e7, "--change", "the time of the change [s of flight]");
    change.emplace(realtime::recipe_from_code(realtime::parse_weather_code(o.change.substr(0, at))), secs[0]);
  }
  const bool transparent = transparent_background(o.background);
  const realtime::CloudRecipe recipe = flight_recipe(o, time, lat, lon);
  spdlog::info("clouds from {}: {} sprite clouds", recipe.source, recipe.sprite_clouds());
  realtime::FlightParams fp;
  fp.altitude_m = o.altitude_ft * realtime::metres_per_foot;
  fp.speed_m_s = o.speed_kt * realtime::metres_per_second_per_knot;
  fp.sort_optimised = !o.no_sort_opt;
  fp.impostors = !o.no_impostors;
  realtime::StraightFlight flight(recipe, g.seed, fp);
  if (change) flight.change_weather_at(change->first, change->second);
  realtime::SpriteRenderer renderer(width, height, g.seed, realtime::gl_api_from_name(o.gl));
  spdlog::info("OpenGL: {} on {}", renderer.gl_version(), renderer.gl_renderer());
  renderer.set_impostor_radius(o.impostor_radius_km * 1000);
  renderer.set_single_sprite_distance(o.lod_km * 1000);
  if (transparent) renderer.set_background(realtime::SpriteRenderer::Background::transparent);
  const realtime::SunLight sun = realtime::sun_light(time, lat, lon);
  const fs::path out(o.out);
  ensure_directory(out);
  AtomicFile csv(out / "frames.csv");
  std::ofstream table(csv.temp_path());
  table << "frame,frame_ms,sprites,impostor_updates\n";
  Progress progress("fly", static_cast<std::size_t>(o.frames));
  double total_ms = 0;
  for (int f = 0; f < o.frames; ++f) {
    const realtime::FrameStats st = flight.next_frame(renderer, sun);
    total_ms += st.milliseconds;
    table << fmt::format("{},{:.3f},{},{}\n", f, st.milliseconds, st.sprites, st.impostor_updates);
    write_frame_png(out / fmt::format("frame_{:04d}.png", f), renderer, transparent);
    progress.advance();
  }
  csv.commit(table);
  std::cout << fmt::format(
      "fly: {} frames of {}x{}, {} sprite clouds, mean frame {:.1f} ms (CPU time around glFinish; {})\n", o.frames,
      width, height, flight.field().clouds().size(), total_ms / o.frames, renderer.gl_renderer());
  return 0;
}

}  // namespace

Command add_fly_command(CLI::App& app, const GlobalOptions& g) {
  auto o = std::make_shared<FlyOptions>();
  auto* fly = app.add_subcommand("fly", "Real-time sprite clouds along a straight, level flight (headless, EGL)");
  add_flight_options(fly, *o);
  fly->add_option("--frames", o->frames, "Frames (30 per second of flight)")->capture_default_str();
  fly->add_flag("--no-sort-opt", o->no_sort_opt, "Re-sort every frame instead of only when the view changed");
  fly->add_option("--change", o->change, "CODE@SECONDS: the weather changes then (clouds form and dissipate)");
  add_background_option(fly, o->background);
  fly->add_option("--out", o->out, "Output directory")->capture_default_str();
  return {fly, [o, &g] { return run_fly(*o, g); }};
}

Command add_view_command(CLI::App& app, const GlobalOptions& g) {
  auto o = std::make_shared<FlyOptions>();
  o->frames = 0;  // until the window is closed
  auto screenshot = std::make_shared<std::string>();
  auto* view = app.add_subcommand("view", "Sprite clouds in a window: fly with the keyboard and mouse (GLFW)");
  add_flight_options(view, *o);  // --no-impostors: start with the ring off (key I toggles it)
  view->add_option("--frames", o->frames, "Close after N frames of 1/30 s each (0: when the window is closed)")
      ->capture_default_str();
  view->add_option("--screenshot", *screenshot, "PNG of the window's last frame, overlay included");
  return {view, [o, &g, screenshot] { return run_view_command(*o, *screenshot, g); }};
}

}  // namespace nephos::app
