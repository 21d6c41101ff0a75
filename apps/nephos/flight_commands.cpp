// nephos fly (a straight, level flight through sprite clouds, headless) and nephos view (the
// same in a window): the options of realtime::FlightRequest (docs/realtime.md).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <memory>

#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/progress.hpp"
#include "nephos/realtime/gl/flight_job.hpp"
#include "view.hpp"

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
  double impostor_radius_km = 8;
  double lod_km = 20;
  std::string change;
  std::string gl = "gles3";
  std::string background = "sky";
  std::string weather_time;
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

// The request fields whose options are named otherwise.
const std::map<std::string, std::string> flight_flags{
    {"speed_kt", "--speed"}, {"altitude_ft", "--altitude"}, {"sort_opt", "--no-sort-opt"}};

realtime::FlightRequest request_of(const FlyOptions& o, const GlobalOptions& g) {
  realtime::FlightRequest r;
  r.clouds.code = o.code;
  r.clouds.metar = o.metar;
  r.clouds.foreca = o.foreca;
  if (!o.weather.empty()) r.clouds.weather_file = weather_source({o.weather, o.weather_time, false});
  const auto pos = parse_numbers(o.position, 2, "position", "LAT,LON in degrees");
  r.lat_deg = pos[0], r.lon_deg = pos[1];
  std::tie(r.width, r.height) = parse_size(o.size, "size");
  r.speed_kt = o.speed_kt;
  r.altitude_ft = o.altitude_ft;
  r.time = parse_time(o.time, "time");
  r.sort_opt = !o.no_sort_opt;
  r.impostors = !o.no_impostors;
  r.impostor_radius_km = o.impostor_radius_km;
  r.lod_km = o.lod_km;
  r.gl = realtime::gl_api_from_name(o.gl);
  r.transparent = realtime::transparent_background(o.background);
  r.seed = g.seed;
  return r;
}

int run_view_command(const FlyOptions& o, const std::string& screenshot, const GlobalOptions& g) {
  const realtime::FlightRequest r = request_of(o, g);
  realtime::check(r);
  if (o.frames < 0) throw ValueError("must be >= 0 (0: until the window is closed)", {.key = "frames"});
  ViewOptions v;
  v.width = r.width, v.height = r.height;
  v.lat_deg = r.lat_deg, v.lon_deg = r.lon_deg;
  v.time = r.time;
  v.api = r.gl;
  v.recipe = realtime::cloud_recipe(r.clouds, r.time, r.lat_deg, r.lon_deg);
  v.frames = o.frames;
  v.altitude_m = r.altitude_ft * realtime::metres_per_foot;
  v.speed_m_s = r.speed_kt * realtime::metres_per_second_per_knot;
  v.impostor_radius_m = r.impostor_radius_km * 1000;
  v.single_sprite_distance_m = r.lod_km * 1000;
  v.impostors = r.impostors;
  v.screenshot = screenshot;
  v.seed = r.seed;
  return run_view(v);
}

int run_fly(const FlyOptions& o, const GlobalOptions& g) {
  realtime::FlyRequest r;
  r.flight = request_of(o, g);
  r.frames = o.frames;
  r.change = o.change;
  r.out = o.out;
  Progress progress("fly", static_cast<std::size_t>(std::max(o.frames, 0)));
  const realtime::FlyResult res = realtime::run_fly(r, [&](int) { progress.advance(); });
  std::cout << fmt::format(
      "fly: {} frames of {}x{}, {} sprite clouds, mean frame {:.1f} ms (CPU time around glFinish; {})\n", r.frames,
      r.flight.width, r.flight.height, res.clouds, res.mean_frame_ms, res.gl_renderer);
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
  fly->add_option("--background", o->background,
                  "sky, or transparent: RGBA frames (alpha = cloud coverage) to composite over a map or terrain")
      ->capture_default_str();
  fly->add_option("--out", o->out, "Output directory")->capture_default_str();
  return {fly, [o, &g] { return run_fly(*o, g); }, flight_flags};
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
  return {view, [o, &g, screenshot] { return run_view_command(*o, *screenshot, g); }, flight_flags};
}

}  // namespace nephos::app
