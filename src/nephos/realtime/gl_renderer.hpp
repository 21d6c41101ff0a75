#pragma once
// OpenGL rendering of the sprite-cloud field, on OpenGL ES 3.0 (the Android/avionics profile)
// or desktop OpenGL 3.3 core with the same shaders (only the GLSL version line differs):
// headless through EGL (Mesa's llvmpipe software rasteriser on machines without a GPU), or
// into a window whose context the caller made current (nephos view, GLFW). One instanced draw call draws every sprite:
// camera-facing billboards from a texture array baked from nephos's own 3D fractal density,
// each drawn over the octagon of its texture's non-transparent texels (SpriteTrim), sorted
// back to front, premultiplied-alpha blended, shaded on the CPU per sprite (MSFS 2004: five
// height colour levels, a directional term per shading group, a time-of-day ambient factor).
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "nephos/realtime/cloud_field.hpp"
#include "nephos/realtime/frame_logic.hpp"

namespace nephos::realtime {

struct Camera {
  glm::dvec3 position, forward, up{0, 0, 1};
  double fov_deg = 60;
  double far_m = 200000;  ///< far clipping distance
};

/// Camera-facing round sprites with their own grey and opacity (particle clouds), structure of
/// arrays, drawn in index order: sort them back to front first.
struct PointSprites {
  std::vector<float> x, y, z;  ///< world position [m]
  std::vector<float> size_m;   ///< diameter
  std::vector<float> grey;     ///< brightness in [0, 1]
  std::vector<float> alpha;    ///< opacity in [0, 1]
  std::size_t size() const { return x.size(); }
};

struct FrameStats {
  double milliseconds = 0;   ///< CPU time around the frame including glFinish
  std::size_t sprites = 0;   ///< sprites drawn individually (not through impostors)
  int impostor_updates = 0;  ///< impostor textures rendered into this frame, whole or in part (8 on the first frame)
  std::size_t impostor_sprites = 0;  ///< sprites rendered into impostor textures this frame
  std::size_t locked_sprites = 0;    ///< sprites whose facing is locked (camera inside them)
  /// The area of the impostor quads the ring's draw covers, as a fraction of the quads' whole
  /// area (each impostor trimmed to the columns of its texture that hold clouds; 1 untrimmed,
  /// 0 without a ring).
  double ring_coverage = 0;
};

/// Which OpenGL: ES 3.0 or desktop 3.3 core profile.
enum class GlApi { gles30, gl33 };
/// "gles3" or "gl33" (ValueError naming the accepted values otherwise).
GlApi gl_api_from_name(const std::string& name);
const char* name(GlApi api);

/// RGBA8 pixels of `framebuffer` (0: the window's) of the current context, rows from the top.
std::vector<std::uint8_t> read_framebuffer_rgba(unsigned framebuffer, int width, int height);

/// Premultiplied RGBA8 (what the renderer's frames hold) to straight alpha (what PNG stores):
/// each colour divided by its alpha, rounded to nearest and clamped to 255; a = 0 gives 0, 0, 0, 0.
std::vector<std::uint8_t> straight_alpha(std::vector<std::uint8_t> premultiplied_rgba);

/// The octagon |x| <= a, |y| <= b, |x| + |y| <= c (quad corners at +-1) outside which a sprite
/// texture's bilinear samples are all transparent: drawn instead of the whole quad, it spares
/// the rasteriser the transparent corners (particle trimming). All zero for a transparent texture.
struct SpriteTrim {
  float a = 1, b = 1, c = 2;
};
/// SpriteTrim of one `size` x `size` RGBA8 texture (rows from the top).
SpriteTrim sprite_trim(const std::uint8_t* rgba, int size);

class SpriteRenderer {
 public:
  /// Frames over which a new impostor set crossfades with the old one (0.53 s at 30 frames per
  /// second). MSFS 2004 crossfades without saying how long; 16 steps of 1/17 keep every
  /// frame-to-frame change of a d400 flight small (docs/realtime.md, "The ring's crossfade").
  static constexpr int crossfade_frames = 16;
  /// Creates a headless EGL context of `api` and an off-screen framebuffer. Throws IoError if
  /// EGL or the API is not available (the message says which call failed).
  SpriteRenderer(int width, int height, std::uint64_t seed, GlApi api = GlApi::gles30);
  /// Uses the caller's current context of `api` (a window's); frames are drawn off screen as
  /// always and copied to the window by present().
  struct UseCurrentContext {};
  SpriteRenderer(UseCurrentContext, int width, int height, std::uint64_t seed, GlApi api);
  ~SpriteRenderer();
  /// Makes this renderer's context current: several headless renderers in one thread take
  /// turns, each draw preceded by its renderer's make_current() (a no-op for a window's
  /// context, which the caller manages). Throws IoError if EGL refuses.
  void make_current();
  /// Detaches this renderer's context from the calling thread (a no-op for a window's), so that
  /// another thread may make it current and draw next: EGL lets a context be current in one
  /// thread at a time. Throws IoError if EGL refuses.
  void release_current();
  SpriteRenderer(const SpriteRenderer&) = delete;
  SpriteRenderer& operator=(const SpriteRenderer&) = delete;

  /// Draws the field's clouds; `sort` re-sorts back to front (else the previous order, unless
  /// the set of sprites changed). With `impostors`, clouds beyond the ring radius are drawn
  /// through the octagonal impostor ring of MSFS 2004 (see ImpostorRing): eight 256 x 256
  /// textures around the camera, rebuilt over the following frames (set_impostor_sprites_per_frame)
  /// when the camera has moved past the thresholds, then crossfaded over crossfade_frames frames.
  FrameStats draw(const CloudField& field, const Camera& camera, const SunLight& sun, bool sort, bool impostors = true);
  /// The impostor ring's parameters and state (radius, thresholds; valid after a draw).
  const ImpostorRing& impostor_ring() const;
  void set_impostor_radius(double radius_m);
  /// Single-sprite level of detail: a cloud drawn as sprites whose centre is farther than
  /// `distance_m` from the camera is drawn as its one LOD sprite (SpriteCloud::lod); 0 (the
  /// default) draws every sprite. With the impostor ring on, it applies to the clouds the ring
  /// does not hold (forming or dissipating, or beyond the 10,000 ft rule).
  void set_single_sprite_distance(double distance_m);
  /// Whether two flat layers of one type, next to each other on the same side of the camera,
  /// are drawn as one quad compositing both (default, one fill instead of two) or as two quads
  /// (for comparison; the frames agree to the rounding of the 8-bit blends).
  void set_merge_flat_layers(bool merge);
  /// Whether sprites cover only the octagon of their texture's non-transparent texels (default)
  /// or the whole quad (for comparison: the frames are the same up to float rounding).
  void set_trim_sprites(bool trim);
  /// Whether the frame's first flat layer, which lies over nothing but the cleared sky, is
  /// composited with the sky in its shader and written without blending (default) or blended
  /// like the others (for comparison: the frames agree to the rounding of the 8-bit blend).
  void set_first_layer_over_sky(bool over_sky);
  /// Which of a flat layer's two baked views a pixel shows (sprite_textures.hpp): `automatic`
  /// (default) blends the vertical view into the 45-degree one by the pixel's elevation (the
  /// vertical one straight overhead or below, the 45-degree one from 45 degrees to the horizon)
  /// and draws a frame whose every ray is more than 45 degrees from the vertical on the layer's
  /// side with a shader that reads the 45-degree view alone; `blended` always uses the blending
  /// shader; `vertical` and `slant` show one view everywhere. All but `automatic` are for
  /// comparison (`blended` gives the same frames).
  enum class LayerViews { automatic, blended, vertical, slant };
  void set_layer_views(LayerViews views);
  /// Whether each impostor is drawn over only the columns of its texture that hold clouds
  /// (default; ring_columns columns, each from its lowest to its highest non-transparent texel,
  /// read back after the impostor is rendered) or over its whole quad (for comparison: the
  /// pixels left out would have blended a fully transparent texel).
  void set_trim_ring(bool trim);
  /// What lies behind the clouds: the sky colour (default; sky_colour()), or nothing, so that
  /// a frame's alpha is the clouds' coverage and its colours are premultiplied by it, ready to
  /// be composited over a map or terrain ("over": frame + (1 - alpha) behind; docs/realtime.md).
  enum class Background { sky, transparent };
  void set_background(Background background);
  /// Sprites rendered into the new impostor set per frame while it is built, so that a sector
  /// full of clouds is spread over several frames instead of lengthening one (MSFS 2004 renders
  /// into its impostors "one 16-square-kilometer cloud block per frame" on its software path).
  /// At least 1; the first frame's ring is rendered whole. The images do not depend on it.
  void set_impostor_sprites_per_frame(std::size_t sprites);
  static constexpr std::size_t default_impostor_sprites_per_frame = 128;
  /// Columns per impostor for set_trim_ring (8 texels each).
  static constexpr int ring_columns = 32;
  /// Draws point sprites (one instanced draw call), in their given order.
  FrameStats draw_points(const PointSprites& sprites, const Camera& camera);
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
  /// Where and how a pass draws: a camera with its own frustum into a framebuffer.
  struct Target {
    Camera camera;
    unsigned fbo = 0;
    int width = 0, height = 0;
    double tan_half_x = 1;
    double tan_y_low = -1, tan_y_high = 1;  ///< vertical extent of the frustum (asymmetric for impostors)
    std::array<float, 4> clear{};
    glm::dvec3 sun{0, 0, 1};
  };
  Target screen(const Camera& camera, const SunLight& sun) const;
  /// Which shader a draw uses: flat (impostor quads, particles), sprites with the bent-normal
  /// diffuse term, a flat layer (faded to its mean far out), or two flat layers of one type
  /// composited in one pass; the _slant variants of the last two for frames whose every ray is
  /// more than 45 degrees from the vertical, which see only the layers' 45-degree view.
  enum class Shading { plain, bent_normal, sheet, layer_pair, sheet_slant, layer_pair_slant };
  /// Uploads instances [first, first + count) of the buffer and draws them in one instanced call
  /// with `shading`, blended over what `target` holds; with `over_sky`, flat layers drawn over
  /// nothing but the cleared sky: composited with the sky colour in their shader and written
  /// without blending.
  void submit(const Target& target, std::size_t first, std::size_t count, unsigned texture, bool clear, Shading shading,
              bool over_sky = false);
  /// Draws vertices [first, first + count) of the ring's triangles (built in draw()) with the
  /// flat shader, blended over what `target` holds.
  void submit_ring(const Target& target, std::size_t first, std::size_t count, unsigned texture);
  /// What submit() and submit_ring() share: binds `target`, clears it if asked, and sets the
  /// blend state, the program of `shading` with its uniforms (sprite trims if `trimmed`) and
  /// `texture`.
  void begin_pass(const Target& target, unsigned texture, bool clear, Shading shading, bool over_sky, bool trimmed);
  /// The frustum of impostor `sector` (0 = east, CCW) of set `set`, from the ring centre.
  Target impostor_target(int set, int sector, const SunLight& sun, const Camera& camera) const;
  /// Starts rendering the captured clouds of impostor set `set` into its sector `sector` from
  /// the ring centre `centre`: gathers, sorts and shades the sprites.
  void begin_impostor(int set, int sector, const glm::dvec3& centre, const CloudField& field, const SunLight& sun);
  /// Renders the next `budget` of them (at most) into the scratch target; once all are drawn
  /// (`complete`), copies the image into the set's layer and finds its columns' spans. Returns
  /// how many sprites it drew.
  std::size_t continue_impostor(int set, int sector, std::size_t budget, const SunLight& sun, const Camera& camera,
                                bool& complete);
  void create_context();
  void init_gl(std::uint64_t seed);
  std::unique_ptr<Impl> impl_;
  int w_, h_;
  GlApi api_;
};

}  // namespace nephos::realtime
