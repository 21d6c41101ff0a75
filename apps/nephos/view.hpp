#pragma once
// nephos view: the sprite-cloud renderer in a window (GLFW), flown with keyboard and mouse,
// with an on-screen frame time. The same renderer, shaders and cloud field as nephos fly.
#include <cstdint>
#include <string>
#include <vector>

#include "nephos/core/time.hpp"
#include "nephos/realtime/gl/sprite_renderer.hpp"
#include "nephos/realtime/weather_input.hpp"

namespace nephos::app {

struct ViewOptions {
  realtime::CloudRecipe recipe;
  int width = 1280, height = 720;  ///< window size [pixels]
  double lat_deg = 48, lon_deg = 11;
  UtcTime time;
  realtime::GlApi api = realtime::GlApi::gles30;
  double altitude_m = 2438, speed_m_s = 128.6;
  double impostor_radius_m = 8000;
  double single_sprite_distance_m = 20000;  ///< level of detail (0: every sprite)
  bool impostors = true;
  int frames = 0;          ///< > 0: close after this many frames of 1/30 s of flight (scripted, deterministic)
  std::string screenshot;  ///< PNG of the last frame as shown, overlay included
  std::uint64_t seed = 1;
};

/// RGBA8 pixels (rows from the top) as an RGB PNG: the frames' sky is opaque, so alpha
/// carries nothing.
void write_rgb_png(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgba);

/// Opens the window and flies until it is closed (or `frames` have been shown). Throws
/// IoError when no window can be opened (no display), naming the reason.
int run_view(const ViewOptions& options);

}  // namespace nephos::app
