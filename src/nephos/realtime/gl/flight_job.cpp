#include "nephos/realtime/gl/flight_job.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <fstream>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/io/png.hpp"
#include "nephos/weather/reader.hpp"

namespace nephos::realtime {

CloudRecipe cloud_recipe(const CloudSource& s, const UtcTime& time, double lat_deg, double lon_deg) {
  const int sources =
      !s.code.empty() + !s.metar.empty() + !s.foreca.empty() + s.weather_file.has_value() + (s.weather != nullptr);
  if (sources > 1) throw ValueError("give one of code, metar, foreca, weather", {.key = "code"});
  if (!s.metar.empty()) return recipe_from_metar(s.metar);
  if (!s.foreca.empty()) return recipe_from_code(code_from_foreca_json(s.foreca, time));
  if (s.weather_file || s.weather) {
    const weather::WeatherGrid w = s.weather ? *s.weather : weather::load_weather(*s.weather_file, 0);
    return recipe_from_weather(weather::compute_masks(w, weather::MaskParams{}), w, lat_deg, lon_deg);
  }
  return recipe_from_code(parse_weather_code(s.code.empty() ? "d300" : s.code));
}

void check(const FlightRequest& r) {
  require_range(r.lat_deg, -90, 90, "position", "the latitude [deg]");
  require_range(r.lon_deg, -max_abs_longitude_deg, max_abs_longitude_deg, "position", "the longitude [deg]");
  require_image_size(r.width, r.height, "size");
  require_range(r.altitude_ft, min_altitude_ft, max_altitude_ft, "altitude_ft", "the altitude [ft]");
  require_range(r.speed_kt, 0, max_speed_kt, "speed_kt", "the ground speed [kt]");
  require_range(r.lod_km, 0, max_lod_km, "lod_km", "the level-of-detail distance [km] (0: off)");
  require_range_above(r.impostor_radius_km, 0, max_impostor_radius_km, "impostor_radius_km",
                      "the impostor ring radius [km]");
}

bool transparent_background(const std::string& background) {
  if (background != "sky" && background != "transparent")
    throw ValueError("expected sky or transparent, got '" + background + "'", {.key = "background"});
  return background == "transparent";
}

namespace {
// Rows-from-the-top RGBA8 of a frame as PNG pixels: RGB, or straight-alpha RGBA.
std::vector<std::uint8_t> png_pixels(std::vector<std::uint8_t> rgba, bool transparent) {
  if (transparent) return straight_alpha(std::move(rgba));
  std::vector<std::uint8_t> rgb(rgba.size() / 4 * 3);
  for (std::size_t p = 0, n = rgb.size() / 3; p < n; ++p)
    for (std::size_t c = 0; c < 3; ++c) rgb[3 * p + c] = rgba[4 * p + c];
  return rgb;
}
}  // namespace

void write_frame_png(const std::filesystem::path& path, const SpriteRenderer& renderer, bool transparent) {
  io::write_png(path, renderer.width(), renderer.height(), transparent ? 4 : 3,
                png_pixels(renderer.read_pixels(), transparent));
}

std::pair<WeatherCode, double> parse_weather_change(const std::string& text) {
  const auto at = text.find('@');
  if (at == std::string::npos)
    throw ValueError("expected CODE@SECONDS, e.g. d400@1.5, got '" + text + "'", {.key = "change"});
  const auto secs = parse_numbers(text.substr(at + 1), 1, "change", "CODE@SECONDS");
  require_range(secs[0], 0, FlightSession::max_change_s, "change", "the time of the change [s of flight]");
  return {parse_weather_code(text.substr(0, at)), secs[0]};
}

namespace {
FlightParams flight_params(const FlightRequest& r) {
  check(r);
  FlightParams fp;
  fp.altitude_m = r.altitude_ft * metres_per_foot;
  fp.speed_m_s = r.speed_kt * metres_per_second_per_knot;
  fp.sort_optimised = r.sort_opt;
  fp.impostors = r.impostors;
  return fp;
}
}  // namespace

FlightSession::FlightSession(const FlightRequest& r)
    : recipe_((check(r), cloud_recipe(r.clouds, r.time, r.lat_deg, r.lon_deg))),
      flight_(recipe_, r.seed, flight_params(r)),
      sun_(sun_light(r.time, r.lat_deg, r.lon_deg)),
      transparent_(r.transparent) {
  renderer_ = std::make_unique<SpriteRenderer>(r.width, r.height, r.seed, r.gl);
  renderer_->set_impostor_radius(r.impostor_radius_km * 1000);
  renderer_->set_single_sprite_distance(r.lod_km * 1000);
  if (transparent_) renderer_->set_background(SpriteRenderer::Background::transparent);
}

FrameStats FlightSession::next_frame() { return flight_.next_frame(*renderer_, sun_); }

void FlightSession::change_weather(const WeatherCode& code, double at_s) {
  require_range(at_s, 0, max_change_s, "at_s", "the time of the change [s of flight]");
  flight_.change_weather_at(recipe_from_code(code), at_s);
}

std::vector<std::uint8_t> FlightSession::pixels() const { return png_pixels(renderer_->read_pixels(), transparent_); }

void FlightSession::write_png(const std::filesystem::path& path) const {
  write_frame_png(path, *renderer_, transparent_);
}

FlyResult run_fly(const FlyRequest& request, const std::function<void(int)>& after_frame) {
  if (request.frames < 1) throw ValueError("must be >= 1", {.key = "frames"});
  std::optional<std::pair<WeatherCode, double>> change;
  if (!request.change.empty()) change = parse_weather_change(request.change);
  FlightSession session(request.flight);
  spdlog::info("clouds from {}: {} sprite clouds", session.recipe().source, session.recipe().sprite_clouds());
  spdlog::info("OpenGL: {} on {}", session.renderer().gl_version(), session.renderer().gl_renderer());
  if (change) session.change_weather(change->first, change->second);
  ensure_directory(request.out);
  AtomicFile csv(request.out / "frames.csv");
  std::ofstream table(csv.temp_path());
  table << "frame,frame_ms,sprites,impostor_updates\n";
  double total_ms = 0;
  for (int f = 0; f < request.frames; ++f) {
    const FrameStats st = session.next_frame();
    total_ms += st.milliseconds;
    table << fmt::format("{},{:.3f},{},{}\n", f, st.milliseconds, st.sprites, st.impostor_updates);
    session.write_png(request.out / fmt::format("frame_{:04d}.png", f));
    if (after_frame) after_frame(f);
  }
  csv.commit(table);
  return {total_ms / request.frames, session.flight().field().clouds().size(), session.renderer().gl_renderer()};
}

}  // namespace nephos::realtime
