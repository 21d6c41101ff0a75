#pragma once
// OpenGL rendering of the sprite-cloud field, on OpenGL ES 3.0 (the Android/avionics profile)
// or desktop OpenGL 3.3 core with the same shaders (only the GLSL version line differs):
// headless through EGL (Mesa's llvmpipe software rasteriser on machines without a GPU), or
// into a window whose context the caller made current (nephos view, GLFW). Each frame is
// planned without a GPU (FramePlanner: what is drawn, in which order, with which opacity, and
// the impostor ring's upkeep) and executed here: camera-facing billboards from a texture array
// baked from nephos's own 3D fractal density, each drawn over the octagon of its texture's
// non-transparent texels, sorted back to front, premultiplied-alpha blended, shaded on the CPU
// per sprite (MSFS 2004: five height colour levels, a directional term per shading group, a
// time-of-day ambient factor).
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "nephos/realtime/cloud_field.hpp"
#include "nephos/realtime/frame_logic.hpp"
#include "nephos/realtime/frame_plan.hpp"
#include "nephos/realtime/gl/egl_context.hpp"

namespace nephos::realtime {

/// RGBA8 pixels of `framebuffer` (0: the window's) of the current context, rows from the top.
std::vector<std::uint8_t> read_framebuffer_rgba(unsigned framebuffer, int width, int height);

/// Premultiplied RGBA8 (what the renderer's frames hold) to straight alpha (what PNG stores):
/// each colour divided by its alpha, rounded to nearest and clamped to 255; a = 0 gives 0, 0, 0, 0.
std::vector<std::uint8_t> straight_alpha(std::vector<std::uint8_t> premultiplied_rgba);

class SpriteRenderer {
 public:
  static constexpr int crossfade_frames = FramePlanner::crossfade_frames;
  static constexpr std::size_t default_impostor_sprites_per_frame = FramePlanner::default_impostor_sprites_per_frame;
  static constexpr int ring_columns = realtime::ring_columns;
  using LayerViews = RenderOptions::LayerViews;

  /// Creates a headless EGL context of `api` and an off-screen framebuffer. Throws IoError if
  /// EGL or the API is not available (the message says which call failed), ValueError naming
  /// "size" if the frame exceeds the implementation's largest framebuffer.
  SpriteRenderer(int width, int height, std::uint64_t seed, GlApi api = GlApi::gles30);
  /// Uses the caller's current context of `api` (a window's); frames are drawn off screen as
  /// always and copied to the window by present().
  struct UseCurrentContext {};
  SpriteRenderer(UseCurrentContext, int width, int height, std::uint64_t seed, GlApi api);
  ~SpriteRenderer();
  SpriteRenderer(const SpriteRenderer&) = delete;
  SpriteRenderer& operator=(const SpriteRenderer&) = delete;
  /// Makes this renderer's context current: several headless renderers in one thread take
  /// turns, each draw preceded by its renderer's make_current() (a no-op for a window's
  /// context, which the caller manages). Throws IoError if EGL refuses.
  void make_current();
  /// Detaches this renderer's context from the calling thread (a no-op for a window's), so that
  /// another thread may make it current and draw next. Throws IoError if EGL refuses.
  void release_current();

  /// Draws the field's clouds (FramePlanner::plan): `sort` re-sorts back to front; with
  /// `impostors`, clouds beyond the ring radius through the octagonal impostor ring of MSFS
  /// 2004, rebuilt over the following frames when the camera has moved past the thresholds,
  /// then crossfaded over crossfade_frames frames.
  FrameStats draw(const CloudField& field, const Camera& camera, const SunLight& sun, bool sort, bool impostors = true);
  /// Draws point sprites (one instanced draw call), in their given order.
  FrameStats draw_points(const PointSprites& sprites, const Camera& camera);

  /// How the frames are drawn (for comparison; the defaults draw the same frames faster).
  RenderOptions& options();
  /// The impostor ring's parameters and state (radius, thresholds; valid after a draw).
  const ImpostorRing& impostor_ring() const;
  void set_impostor_radius(double radius_m);
  /// Single-sprite level of detail: a cloud drawn as sprites whose centre is farther than
  /// `distance_m` from the camera is drawn as its one LOD sprite (SpriteCloud::lod); 0 (the
  /// default) draws every sprite. With the impostor ring on, it applies to the clouds the ring
  /// does not hold (forming or dissipating, or beyond the 10,000 ft rule).
  void set_single_sprite_distance(double distance_m);
  /// Sprites rendered into the new impostor set per frame while it is built (MSFS 2004 renders
  /// into its impostors "one 16-square-kilometer cloud block per frame" on its software path).
  /// At least 1; the images do not depend on it.
  void set_impostor_sprites_per_frame(std::size_t sprites);
  /// What lies behind the clouds: the sky colour (default; sky_colour()), or nothing, so that
  /// a frame's alpha is the clouds' coverage and its colours are premultiplied by it, ready to
  /// be composited over a map or terrain ("over": frame + (1 - alpha) behind; docs/realtime.md).
  enum class Background { sky, transparent };
  void set_background(Background background);

  /// Copies the last frame into the current context's default framebuffer (window mode),
  /// scaled to `width` x `height` pixels.
  void present(int width, int height) const;
  GlApi api() const { return api_; }
  /// The GL_VERSION string of the context.
  std::string gl_version() const;
  /// The GL_RENDERER string of the context: what draws ("llvmpipe ..." for Mesa's software
  /// rasteriser, the GPU's name otherwise).
  std::string gl_renderer() const;
  /// RGBA8 pixels of the last frame, rows from the top.
  std::vector<std::uint8_t> read_pixels() const;
  int width() const { return w_; }
  int height() const { return h_; }
  /// The sky colour the frame is cleared to (RGBA8), for tests.
  static std::array<std::uint8_t, 4> sky_colour();

 private:
  struct Impl;
  void init_gl(std::uint64_t seed);
  std::unique_ptr<EglContext> context_;  // null with a caller's context
  std::unique_ptr<Impl> impl_;
  int w_, h_;
  GlApi api_;
};

}  // namespace nephos::realtime
