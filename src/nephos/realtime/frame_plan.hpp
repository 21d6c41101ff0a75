#pragma once
// What one frame of the sprite-cloud renderer draws, decided without a GPU: the flat layers and
// the sprites as instances in drawing order with their shading and opacity, the facing lock,
// the single-sprite level of detail, and the impostor ring's upkeep (which clouds each set
// holds, which sector to render next within the frame's budget, the crossfade) and its
// triangles. The GL renderer (realtime/gl) executes a FramePlan; the impostors' images are
// rendered through an ImpostorCanvas, which tests replace.
#include <array>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "nephos/realtime/cloud_field.hpp"
#include "nephos/realtime/frame_logic.hpp"

namespace nephos::realtime {

struct Camera {
  glm::dvec3 position, forward, up{0, 0, 1};
  double fov_deg = 60;    ///< vertical field of view
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

/// Floats per drawn instance, the shaders' per-instance attributes: position relative to the
/// camera [m] and size [m] (4); colour, premultiplied by opacity, and alpha (4); texture layer
/// and sheet tiling (2); bent-normal diffuse colour (3); fixed facing and height/width (4).
inline constexpr std::size_t instance_floats = 17;
/// Floats per vertex of the ring's triangles: the quad corner (3) and the impostor's instance.
inline constexpr std::size_t ring_vertex_floats = 3 + instance_floats;
inline constexpr int impostor_size = 256;  ///< MSFS 2004: eight 256 x 256 impostors
inline constexpr int ring_columns = 32;    ///< columns per impostor the ring's draw is trimmed to

/// The octagon |x| <= a, |y| <= b, |x| + |y| <= c (quad corners at +-1) outside which a sprite
/// texture's bilinear samples are all transparent: drawn instead of the whole quad, it spares
/// the rasteriser the transparent corners (particle trimming). All zero for a transparent texture.
struct SpriteTrim {
  float a = 1, b = 1, c = 2;
};
/// SpriteTrim of one `size` x `size` RGBA8 texture (rows from the top).
SpriteTrim sprite_trim(const std::uint8_t* rgba, int size);

/// The shader a draw uses: flat (impostor quads, particles), sprites with the bent-normal
/// diffuse term, a flat layer (faded to its mean far out), or two flat layers of one type
/// composited in one pass; the _slant variants of the last two for frames whose every ray is
/// more than 45 degrees from the vertical, which see only the layers' 45-degree view.
enum class Shading { plain, bent_normal, sheet, layer_pair, sheet_slant, layer_pair_slant };

/// How (not what) the renderer draws; every setting but the defaults is for comparison.
struct RenderOptions {
  /// Two flat layers of one type next to each other on one side of the camera as one quad
  /// compositing both (else two quads; the frames agree to the 8-bit blends' rounding).
  bool merge_flat_layers = true;
  /// Sprites over the octagon of their texture's non-transparent texels (else the whole quad).
  bool trim_sprites = true;
  /// The frame's first flat layer, over nothing but the sky, composited with it in its shader
  /// and written without blending (else blended like the others).
  bool first_layer_over_sky = true;
  /// Which of a flat layer's two baked views a pixel shows (sprite_textures.hpp): `automatic`
  /// blends the vertical view into the 45-degree one by the pixel's elevation and draws a frame
  /// whose every ray is more than 45 degrees from the vertical on the layer's side with a
  /// shader that reads the 45-degree view alone; `blended` always uses the blending shader
  /// (the same frames); `vertical` and `slant` show one view everywhere.
  enum class LayerViews { automatic, blended, vertical, slant };
  LayerViews layer_views = LayerViews::automatic;
  /// Each impostor over the columns of its texture that hold clouds (else its whole quad).
  bool trim_ring = true;
};

/// Where a pass draws from: a camera and its (possibly off-centre) frustum.
struct Frustum {
  Camera camera;
  double tan_half_x = 1;
  double tan_y_low = -1, tan_y_high = 1;  ///< vertical extent (asymmetric for impostors)
  glm::dvec3 sun{0, 0, 1};                ///< towards the sun
};

/// One column of an impostor's image: the rows holding clouds as quad y in [-1, 1] (bottom,
/// top; bottom > top: none).
struct ColumnSpan {
  float bottom = 1, top = -1;
};
using ColumnSpans = std::array<ColumnSpan, ring_columns>;
/// The spans of an impostor image (impostor_size^2 RGBA8, rows from the bottom). A ring pixel
/// samples it bilinearly, so a column's span covers the texels whose footprint reaches into it
/// (one texel beyond each side) and half a texel more above and below, with another half to
/// spare for the rounding of interpolation; outside every sample is transparent. `any` tells
/// whether any column holds clouds.
ColumnSpans column_spans(const std::uint8_t* rgba, bool& any);

/// The GPU side of the impostors: renders sprites into a scratch image and keeps finished
/// images as layers of two sets (the front one drawn, the back one being rebuilt).
class ImpostorCanvas {
 public:
  virtual ~ImpostorCanvas() = default;
  /// Draws `count` instances (instance_floats each, bent-normal shading) into the scratch
  /// image through `frustum`, cleared first if `clear`, else blended over what it holds.
  virtual void render(const Frustum& frustum, const float* instances, std::size_t count, bool clear) = 0;
  /// Stores the scratch image as layer `sector` of set `set` and returns its column spans
  /// (column_spans of its pixels).
  virtual ColumnSpans store(int set, int sector, bool& any) = 0;
};

/// A frame to draw, in order: the sky; instances [first_sprite, first_sprite + beyond), the
/// sprites beyond a flat layer; the layer instances from 0 in runs of one shader (the first
/// one over the sky without blending if first_over_sky); the ring's triangles, front set then
/// back set (each its own texture array); the remaining instances, the sprites of the camera's
/// band.
struct FramePlan {
  Frustum screen;
  std::vector<float> instances;
  std::vector<std::pair<Shading, std::size_t>> layer_runs;
  std::size_t first_sprite = 0, beyond = 0;
  bool first_over_sky = false;
  bool first_layer_above = false;  ///< the first layer drawn lies above the camera
  std::vector<float> ring_vertices;
  std::size_t ring_vertex_count[2] = {0, 0};  ///< front set's, back set's
  int front = 0, back = 1;                    ///< which impostor set is which
  FrameStats stats;
};

class FramePlanner {
 public:
  /// Frames over which a new impostor set crossfades with the old one (0.53 s at 30 frames per
  /// second). MSFS 2004 crossfades without saying how long; 16 steps of 1/17 keep every
  /// frame-to-frame change of a d400 flight small (docs/realtime.md, "The ring's crossfade").
  static constexpr int crossfade_frames = 16;
  static constexpr std::size_t default_impostor_sprites_per_frame = 128;

  /// The frame for `camera` (a `width` x `height` image): `sort` re-sorts back to front (else
  /// the previous order, unless the set of sprites changed); with `impostors`, clouds beyond
  /// the ring radius go through the octagonal impostor ring, whose images `canvas` renders.
  FramePlan plan(const CloudField& field, const Camera& camera, const SunLight& sun, bool sort, bool impostors,
                 int width, int height, ImpostorCanvas& canvas);

  RenderOptions options;
  const ImpostorRing& impostor_ring() const { return ring_; }
  /// A new ring radius [m] (> 0; ValueError naming "impostor_radius_m"): the ring is made again.
  void set_impostor_radius(double radius_m);
  /// Single-sprite level of detail beyond `distance_m` (>= 0, 0: off; ValueError naming
  /// "single_sprite_distance_m").
  void set_single_sprite_distance(double distance_m);
  /// Sprites rendered into a new impostor set per frame while it is built (>= 1; ValueError
  /// naming "impostor_sprites_per_frame"); the first frame's ring is rendered whole.
  void set_impostor_sprites_per_frame(std::size_t sprites);

 private:
  // A sprite's identity across frames: its cloud (id, relocations) and its index in the cloud.
  struct SpriteKey {
    std::uint64_t cloud;
    std::uint32_t sprite;
    auto operator<=>(const SpriteKey&) const = default;
  };
  struct Band {  // between the nearest flat layers below and above the camera
    double lo, hi;
    bool contains(double z) const { return z > lo && z < hi; }
    bool operator==(const Band&) const = default;
  };
  void capture(int set, const glm::dvec3& centre, const CloudField& field, const Band& band);
  void begin_impostor(int set, int sector, const glm::dvec3& centre, const CloudField& field, const SunLight& sun);
  std::size_t continue_impostor(int set, int sector, std::size_t budget, const Camera& cam, const SunLight& sun,
                                ImpostorCanvas& canvas, bool& complete);
  double ring_upkeep(const CloudField& field, const Camera& cam, const SunLight& sun, bool impostors, const Band& band,
                     ImpostorCanvas& canvas, FrameStats& stats);
  void ring_triangles(FramePlan& plan, const glm::dvec3& air, double back_weight) const;
  void plan_layers(FramePlan& plan, const CloudField& field, const Camera& cam, const SunLight& sun,
                   const glm::dvec3& cam_air, int height) const;
  void plan_sprites(FramePlan& plan, const CloudField& field, const Camera& cam, const SunLight& sun, bool sort,
                    bool impostors, const Band& band, double back_weight);

  double single_sprite_distance_m_ = 0;
  std::size_t impostor_sprite_budget_ = default_impostor_sprites_per_frame;
  std::vector<std::size_t> order_;                       // back-to-front order of the last sort
  std::uint64_t order_generation_ = ~0ull;               // which sprite set order_ sorts
  std::uint64_t generation_ = 0;                         // bumps when the sprite set changes
  std::uint64_t lod_signature_ = 0;                      // the clouds drawn as one sprite last frame
  std::unordered_map<std::uint64_t, glm::vec3> locked_;  // facing of sprites the camera is inside

  // The impostor ring (MSFS 2004): two sets of 8 images, the front one drawn, the back one
  // rebuilt over several frames (a budget of sprites each), then crossfaded.
  ImpostorRing ring_;
  int front_ = 0;
  glm::dvec3 back_centre_{0.0};
  int next_sector_ = -1;                 // sector of the back set being rendered; -1: not building
  std::vector<float> sector_instances_;  // the impostor being rendered, back to front from its centre
  std::size_t sector_drawn_ = 0;         // how many of them are drawn so far
  bool sector_begun_ = false;
  int crossfade_ = -1;                                        // frame of the crossfade; -1: none
  std::vector<SpriteKey> captured_[2];                        // sprites in each set, sorted
  std::array<bool, 8> sector_empty_[2] = {};                  // nothing was rendered into the sector
  std::array<double, 8> tan_low_[2] = {}, tan_high_[2] = {};  // each impostor's vertical extent
  Band band_[2] = {};                                         // the camera's band when each set was captured
  std::array<ColumnSpans, 8> spans_[2] = {};
};

}  // namespace nephos::realtime
