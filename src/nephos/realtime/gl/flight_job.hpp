#pragma once
// `nephos fly` and Python's nephos.Flight as a typed request: the weather the clouds come from,
// the aircraft and the renderer, checked in one place (errors name the request's fields:
// "position", "speed_kt", ...), and a session that flies and draws frame by frame.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "nephos/core/time.hpp"
#include "nephos/realtime/gl/flight.hpp"
#include "nephos/realtime/gl/sprite_renderer.hpp"
#include "nephos/realtime/weather_input.hpp"
#include "nephos/weather/source.hpp"

namespace nephos::realtime {

/// Where a flight's clouds come from: at most one of these; none is the Foreca code d300.
struct CloudSource {
  std::string code;                                    ///< Foreca weather symbol, e.g. "d400"
  std::string metar;                                   ///< a METAR report (its cloud groups)
  std::filesystem::path foreca;                        ///< a Foreca JSON file (hourly or daily)
  std::optional<weather::WeatherSource> weather_file;  ///< GRIB weather: masks and winds at the position
  const weather::WeatherGrid* weather = nullptr;       ///< or weather already read (not owned)
};

/// The clouds of `source` at (lat, lon) and `time`. ValueError naming "code" when several
/// sources are given; the decoders' errors otherwise.
CloudRecipe cloud_recipe(const CloudSource& source, const UtcTime& time, double lat_deg, double lon_deg);

/// A straight, level flight eastwards, drawn headless.
struct FlightRequest {
  CloudSource clouds;
  double lat_deg = 48.0, lon_deg = 11.0;  ///< the aircraft's position [deg]
  int width = 1280, height = 720;         ///< frame [pixels]
  double speed_kt = 250, altitude_ft = 8000;
  UtcTime time = UtcTime::from_civil(2024, 6, 21, 10);  ///< for the sun
  bool sort_opt = true;                                 ///< re-sort only when the view changed enough
  bool impostors = true;                                ///< far clouds through the impostor ring
  double impostor_radius_km = 8;                        ///< MSFS 2004's ring radius
  double lod_km = 20;                                   ///< single-sprite level of detail beyond this (0: off)
  GlApi gl = GlApi::gles30;
  bool transparent = false;  ///< RGBA frames over nothing (alpha: cloud coverage) instead of the sky
  std::uint64_t seed = 1;
};

/// The numbers of a request, each in its range; ValueError naming the field otherwise.
void check(const FlightRequest& request);
/// "sky" (false) or "transparent" (true); ValueError naming "background" otherwise.
bool transparent_background(const std::string& background);
/// A renderer's last frame as a PNG: RGB over the sky, or straight-alpha RGBA (written atomically).
void write_frame_png(const std::filesystem::path& path, const SpriteRenderer& renderer, bool transparent);
/// "CODE@SECONDS" (d400@1.5): the weather code and when it takes over [s of flight];
/// ValueError naming "change" otherwise.
std::pair<WeatherCode, double> parse_weather_change(const std::string& text);

/// A flight being flown and drawn: the request checked, its clouds decoded, the renderer made.
class FlightSession {
 public:
  explicit FlightSession(const FlightRequest& request);
  /// Flies 1/30 s and draws the frame.
  FrameStats next_frame();
  /// From `at_s` seconds of flight on (0..max_change_s), the weather is `code`; ValueError
  /// naming "at_s" otherwise.
  void change_weather(const WeatherCode& code, double at_s);
  static constexpr double max_change_s = 1e7;
  /// The last frame, rows from the top: RGB8 over the sky, or straight-alpha RGBA8 when
  /// transparent.
  std::vector<std::uint8_t> pixels() const;
  int channels() const { return transparent_ ? 4 : 3; }
  /// The last frame as a PNG (RGB, or RGBA when transparent), written atomically.
  void write_png(const std::filesystem::path& path) const;

  const StraightFlight& flight() const { return flight_; }
  const SpriteRenderer& renderer() const { return *renderer_; }
  SpriteRenderer& renderer() { return *renderer_; }
  const CloudRecipe& recipe() const { return recipe_; }

 private:
  CloudRecipe recipe_;
  StraightFlight flight_;
  std::unique_ptr<SpriteRenderer> renderer_;
  SunLight sun_;
  bool transparent_;
};

/// `nephos fly`: `frames` frames of a flight as frame_NNNN.png and frames.csv in `out`.
struct FlyRequest {
  FlightRequest flight;
  int frames = 60;
  std::string change;  ///< "CODE@SECONDS": the weather changes then (clouds form and dissipate)
  std::filesystem::path out = "out/fly";
};
struct FlyResult {
  double mean_frame_ms = 0;
  std::size_t clouds = 0;
  std::string gl_renderer;
};
/// Runs `request`; `after_frame` (optional) is called after each frame is written.
FlyResult run_fly(const FlyRequest& request, const std::function<void(int frame)>& after_frame = {});

}  // namespace nephos::realtime
