#include "nephos/realtime/gl_renderer.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <unordered_map>

#include "nephos/core/error.hpp"
#include "nephos/realtime/gl_program.hpp"
#include "nephos/realtime/sprite_textures.hpp"

namespace nephos::realtime {
namespace {

constexpr int impostor_size = 256;  // MSFS 2004: eight 256 x 256 impostors
// A ring vertex: the quad corner (the octagon mesh's 3 floats) and the impostor quad's 17
// instance floats, all per vertex, so that every sector's trimmed columns go in one draw.
constexpr std::size_t ring_vertex_floats = 20;
constexpr std::uint32_t lod_index = 0xfffff;  // sprite index of a cloud's LOD sprite (facing-lock key)

}  // namespace

SpriteTrim sprite_trim(const std::uint8_t* rgba, int size) {
  // A bilinear fetch at p is non-zero only if a non-zero texel centre q lies within one texel
  // pitch of p along each axis: |p.x| < |q.x| + pitch, |p.x| + |p.y| < |q.x| + |q.y| + 2 pitch.
  const double pitch = 2.0 / size;  // quad corners at -1 and 1
  double a = -1, b = -1, c = -1;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      if (rgba[(static_cast<std::size_t>(y) * size + x) * 4 + 3] == 0) continue;
      const double u = std::abs((x + 0.5) * pitch - 1), v = std::abs((y + 0.5) * pitch - 1);
      a = std::max(a, u), b = std::max(b, v), c = std::max(c, u + v);
    }
  if (a < 0) return {0, 0, 0};  // transparent: nothing to draw
  return {static_cast<float>(std::min(a + pitch, 1.0)), static_cast<float>(std::min(b + pitch, 1.0)),
          static_cast<float>(std::min(c + 2 * pitch, 2.0))};
}

namespace {

// One shader body for GLSL ES 3.00 and GLSL 3.30 core; only the version line differs.
// Instance data (17 floats): position relative to the camera [m] and size [m]; colour (ambient +
// per-shading-group directional, premultiplied by the cloud's opacity) and alpha; texture layer
// and sheet tiling; bent-normal diffuse colour; fixed facing direction and height/width ratio.
// A flat-layer pair (LAYER_PAIR) reuses the last two: diffuse.z is the farther layer's opacity,
// facing_aspect.x the ratio of its height above (or below) the camera to the nearer one's.
const char* vertex_body = R"(
layout(location = 0) in vec3 vertex;        // an octagon vertex: signs of x and y; 1 if it ends an
                                            // edge |x| = a (else |y| = b): see SpriteTrim
layout(location = 1) in vec4 pos_size;      // position relative to the camera [m], size [m]
layout(location = 2) in vec4 colour_alpha;  // shaded colour, alpha (opacity: formation, crossfade)
layout(location = 3) in vec2 layer_tiles;   // texture layer; y > 0: horizontal sheet tiled y times;
                                            // y < 0: impostor quad (render-to-texture, v flipped)
layout(location = 4) in vec3 diffuse;       // colour of the bent-normal diffuse term (thesis B.7);
                                            // sheets: xy = texture offset [tiles] (ground-fixed)
layout(location = 5) in vec4 facing_aspect; // fixed facing (away from the viewer) and height/width;
                                            // zero: a camera-facing billboard
uniform mat4 view_proj;
uniform vec3 trim[TRIM_LAYERS];  // per texture layer: |x| <= a, |y| <= b, |x| + |y| <= c
uniform vec3 cam_right;
uniform vec3 cam_up;
// Per-instance values are flat: the same at every vertex, and llvmpipe interpolates every
// other component per fragment (flat: sprite frames 7-10 % faster, docs/PERFORMANCE.md).
out vec2 v_uv;
flat out float v_layer;
flat out vec4 v_colour;
flat out vec3 v_diffuse;
#ifdef BENT_NORMAL
uniform vec3 sun_dir;  // towards the sun
uniform vec3 cam_front;
out vec3 v_bend;      // the unnormalised bent normal
out float v_bend_sun; // its dot product with the sun direction
#endif
#ifdef SHEET
uniform vec4 sheet_mean[SHEET_LAYERS];  // each flat-layer texture's mean texel
out vec2 v_rel;        // position relative to the camera on the (nearer) sheet [tiles]
flat out vec4 v_fade;  // distance fade: nearer sheet's scale [1/tiles^2], offset, farther sheet's
                       // scale; 1 / the sheet's half-width^2 [1/tiles^2]
flat out vec4 v_mean;  // the layer texture's mean texel
flat out float v_dz2;  // the (nearer) sheet's height above or below the camera, squared [tiles^2]
#endif
#ifdef LAYER_PAIR
out vec4 v_far;  // the farther layer: texture coordinates [tiles], position [its half-widths]
#endif
void main() {
  // Sprites cover the octagon of their texture layer's non-transparent texels (the fill is the
  // cost on a software rasteriser); other draws set every layer's octagon to the whole quad.
  vec3 t = trim[int(layer_tiles.x)];
  vec2 corner = vertex.xy * (vertex.z > 0.5 ? vec2(t.x, min(t.y, t.z - t.x)) : vec2(min(t.x, t.z - t.y), t.y));
  vec3 ax = cam_right;
  vec3 ay = cam_up;
  float aspect = 1.0;
  if (layer_tiles.y > 0.0) {
    ax = vec3(1.0, 0.0, 0.0);
    ay = vec3(0.0, 1.0, 0.0);
  } else if (dot(facing_aspect.xyz, facing_aspect.xyz) > 0.0) {
    vec3 f = normalize(facing_aspect.xyz);
    ax = normalize(cross(f, vec3(0.0, 0.0, 1.0)));
    ay = cross(ax, f);
    aspect = facing_aspect.w;
  }
  vec3 p = pos_size.xyz + 0.5 * pos_size.w * (corner.x * ax + corner.y * aspect * ay);
  gl_Position = view_proj * vec4(p, 1.0);
  vec2 uv = corner * vec2(0.5, -0.5) + 0.5;
  if (layer_tiles.y < 0.0) uv.y = 1.0 - uv.y;
  v_uv = layer_tiles.y > 0.0 ? uv * layer_tiles.y + diffuse.xy : uv;
  v_layer = layer_tiles.x;
  v_colour = colour_alpha;
  v_diffuse = diffuse;
#ifdef BENT_NORMAL
  // Thesis B.7: the billboard normal, turned to the sun's side of the view, bent outwards by
  // the fragment's offset from the centre (in half-sizes). Both it and its dot product with the
  // sun are affine in the corner, so they interpolate exactly and the fragment only normalises.
  v_bend = (dot(cam_front, sun_dir) < 0.0 ? -cam_front : cam_front) + 0.5 * (corner.x * ax + corner.y * ay);
  v_bend_sun = dot(v_bend, sun_dir);
  // The wrapped diffuse term d (n.l + 1) / 2 as (d / 2) + (d / 2) n.l: the constant half joins
  // the colour here instead of in every fragment.
  v_diffuse = 0.5 * diffuse;
  v_colour.rgb += v_diffuse;
#endif
#ifdef SHEET
  // Flat layers: facing_aspect.yz hold the distance fade's scale and offset (see the fragment
  // shader), facing_aspect.x the farther sheet's height ratio (a pair; its pixel footprint in
  // texels is that many times the nearer sheet's at the same pixel).
  v_rel = (uv - 0.5) * layer_tiles.y;
  v_fade = vec4(facing_aspect.y, facing_aspect.z, facing_aspect.y * facing_aspect.x, 4.0 / (layer_tiles.y * layer_tiles.y));
  v_mean = sheet_mean[int(layer_tiles.x) - FIRST_SHEET_LAYER];
  float dz = pos_size.z * layer_tiles.y / pos_size.w;  // metres to tiles
  v_dz2 = dz * dz;
#endif
#ifdef LAYER_PAIR
  // The view ray through this point of the nearer sheet meets the farther one, k times as far
  // above (below) the camera, at k times the horizontal offset: an affine map of the corner, so
  // interpolated exactly. Both sheets are centred on the camera with the same tiling and offset.
  vec2 far_corner = corner * facing_aspect.x;
  v_far = vec4((far_corner * vec2(0.5, -0.5) + 0.5) * layer_tiles.y + diffuse.xy, far_corner);
#endif
}
)";
const char* fragment_body = R"(
uniform highp sampler2DArray sprites;
in vec2 v_uv;
flat in float v_layer;
flat in vec4 v_colour;
flat in vec3 v_diffuse;
#ifdef BENT_NORMAL
in vec3 v_bend;
in float v_bend_sun;
#endif
#ifdef SHEET
in vec2 v_rel;
flat in vec4 v_fade;
flat in vec4 v_mean;
flat in float v_dz2;
#endif
#ifdef LAYER_PAIR
in vec4 v_far;
#endif
#ifdef SHEET
uniform vec4 under;  // the sky for the first layer of a frame, written without blending; else 0
uniform float view_scale;  // 1, or 0 for the vertical view everywhere (set_layer_views)
#endif
out vec4 frag;
void main() {
#ifdef SHEET
  // Flat layers. Each texel holds the slab seen from the camera's side along the vertical
  // (r: radiance, g: opacity) and at 45 degrees (b, a), premultiplied; a pixel blends the two by
  // its view's elevation, sin^2 of its zenith angle d2 / (dz2 + d2) (0 overhead, 1/2 at 45
  // degrees), the same for both sheets of a pair (one ray). Far out on a sheet a pixel spans
  // many texels and the unfiltered texture aliases (moire at the horizon; mipmaps would add 1-2
  // ms to a frame on llvmpipe, measured). The footprint in texels grows as the squared
  // distance, so the texel fades to the texture's mean from 1 to 4 texels per pixel: a smooth
  // deck towards the horizon, as a filtered texture would show. And the sheet, a finite
  // square, fades out radially from 0.3 of its half-width to its edge, so that the deck
  // dissolves into the sky near the horizon instead of ending at a hard line.
  float d2 = dot(v_rel, v_rel);
#ifdef SLANT_ONLY
  // A frame whose every ray is more than 45 degrees from the vertical: the 45-degree view alone.
  vec2 ca = mix(texture(sprites, vec3(v_uv, v_layer)).ba, v_mean.ba, clamp(d2 * v_fade.x - v_fade.y, 0.0, 1.0));
#else
  float view = clamp(2.0 * d2 / (v_dz2 + d2) * view_scale, 0.0, 1.0);
  vec4 s = mix(texture(sprites, vec3(v_uv, v_layer)), v_mean, clamp(d2 * v_fade.x - v_fade.y, 0.0, 1.0));
  vec2 ca = mix(s.rg, s.ba, view);
#endif
  ca *= clamp((1.0 - d2 * v_fade.w) * EDGE_FADE, 0.0, 1.0);
  vec4 t = vec4(ca.xxx, ca.y);
#else
  vec4 t = texture(sprites, vec3(v_uv, v_layer));  // premultiplied
#endif
  vec3 c = v_colour.rgb;
#ifdef BENT_NORMAL
  // Sprites only: the wrapped diffuse term of the normalised bent normal (see the vertex shader).
  c = min(c + v_diffuse * (v_bend_sun * inversesqrt(dot(v_bend, v_bend))), vec3(1.0));
#endif
  frag = vec4(t.rgb * c, t.a) * v_colour.a;
#ifdef LAYER_PAIR
  // The farther sheet behind the nearer one (faded alike; its footprint and its position in its
  // half-widths are k times the nearer one's): the two "over" blends of separate passes,
  // composited here and blended into the frame once.
#ifdef SLANT_ONLY
  vec2 ca_far = mix(texture(sprites, vec3(v_far.xy, v_layer)).ba, v_mean.ba, clamp(d2 * v_fade.z - v_fade.y, 0.0, 1.0));
#else
  vec4 s_far = mix(texture(sprites, vec3(v_far.xy, v_layer)), v_mean, clamp(d2 * v_fade.z - v_fade.y, 0.0, 1.0));
  vec2 ca_far = mix(s_far.rg, s_far.ba, view);
#endif
  ca_far *= clamp((1.0 - dot(v_far.zw, v_far.zw)) * EDGE_FADE, 0.0, 1.0) * v_diffuse.z;
  frag += (1.0 - frag.a) * vec4(ca_far.x * c, ca_far.y);
#endif
#ifdef SHEET
  frag += (1.0 - frag.a) * under;
#endif
}
)";

// A sprite's identity across frames: its cloud (id, relocations) and its index in the cloud.
struct SpriteKey {
  std::uint64_t cloud;
  std::uint32_t sprite;
  auto operator<=>(const SpriteKey&) const = default;
};

}  // namespace

struct SpriteRenderer::Impl {
  EGLDisplay dpy = EGL_NO_DISPLAY;
  EGLContext ctx = EGL_NO_CONTEXT;
  GLuint fbo = 0, colour = 0, depth = 0, vao = 0, quad = 0, instances = 0, texture = 0;
  // Programs from the same source, each compiled with only what its draws need: sprites with
  // the bent-normal diffuse term; impostor quads and particles without it; single flat layers
  // and pairs of them, each also reading only the 45-degree view (SLANT_ONLY). On llvmpipe a
  // shader pays for a branch's body on every fragment, which made the flat layers cost twice as
  // much.
  struct Program {
    GLuint id = 0;
    GLint u_view_proj = -1, u_right = -1, u_up = -1, u_sprites = -1, u_sun = -1, u_front = -1, u_trim = -1,
          u_under = -1, u_sheet_mean = -1, u_view_scale = -1;
  };
  Program lit, plain, sheet, layer_pair, sheet_slant, layer_pair_slant;
  bool merge_layers = true;                        // draw two flat layers of a type in one pass (set_merge_flat_layers)
  bool trim_sprites = true;                        // sprites cover their layer's octagon (set_trim_sprites)
  bool first_layer_over_sky = true;                // set_first_layer_over_sky
  LayerViews layer_views = LayerViews::automatic;  // set_layer_views
  std::array<float, 3 * texture_layer_count> trim{};   // SpriteTrim per texture layer (a, b, c)
  std::array<float, 4 * 2 * slab_types> sheet_mean{};  // mean texel of each flat-layer texture
  std::vector<std::size_t> order;
  std::uint64_t order_generation = ~0ull;  // which sprite set `order` sorts
  std::vector<float> buffer;
  std::unordered_map<std::uint64_t, glm::vec3> locked;  // facing of sprites the camera is inside
  double single_sprite_distance_m = 0;                  // level of detail (0: every sprite)
  std::uint64_t lod_signature = 0;                      // the clouds drawn as one sprite last frame

  // Impostor ring (MSFS 2004): two sets of 8 layers of 256x256, the front one drawn, the back
  // one being rebuilt over several frames (a budget of sprites each), then crossfaded.
  // The sets are only sampled: each impostor is rendered into one scratch target, read back
  // and copied into its set's layer (llvmpipe samples a texture that was filled by an upload
  // and is attached to no framebuffer faster: docs/PERFORMANCE.md).
  GLuint imp_tex[2] = {0, 0}, imp_fbo = 0, imp_scratch = 0;
  int front = 0;
  ImpostorRing ring;
  glm::dvec3 back_centre{0.0};
  int next_sector = -1;  // sector of the back set being rendered; -1: not building
  // The impostor being rendered into the scratch target, a part per frame within the budget of
  // sprites: its instances, back to front from the ring centre, and how many are drawn so far.
  std::vector<float> sector_instances;
  std::size_t sector_drawn = 0;
  bool sector_begun = false;
  std::size_t impostor_sprite_budget = SpriteRenderer::default_impostor_sprites_per_frame;
  int crossfade = -1;                        // frame of the crossfade; -1: none
  std::vector<SpriteKey> captured[2];        // sprites in each set, sorted
  std::array<bool, 8> sector_empty[2] = {};  // nothing was rendered into the sector
  // Vertical extent of each impostor (set, sector): the tangents of its frustum's bottom and top.
  std::array<double, 8> tan_low[2] = {}, tan_high[2] = {};
  std::array<double, 2> band[2] = {};  // the camera's band between flat layers when each set was captured
  // Per impostor (set, sector) and column: the rows holding clouds, as quad y in [-1, 1]
  // (bottom, top; bottom > top: none), from the texture read back after rendering it.
  struct ColumnSpan {
    float bottom = 1, top = -1;
  };
  std::array<std::array<ColumnSpan, ring_columns>, 8> spans[2] = {};
  bool trim_ring = true;     // set_trim_ring
  bool transparent = false;  // set_background
  GLuint ring_vao = 0, ring_vbo = 0;
  std::vector<float> ring_vertices;  // this frame's ring triangles, ring_vertex_floats each
  std::uint64_t generation = 0;      // bumps when the sprite set changes
};

namespace {

std::uint64_t cloud_key(const SpriteCloud& c) { return (static_cast<std::uint64_t>(c.id) << 32) | c.relocations; }

// The sprites of cloud `c` an impostor set holds: one flag per sprite, by a merge against the
// set's sorted keys (the cloud's keys are contiguous there). Returns whether any is held.
bool captured_sprites(const std::vector<SpriteKey>& set, const SpriteCloud& c, std::vector<char>& held) {
  held.assign(c.sprites.size(), 0);
  const std::uint64_t key = cloud_key(c);
  bool any = false;
  for (auto it = std::lower_bound(set.begin(), set.end(), SpriteKey{key, 0}); it != set.end() && it->cloud == key; ++it)
    if (it->sprite < held.size()) held[it->sprite] = 1, any = true;
  return any;
}

// Radius of the sphere a sprite's billboard stays inside whichever way it faces [m].
double sprite_radius(const Sprite& s) { return 0.5 * M_SQRT2 * s.size_m; }

// Shading of one sprite (MSFS 2004): five colour levels by height within the cloud (dark base,
// white top) times a time-of-day ambient factor, plus a directional term per shading group; the
// bent-normal diffuse term (thesis B.7) is added per fragment.
struct Shade {
  glm::dvec3 colour, diffuse;
};
Shade shade_sprite(const SpriteCloud& cloud, const Sprite& sprite, const SunLight& sun) {
  static const glm::dvec3 levels[5] = {
      {0.45, 0.48, 0.55}, {0.58, 0.61, 0.67}, {0.72, 0.74, 0.78}, {0.86, 0.87, 0.89}, {0.97, 0.97, 0.98}};
  const double ambient = 0.35 + 0.65 * std::clamp(sun.elevation_deg / 30.0, 0.0, 1.0);
  const double h = std::clamp((sprite.offset.z + 300.0) / 1500.0, 0.0, 0.999) * 4;
  const int lo = static_cast<int>(h);
  const glm::dvec3 level = levels[lo] + (h - lo) * (levels[std::min(lo + 1, 4)] - levels[lo]);
  const glm::dvec3 g = glm::dvec3(sprite.offset - cloud.group_centres[static_cast<std::size_t>(sprite.shading_group)]);
  const double dir = glm::length(g) > 1e-6 ? std::max(0.0, glm::dot(glm::normalize(g), sun.direction)) : 0.0;
  return {glm::min(glm::dvec3(1.0), 0.85 * ambient * level + 0.3 * dir * sun.colour), 0.25 * sun.colour};
}

void push_instance(std::vector<float>& b, const glm::dvec3& rel, double size, const glm::dvec3& colour, double alpha,
                   double layer, double tiles, const glm::dvec3& diffuse, const glm::dvec3& facing, double aspect) {
  const float v[17] = {static_cast<float>(rel.x),     static_cast<float>(rel.y),     static_cast<float>(rel.z),
                       static_cast<float>(size),      static_cast<float>(colour.r),  static_cast<float>(colour.g),
                       static_cast<float>(colour.b),  static_cast<float>(alpha),     static_cast<float>(layer),
                       static_cast<float>(tiles),     static_cast<float>(diffuse.r), static_cast<float>(diffuse.g),
                       static_cast<float>(diffuse.b), static_cast<float>(facing.x),  static_cast<float>(facing.y),
                       static_cast<float>(facing.z),  static_cast<float>(aspect)};
  b.insert(b.end(), v, v + 17);
}

double sprite_layer(const SpriteCloud& c, const Sprite& s) {
  return (c.type == SpriteCloudType::cumulus ? 0 : sprite_views_per_type) + s.texture_layer % sprite_views_per_type;
}

// Vertical half-angle of an impostor: clouds up to max_vertical_offset above or below, seen
// from the ring's radius.
double impostor_half_height(const ImpostorRing& ring) { return std::atan(ring.max_vertical_offset_m / ring.radius_m); }

// A sphere of radius r [m] at p seen from a ring centred at `centre`: its horizontal direction
// and angular radius [rad].
struct Bearing {
  double angle, reach;
};
Bearing bearing(const glm::dvec3& p, double r, const glm::dvec3& centre) {
  const glm::dvec2 d{p.x - centre.x, p.y - centre.y};
  return {std::atan2(d.y, d.x), std::asin(std::min(1.0, r / std::max(glm::length(d), 1.0)))};
}
// Whether the sphere may show in impostor sector `sector` (0 = east, CCW): its direction within
// the sector's 45 degrees widened by its angular radius.
bool overlaps_sector(const Bearing& b, int sector) {
  double off = std::fmod(std::abs(b.angle - sector * M_PI / 4), 2 * M_PI);
  off = std::min(off, 2 * M_PI - off);  // angle to the sector's axis
  return off <= M_PI / 8 + b.reach;
}
bool overlaps_sector(const glm::dvec3& p, double r, const glm::dvec3& centre, int sector) {
  return overlaps_sector(bearing(p, r, centre), sector);
}

}  // namespace

std::array<std::uint8_t, 4> SpriteRenderer::sky_colour() { return {110, 160, 225, 255}; }

GlApi gl_api_from_name(const std::string& name) {
  if (name == "gles3") return GlApi::gles30;
  if (name == "gl33") return GlApi::gl33;
  throw ValueError("expected gles3 (OpenGL ES 3.0) or gl33 (OpenGL 3.3 core), got '" + name + "'", {.key = "gl"});
}

const char* name(GlApi api) { return api == GlApi::gl33 ? "gl33" : "gles3"; }

SpriteRenderer::SpriteRenderer(int width, int height, std::uint64_t seed, GlApi api)
    : impl_(std::make_unique<Impl>()), w_(width), h_(height), api_(api) {
  create_context();
  init_gl(seed);
}

SpriteRenderer::SpriteRenderer(UseCurrentContext, int width, int height, std::uint64_t seed, GlApi api)
    : impl_(std::make_unique<Impl>()), w_(width), h_(height), api_(api) {
  init_gl(seed);
}

namespace {
// Headless renderers alive: they share the EGL display (EGL hands out one per device), which
// eglTerminate would pull from under the others, so the last one terminates it.
std::atomic<int> live_headless_renderers{0};
}  // namespace

void SpriteRenderer::create_context() {
  auto& m = *impl_;
  auto get_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  m.dpy = get_display ? get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr) : EGL_NO_DISPLAY;
  if (m.dpy == EGL_NO_DISPLAY) m.dpy = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  EGLint major = 0, minor = 0;
  if (m.dpy == EGL_NO_DISPLAY || !eglInitialize(m.dpy, &major, &minor))
    throw IoError("EGL: no display could be initialised");
  const bool desktop = api_ == GlApi::gl33;
  if (!eglBindAPI(desktop ? EGL_OPENGL_API : EGL_OPENGL_ES_API))
    throw IoError(desktop ? "EGL: the desktop OpenGL API is not available" : "EGL: OpenGL ES is not available");
  const EGLint cfg_attr[] = {EGL_RENDERABLE_TYPE, desktop ? EGL_OPENGL_BIT : EGL_OPENGL_ES3_BIT, EGL_NONE};
  EGLConfig cfg = nullptr;
  EGLint n = 0;
  eglChooseConfig(m.dpy, cfg_attr, &cfg, 1, &n);
  const EGLint es_attr[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0, EGL_NONE};
  const EGLint gl_attr[] = {
      EGL_CONTEXT_MAJOR_VERSION,           3,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  m.ctx = eglCreateContext(m.dpy, n ? cfg : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, desktop ? gl_attr : es_attr);
  if (m.ctx == EGL_NO_CONTEXT || !eglMakeCurrent(m.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, m.ctx))
    throw IoError(desktop ? "EGL: cannot create an OpenGL 3.3 core context"
                          : "EGL: cannot create an OpenGL ES 3.0 context");
  ++live_headless_renderers;
}

void SpriteRenderer::make_current() {
  auto& m = *impl_;
  if (m.dpy != EGL_NO_DISPLAY && !eglMakeCurrent(m.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, m.ctx))
    throw IoError("EGL: eglMakeCurrent failed for a sprite renderer's context");
}

void SpriteRenderer::release_current() {
  auto& m = *impl_;
  if (m.dpy != EGL_NO_DISPLAY && !eglMakeCurrent(m.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT))
    throw IoError("EGL: eglMakeCurrent failed to release a sprite renderer's context");
}

void SpriteRenderer::init_gl(std::uint64_t seed) {
  auto& m = *impl_;
  // The frame is one renderbuffer: its side is bounded by the implementation (16384 on
  // llvmpipe), beyond which the framebuffer would only be "incomplete".
  GLint max_side = 0;
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_side);
  if (w_ > max_side || h_ > max_side)
    throw ValueError(
        fmt::format("a {}x{} frame exceeds this OpenGL's largest framebuffer, {} pixels per side", w_, h_, max_side),
        {.key = "size"});
  glGenFramebuffers(1, &m.fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glGenRenderbuffers(1, &m.colour);
  glBindRenderbuffer(GL_RENDERBUFFER, m.colour);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w_, h_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, m.colour);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw IoError("OpenGL ES: framebuffer incomplete");

  // The one difference between the APIs' shaders: GLSL ES 3.00 and GLSL 3.30 share every
  // construct used here, and 3.30 accepts (and ignores) the precision statements.
  const std::string version = std::string(api_ == GlApi::gl33 ? "#version 330 core\n" : "#version 300 es\n") +
                              "precision highp float;\nprecision highp sampler2DArray;\n#define TRIM_LAYERS " +
                              std::to_string(texture_layer_count) + "\n";
  auto link = [&](Impl::Program& p, const std::string& defines) {
    p.id = link_program(version + defines + vertex_body, version + defines + fragment_body);
    p.u_view_proj = glGetUniformLocation(p.id, "view_proj");
    p.u_right = glGetUniformLocation(p.id, "cam_right");
    p.u_up = glGetUniformLocation(p.id, "cam_up");
    p.u_sprites = glGetUniformLocation(p.id, "sprites");
    p.u_sun = glGetUniformLocation(p.id, "sun_dir");
    p.u_front = glGetUniformLocation(p.id, "cam_front");
    p.u_trim = glGetUniformLocation(p.id, "trim");
    p.u_under = glGetUniformLocation(p.id, "under");
    p.u_sheet_mean = glGetUniformLocation(p.id, "sheet_mean");
    p.u_view_scale = glGetUniformLocation(p.id, "view_scale");
    // The layer textures' mean texels never change: set once, kept by the program.
    if (p.u_sheet_mean >= 0) {
      glUseProgram(p.id);
      glUniform4fv(p.u_sheet_mean, 2 * slab_types, m.sheet_mean.data());
    }
  };
  const auto pixels = bake_sprite_textures(seed);
  // Each flat-layer texture's mean texel, the value a fully filtered lookup converges to far out
  // on a sheet (a uniform per layer, read by the vertex shader).
  for (int l = 0; l < 2 * slab_types; ++l) {
    const std::array<float, 4> mean = layer_mean_texel(pixels, first_slab_layer + l);
    std::copy(mean.begin(), mean.end(), m.sheet_mean.begin() + 4 * l);
  }
  const std::string sheet = "#define SHEET 1\n#define FIRST_SHEET_LAYER " + std::to_string(first_slab_layer) +
                            "\n#define SHEET_LAYERS " + std::to_string(2 * slab_types) + "\n#define EDGE_FADE " +
                            fmt::format("{:.9g}", 1 / (1 - 0.3 * 0.3)) + "\n";
  link(m.lit, "#define BENT_NORMAL 1\n");
  link(m.plain, "");
  link(m.sheet, sheet);
  link(m.layer_pair, sheet + "#define LAYER_PAIR 1\n");
  link(m.sheet_slant, sheet + "#define SLANT_ONLY 1\n");
  link(m.layer_pair_slant, sheet + "#define SLANT_ONLY 1\n#define LAYER_PAIR 1\n");

  for (int l = 0; l < texture_layer_count; ++l) {
    const SpriteTrim t =
        sprite_trim(pixels.data() + static_cast<std::size_t>(l) * sprite_texture_size * sprite_texture_size * 4,
                    sprite_texture_size);
    m.trim[3 * l] = t.a, m.trim[3 * l + 1] = t.b, m.trim[3 * l + 2] = t.c;
  }
  glGenTextures(1, &m.texture);
  glBindTexture(GL_TEXTURE_2D_ARRAY, m.texture);
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA8, sprite_texture_size, sprite_texture_size, texture_layer_count, 0,
               GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  // No mipmaps: on llvmpipe they cost 25-40 % of the frame (measured), more than the shimmer of
  // the tiled sheets near the horizon is worth.
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  // Repeat, for the tiled sheets; sprites stay in [0, 1] and fade to zero at their edges.
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_REPEAT);

  glGenVertexArrays(1, &m.vao);
  glBindVertexArray(m.vao);
  // Vertices 0-7: the octagon |x| <= a, |y| <= b, |x| + |y| <= c as one triangle strip,
  // zigzagging between its right and left halves; per vertex the signs of x and y and whether it
  // ends an edge |x| = a (1) or |y| = b (0). Vertices 8-11: the whole quad (a = b = 1, c = 2),
  // for the other draws: for tiny sprites the octagon's four extra triangles cost more than the
  // pixels they spare (the particle benchmark's 100 000 point sprites: 37 -> 58 ms).
  // clang-format off
  const float mesh[12 * 3] = {1, 1, 1,   1, -1, 1,   1, 1, 0,    1, -1, 0,
                              -1, 1, 0,  -1, -1, 0,  -1, 1, 1,   -1, -1, 1,
                              -1, -1, 1, 1, -1, 1,   -1, 1, 1,   1, 1, 1};
  // clang-format on
  glGenBuffers(1, &m.quad);
  glBindBuffer(GL_ARRAY_BUFFER, m.quad);
  glBufferData(GL_ARRAY_BUFFER, sizeof mesh, mesh, GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glGenBuffers(1, &m.instances);
  glBindBuffer(GL_ARRAY_BUFFER, m.instances);
  // Per-instance attributes, 17 floats: location, component count, offset [floats].
  constexpr GLsizei stride = 17 * sizeof(float);
  constexpr struct {
    GLuint location;
    GLint size;
    std::size_t offset;
  } instance_attributes[] = {{1, 4, 0}, {2, 4, 4}, {3, 2, 8}, {4, 3, 10}, {5, 4, 13}};
  for (const auto& a : instance_attributes) {
    glEnableVertexAttribArray(a.location);
    glVertexAttribPointer(a.location, a.size, GL_FLOAT, GL_FALSE, stride,
                          reinterpret_cast<void*>(a.offset * sizeof(float)));
    glVertexAttribDivisor(a.location, 1);
  }
  // The impostor ring's triangles: the same attributes, all per vertex (ring_vertex_floats).
  glGenVertexArrays(1, &m.ring_vao);
  glBindVertexArray(m.ring_vao);
  glGenBuffers(1, &m.ring_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, m.ring_vbo);
  constexpr GLsizei ring_stride = ring_vertex_floats * sizeof(float);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, ring_stride, nullptr);
  for (const auto& a : instance_attributes) {
    glEnableVertexAttribArray(a.location);
    glVertexAttribPointer(a.location, a.size, GL_FLOAT, GL_FALSE, ring_stride,
                          reinterpret_cast<void*>((3 + a.offset) * sizeof(float)));
  }
  glBindVertexArray(m.vao);

  // Impostor textures: 2 sets x 8 sectors x 256 x 256 RGBA8 (premultiplied), 2 MiB per set.
  glGenTextures(2, m.imp_tex);
  for (GLuint t : m.imp_tex) {
    glBindTexture(GL_TEXTURE_2D_ARRAY, t);
    glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA8, impostor_size, impostor_size, 8, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                 nullptr);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  glGenFramebuffers(1, &m.imp_fbo);
  glGenRenderbuffers(1, &m.imp_scratch);
  glBindRenderbuffer(GL_RENDERBUFFER, m.imp_scratch);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, impostor_size, impostor_size);
  glBindFramebuffer(GL_FRAMEBUFFER, m.imp_fbo);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, m.imp_scratch);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw IoError("OpenGL ES: impostor framebuffer incomplete");
}

SpriteRenderer::~SpriteRenderer() {
  auto& m = *impl_;
  if (m.dpy != EGL_NO_DISPLAY) {
    // Released only if it is this renderer's: another renderer's context may be current.
    if (eglGetCurrentContext() == m.ctx) eglMakeCurrent(m.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (m.ctx != EGL_NO_CONTEXT) eglDestroyContext(m.dpy, m.ctx);
    if (m.ctx != EGL_NO_CONTEXT && --live_headless_renderers == 0) eglTerminate(m.dpy);
  }
}

void SpriteRenderer::begin_pass(const Target& target, unsigned texture, bool clear, Shading shading, bool over_sky,
                                bool trimmed) {
  auto& m = *impl_;
  const Camera& cam = target.camera;
  // Camera matrices (camera at the origin: positions are relative, which keeps float precision).
  const glm::dvec3 f = glm::normalize(cam.forward), r = glm::normalize(glm::cross(f, cam.up)), u = glm::cross(r, f);
  const double tlo = target.tan_y_low, thi = target.tan_y_high, tx = target.tan_half_x, zn = 10, zf = cam.far_m;
  glm::mat4 view(1.0f), proj(0.0f);
  for (int i = 0; i < 3; ++i) {
    view[i][0] = static_cast<float>(r[i]);
    view[i][1] = static_cast<float>(u[i]);
    view[i][2] = static_cast<float>(-f[i]);
  }
  proj[0][0] = static_cast<float>(1 / tx);
  proj[1][1] = static_cast<float>(2 / (thi - tlo));
  proj[2][1] = static_cast<float>((thi + tlo) / (thi - tlo));  // off-centre (impostors look up or down)
  proj[2][2] = static_cast<float>(-(zf + zn) / (zf - zn));
  proj[2][3] = -1;
  proj[3][2] = static_cast<float>(-2 * zf * zn / (zf - zn));
  const glm::mat4 vp = proj * view;

  glBindFramebuffer(GL_FRAMEBUFFER, target.fbo);
  glViewport(0, 0, target.width, target.height);
  if (clear) {
    glClearColor(target.clear[0], target.clear[1], target.clear[2], target.clear[3]);
    glClear(GL_COLOR_BUFFER_BIT);
  }
  if (over_sky) {
    glDisable(GL_BLEND);
  } else {
    glEnable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);  // premultiplied alpha
  }
  const Impl::Program& p = shading == Shading::bent_normal        ? m.lit
                           : shading == Shading::layer_pair       ? m.layer_pair
                           : shading == Shading::sheet            ? m.sheet
                           : shading == Shading::layer_pair_slant ? m.layer_pair_slant
                           : shading == Shading::sheet_slant      ? m.sheet_slant
                                                                  : m.plain;
  glUseProgram(p.id);
  glUniformMatrix4fv(p.u_view_proj, 1, GL_FALSE, &vp[0][0]);
  glUniform3f(p.u_right, static_cast<float>(r.x), static_cast<float>(r.y), static_cast<float>(r.z));
  glUniform3f(p.u_up, static_cast<float>(u.x), static_cast<float>(u.y), static_cast<float>(u.z));
  glUniform3f(p.u_front, static_cast<float>(f.x), static_cast<float>(f.y), static_cast<float>(f.z));
  glUniform3f(p.u_sun, static_cast<float>(target.sun.x), static_cast<float>(target.sun.y),
              static_cast<float>(target.sun.z));
  glUniform1i(p.u_sprites, 0);
  if (p.u_under >= 0) {
    static constexpr std::array<float, 4> none{};
    glUniform4fv(p.u_under, 1, over_sky ? target.clear.data() : none.data());
  } else if (over_sky) {
    throw ValueError("only flat layers are drawn over the sky without blending", {.key = "shading"});
  }
  // Sprites (the bent-normal draws) over their layer's octagon; flat layers, impostor quads and
  // point sprites over the whole quad.
  static constexpr std::array<float, 3 * texture_layer_count> whole_quads = [] {
    std::array<float, 3 * texture_layer_count> q{};
    for (int l = 0; l < texture_layer_count; ++l) q[3 * l] = q[3 * l + 1] = 1, q[3 * l + 2] = 2;
    return q;
  }();
  glUniform3fv(p.u_trim, texture_layer_count, trimmed ? m.trim.data() : whole_quads.data());
  if (p.u_view_scale >= 0) glUniform1f(p.u_view_scale, m.layer_views == LayerViews::vertical ? 0.0f : 1.0f);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D_ARRAY, texture);
}

void SpriteRenderer::submit(const Target& target, std::size_t first, std::size_t count, unsigned texture, bool clear,
                            Shading shading, bool over_sky) {
  auto& m = *impl_;
  const bool trimmed = shading == Shading::bent_normal && m.trim_sprites;
  if (count == 0) {  // at most a clear (the sky)
    if (clear) {
      glBindFramebuffer(GL_FRAMEBUFFER, target.fbo);
      glViewport(0, 0, target.width, target.height);
      glClearColor(target.clear[0], target.clear[1], target.clear[2], target.clear[3]);
      glClear(GL_COLOR_BUFFER_BIT);
    }
    return;
  }
  begin_pass(target, texture, clear, shading, over_sky, trimmed);
  glBindVertexArray(m.vao);
  glBindBuffer(GL_ARRAY_BUFFER, m.instances);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(count * 17 * sizeof(float)), m.buffer.data() + first * 17,
               GL_STREAM_DRAW);
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, trimmed ? 0 : 8, trimmed ? 8 : 4, static_cast<GLsizei>(count));
}

void SpriteRenderer::submit_ring(const Target& target, std::size_t first, std::size_t count, unsigned texture) {
  auto& m = *impl_;
  if (count == 0) return;
  begin_pass(target, texture, false, Shading::plain, false, false);
  glBindVertexArray(m.ring_vao);
  glBindBuffer(GL_ARRAY_BUFFER, m.ring_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(count * ring_vertex_floats * sizeof(float)),
               m.ring_vertices.data() + first * ring_vertex_floats, GL_STREAM_DRAW);
  glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(count));
}

SpriteRenderer::Target SpriteRenderer::screen(const Camera& cam, const SunLight& sun) const {
  Target t;
  t.camera = cam;
  t.fbo = impl_->fbo;
  t.width = w_, t.height = h_;
  t.tan_y_high = std::tan(0.5 * cam.fov_deg * M_PI / 180);
  t.tan_y_low = -t.tan_y_high;
  t.tan_half_x = t.tan_y_high * w_ / h_;
  const auto sky = sky_colour();
  t.clear = impl_->transparent ? std::array<float, 4>{0, 0, 0, 0}
                               : std::array<float, 4>{sky[0] / 255.0f, sky[1] / 255.0f, sky[2] / 255.0f, 1.0f};
  t.sun = sun.direction;
  return t;
}

SpriteRenderer::Target SpriteRenderer::impostor_target(int set, int sector, const SunLight& sun,
                                                       const Camera& cam) const {
  const auto& m = *impl_;
  const double a = sector * M_PI / 4;  // 0 = east, counter-clockwise (ImpostorRing::sector)
  // At the ring centre, which is the origin of the instances' positions (begin_impostor).
  Target t;
  t.camera.forward = {std::cos(a), std::sin(a), 0};
  t.camera.up = {0, 0, 1};
  t.camera.far_m = cam.far_m;
  t.fbo = m.imp_fbo;
  t.width = t.height = impostor_size;
  t.tan_half_x = std::tan(M_PI / 8);
  t.tan_y_low = m.tan_low[set][static_cast<std::size_t>(sector)];
  t.tan_y_high = m.tan_high[set][static_cast<std::size_t>(sector)];
  t.clear = {0, 0, 0, 0};
  t.sun = sun.direction;
  return t;
}

void SpriteRenderer::begin_impostor(int set, int sector, const glm::dvec3& centre, const CloudField& field,
                                    const SunLight& sun) {
  auto& m = *impl_;
  // The captured sprites that overlap this 45-degree sector, back to front from the ring centre,
  // shaded now: the parts drawn in later frames show the clouds as they were at this frame (the
  // clouds drift with the air, as the ring's centre does, so their offsets from it hold).
  std::vector<glm::dvec3> pos;
  std::vector<std::pair<const SpriteCloud*, const Sprite*>> items;
  std::vector<char> held;
  for (const auto& c : field.clouds()) {
    if (!captured_sprites(m.captured[set], c, held) || !overlaps_sector(c.centre, c.radius_m, centre, sector)) continue;
    for (std::size_t k = 0; k < c.sprites.size(); ++k) {
      const glm::dvec3 p = c.centre + glm::dvec3(c.sprites[k].offset);
      if (!held[k] || !overlaps_sector(p, sprite_radius(c.sprites[k]), centre, sector)) continue;
      pos.push_back(p);
      items.push_back({&c, &c.sprites[k]});
    }
  }
  const auto order = back_to_front(pos, centre);
  m.sector_instances.clear();
  for (std::size_t k : order) {
    const Shade sh = shade_sprite(*items[k].first, *items[k].second, sun);
    push_instance(m.sector_instances, pos[k] - centre, items[k].second->size_m, sh.colour, items[k].first->opacity,
                  sprite_layer(*items[k].first, *items[k].second), 0.0, sh.diffuse, glm::dvec3(0.0), 1.0);
  }
  m.sector_drawn = 0;
}

std::size_t SpriteRenderer::continue_impostor(int set, int sector, std::size_t budget, const SunLight& sun,
                                              const Camera& cam, bool& complete) {
  auto& m = *impl_;
  const std::size_t total = m.sector_instances.size() / 17;
  const std::size_t count = std::min(budget, total - m.sector_drawn);
  const bool first = m.sector_drawn == 0;
  if (count > 0) {
    // Each part blends over the parts before it in the scratch target, which keeps what they
    // drew between frames: the image is the one a single draw of every sprite would give.
    m.buffer.assign(m.sector_instances.begin() + static_cast<std::ptrdiff_t>(17 * m.sector_drawn),
                    m.sector_instances.begin() + static_cast<std::ptrdiff_t>(17 * (m.sector_drawn + count)));
    submit(impostor_target(set, sector, sun, cam), 0, count, m.texture, first, Shading::bent_normal);
    m.sector_drawn += count;
  }
  complete = m.sector_drawn == total;
  if (!complete) return count;
  // The columns that hold clouds, for the ring's draw (set_trim_ring). A pixel of the ring
  // samples the texture bilinearly, so a column's span covers the texels whose footprint
  // reaches into it (one texel beyond each side) and half a texel more above and below; outside
  // it every sample is transparent and blending it would change nothing. Reading the image
  // back waits for its rendering, which the frame's glFinish would wait for anyway; the same
  // texels then go into the set's layer.
  auto& spans = m.spans[set][static_cast<std::size_t>(sector)];
  spans.fill({});
  m.sector_empty[set][static_cast<std::size_t>(sector)] = true;
  if (total == 0) return count;
  static thread_local std::vector<std::uint8_t> rgba;
  rgba.resize(4 * static_cast<std::size_t>(impostor_size) * impostor_size);
  glBindFramebuffer(GL_FRAMEBUFFER, m.imp_fbo);
  glReadPixels(0, 0, impostor_size, impostor_size, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());  // rows from the bottom
  glBindTexture(GL_TEXTURE_2D_ARRAY, m.imp_tex[set]);
  glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, sector, impostor_size, impostor_size, 1, GL_RGBA, GL_UNSIGNED_BYTE,
                  rgba.data());
  constexpr int column = impostor_size / ring_columns;
  bool any = false;
  for (int c = 0; c < ring_columns; ++c) {
    int lo = impostor_size, hi = -1;
    const int x0 = std::max(0, c * column - 1), x1 = std::min(impostor_size, (c + 1) * column + 1);
    for (int y = 0; y < impostor_size; ++y) {
      const std::uint8_t* row = rgba.data() + 4 * static_cast<std::size_t>(y) * impostor_size;
      for (int x = x0; x < x1; ++x)
        if (row[4 * x + 3] != 0) {
          lo = std::min(lo, y), hi = y;
          break;
        }
    }
    if (hi < lo) continue;
    any = true;
    // Texel row r spans quad y 2 r / size - 1 .. 2 (r + 1) / size - 1; the bilinear reach adds
    // half a texel each way, and another half keeps clear of the rounding of interpolation.
    auto quad_y = [](double row) { return static_cast<float>(std::clamp(2 * row / impostor_size - 1, -1.0, 1.0)); };
    spans[static_cast<std::size_t>(c)] = {quad_y(lo - 1), quad_y(hi + 2)};
  }
  m.sector_empty[set][static_cast<std::size_t>(sector)] = !any;
  return count;
}

FrameStats SpriteRenderer::draw(const CloudField& field, const Camera& cam, const SunLight& sun, bool sort,
                                bool impostors) {
  auto& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  FrameStats stats;
  // The impostor ring lives in the frame of the (drifting) air, like the clouds it holds: its
  // centre and the re-render thresholds are measured there, and its quads drift with the wind.
  const glm::dvec3 air(field.drift_offset_m(), 0.0), cam_air = cam.position - air;
  // The camera's band: between the nearest flat layers below and above it. A sprite beyond one
  // of them is hidden by it wherever the layer covers it (every ray from the camera to the
  // sprite crosses the layer's plane), so it is drawn before the flat layers, and it stays out
  // of the impostors, which are drawn after them.
  double band_lo = -1e300, band_hi = 1e300;
  for (const auto& l : field.layers()) {
    if (!(l.opacity > 0)) continue;
    if (l.altitude_m > cam.position.z)
      band_hi = std::min(band_hi, l.altitude_m);
    else
      band_lo = std::max(band_lo, l.altitude_m);
  }
  auto in_band = [&](double z) { return z > band_lo && z < band_hi; };
  // The sprites an impostor set holds, and the vertical extent of its images. MSFS 2004 "renders
  // only the sections beyond the radius into impostors"; nephos decides per sprite, so a cloud
  // across the ring has its far sprites in the impostor and its near ones drawn as sprites (in
  // front, being nearer). MSFS moves the impostors up or down to where the clouds are; nephos
  // fits an off-centre frustum to them per sector (within the +-10,000 ft rule's angle), so
  // their texels and fill cover clouds, not sky. In an impostor a sprite is a billboard
  // parallel to the image plane, at its centre's depth along the sector's axis, so the tangents
  // of its bottom and top edges are exact: (z -+ size / 2) / depth.
  auto capture = [&](int set, const glm::dvec3& centre) {
    m.band[set] = {band_lo, band_hi};
    std::vector<SpriteKey> keys;
    std::array<double, 8> lo, hi;
    lo.fill(1e9), hi.fill(-1e9);
    // Forming clouds (relocated ahead, or new weather) go in at the opacity they have when their
    // sector is rendered and keep it until the ring is made again (MSFS 2004: an impostor
    // stands for its clouds as they were); dissipating ones stay sprites, so that they go.
    for (const auto& c : field.clouds()) {
      if (c.fade_to != 1 || !(c.opacity > 0)) continue;
      for (std::uint32_t k = 0; k < c.sprites.size(); ++k) {
        const Sprite& sp = c.sprites[k];
        const glm::dvec3 p = c.centre + glm::dvec3(sp.offset);
        const double r = sprite_radius(sp);
        if (!m.ring.in_impostor(p, r, centre) || !in_band(p.z)) continue;
        keys.push_back({cloud_key(c), k});
        const Bearing b = bearing(p, r, centre);  // once, not per sector
        for (std::size_t s = 0; s < 8; ++s) {
          const int sector = static_cast<int>(s);
          if (!overlaps_sector(b, sector)) continue;
          const double a = sector * M_PI / 4;
          const double depth = (p.x - centre.x) * std::cos(a) + (p.y - centre.y) * std::sin(a);  // > 0.9 radius
          lo[s] = std::min(lo[s], (p.z - 0.5 * sp.size_m - centre.z) / depth);
          hi[s] = std::max(hi[s], (p.z + 0.5 * sp.size_m - centre.z) / depth);
        }
      }
    }
    std::sort(keys.begin(), keys.end());
    m.captured[set] = std::move(keys);
    // A margin of 0.02 (a few texels) keeps the bilinear footprint of the edge texels inside.
    const double limit = std::tan(impostor_half_height(m.ring));
    for (std::size_t s = 0; s < 8; ++s) {
      m.tan_low[set][s] = hi[s] > lo[s] ? std::max(-limit, lo[s] - 0.02) : -limit;
      m.tan_high[set][s] = hi[s] > lo[s] ? std::min(limit, hi[s] + 0.02) : limit;
    }
  };
  // ---- Impostor ring upkeep: once the ring exists, a budget of sprites per frame goes into the
  // new set while it is built.
  double back_weight = 0;  // crossfade weight of the back set
  if (impostors && m.ring.valid && m.band[m.front] != std::array<double, 2>{band_lo, band_hi}) {
    // The camera crossed a flat layer (or one formed or went): the sprites the impostors hold
    // are no longer those it may draw after the layers; all eight are made again now.
    m.ring.valid = false;
  }
  if (!impostors) {
    if (m.ring.valid) ++m.generation;
    m.ring.valid = false;
    m.next_sector = m.crossfade = -1;
  } else if (!m.ring.valid) {
    // The first frame, a new radius or a flat layer crossed: the whole front set at once; a set
    // being built for the old ring is dropped.
    m.next_sector = m.crossfade = -1;
    capture(m.front, cam.position);
    for (int k = 0; k < 8; ++k) {
      begin_impostor(m.front, k, cam.position, field, sun);
      bool complete = false;
      stats.impostor_sprites += continue_impostor(m.front, k, SIZE_MAX, sun, cam, complete);
    }
    stats.impostor_updates = 8;
    m.ring.rebuilt_at(cam_air);
    ++m.generation;
  } else {
    const int back = 1 - m.front;
    if (m.next_sector < 0 && m.crossfade < 0 && m.ring.needs_update(cam_air)) {
      m.back_centre = cam_air;
      capture(back, cam.position);
      m.next_sector = 0;
      m.sector_begun = false;
    }
    if (m.next_sector >= 0) {
      // The new set's sprites go into its impostors a budget of them per frame (MSFS 2004's
      // software path: "one 16-square-kilometer cloud block per frame"), a sector ahead full of
      // clouds over several frames, a few nearly empty ones in one.
      std::size_t budget = m.impostor_sprite_budget;
      while (m.next_sector >= 0) {
        if (!m.sector_begun) {
          begin_impostor(back, m.next_sector, m.back_centre + air, field, sun);
          m.sector_begun = true;
        }
        bool complete = false;
        const std::size_t drawn = continue_impostor(back, m.next_sector, budget, sun, cam, complete);
        ++stats.impostor_updates;
        stats.impostor_sprites += drawn;
        budget -= drawn;
        if (!complete) break;
        m.sector_begun = false;
        if (++m.next_sector == 8) m.next_sector = -1, m.crossfade = 0;
        if (budget == 0) break;
      }
    } else if (m.crossfade >= 0) {
      back_weight = (m.crossfade + 1.0) / (crossfade_frames + 1.0);  // 1 / (N + 1) ... N / (N + 1)
      ++m.generation;
      if (++m.crossfade > crossfade_frames) {  // the new set takes over
        m.front = back;
        m.ring.rebuilt_at(m.back_centre);
        m.crossfade = -1;
        back_weight = 0;
      }
    }
  }
  const int back = 1 - m.front;
  const bool fading_sets = back_weight > 0;

  // ---- The ring's triangles (their own texture and vertex layout), then the instances: flat
  // layers and sprites.
  m.buffer.clear();
  m.ring_vertices.clear();
  // Each impostor is a quad on its sector's image plane at the ring radius, facing the ring's
  // centre, so that from the centre it shows exactly what was rendered into it; it is drawn
  // over the columns of its texture that hold clouds (set_trim_ring), two triangles each from
  // the column's left to its right edge. At an edge shared by two columns the bottom is the
  // lower and the top the higher of their spans, the same two vertices for both, so the
  // columns meet without cracks or overlaps, and each column's trapezoid contains its span.
  std::size_t ring_vertex_count[2] = {0, 0};  // front set, back set
  double ring_area = 0, quad_area = 0;        // in quad units (4 per impostor)
  if (impostors && m.ring.valid) {
    const double w = 2 * m.ring.radius_m * std::tan(M_PI / 8);
    std::vector<float> quad;  // one impostor's 17 instance floats
    for (int which = 0; which < 2; ++which) {
      const double weight = which == 0 ? 1 - back_weight : back_weight;
      if (weight <= 0) continue;
      const int set = which == 0 ? m.front : back;
      const glm::dvec3 centre = which == 0 ? m.ring.centre : m.back_centre;
      const std::size_t before = m.ring_vertices.size();
      for (int k = 0; k < 8; ++k) {
        const auto s = static_cast<std::size_t>(k);
        if (m.sector_empty[set][s]) continue;  // no fill for empty sky
        const double aspect = (m.tan_high[set][s] - m.tan_low[set][s]) / (2 * std::tan(M_PI / 8));
        const double lift = 0.5 * (m.tan_high[set][s] + m.tan_low[set][s]) * m.ring.radius_m;
        const double a = k * M_PI / 4;
        const glm::dvec3 d{std::cos(a), std::sin(a), 0};
        quad.clear();
        push_instance(quad, centre + air + m.ring.radius_m * d + glm::dvec3{0, 0, lift} - cam.position, w,
                      glm::dvec3(1.0), weight, k, -1.0, glm::dvec3(0.0), d, aspect);
        auto vertex = [&](float x, float y) {
          m.ring_vertices.insert(m.ring_vertices.end(), {x, y, 0.0f});
          m.ring_vertices.insert(m.ring_vertices.end(), quad.begin(), quad.end());
        };
        auto trapezoid = [&](float x0, float x1, float b0, float top0, float b1, float top1) {
          vertex(x0, b0), vertex(x1, b1), vertex(x0, top0);
          vertex(x0, top0), vertex(x1, b1), vertex(x1, top1);
          ring_area += 0.5 * ((top0 - b0) + (top1 - b1)) * (x1 - x0);
        };
        quad_area += 4;
        if (!m.trim_ring) {
          trapezoid(-1, 1, -1, 1, -1, 1);
          continue;
        }
        const auto& spans = m.spans[set][s];
        // Bottom and top at the edge between columns c - 1 and c (c = 0 .. ring_columns).
        auto edge = [&](int c) {
          Impl::ColumnSpan e;
          for (int n : {c - 1, c})
            if (n >= 0 && n < ring_columns &&
                spans[static_cast<std::size_t>(n)].bottom <= spans[static_cast<std::size_t>(n)].top)
              e.bottom = std::min(e.bottom, spans[static_cast<std::size_t>(n)].bottom),
              e.top = std::max(e.top, spans[static_cast<std::size_t>(n)].top);
          return e;
        };
        for (int c = 0; c < ring_columns; ++c) {
          const Impl::ColumnSpan& span = spans[static_cast<std::size_t>(c)];
          if (span.bottom > span.top) continue;  // no clouds in this column
          const Impl::ColumnSpan e0 = edge(c), e1 = edge(c + 1);
          const float x0 = 2.0f * static_cast<float>(c) / ring_columns - 1,
                      x1 = 2.0f * static_cast<float>(c + 1) / ring_columns - 1;
          trapezoid(x0, x1, e0.bottom, e0.top, e1.bottom, e1.top);
        }
      }
      ring_vertex_count[which] = (m.ring_vertices.size() - before) / ring_vertex_floats;
    }
  }
  stats.ring_coverage = quad_area > 0 ? ring_area / quad_area : 0.0;
  // Flat layers (altostratus, cirrus, fog), farthest altitude first: wide horizontal sheets
  // centred under/over the camera, drawn behind the sprite clouds. Two layers of one type next to
  // each other on the same side of the camera are one quad, the nearer sheet's, whose shader
  // composites the farther sheet behind it (LAYER_PAIR): a frame on the software rasteriser
  // costs its fill, and an overcast deck of two altostratus sheets would otherwise fill the
  // upper half of the frame twice. Layers above and below the camera cover disjoint parts of
  // the frame, so only the order within a side matters.
  const double ambient = 0.35 + 0.65 * std::clamp(sun.elevation_deg / 30.0, 0.0, 1.0);
  // A layer's texture holds its slab's radiance (relative to the light falling on it) and
  // opacity, seen from the camera's side (sprite_textures.hpp); the light is the sprites'
  // time-of-day ambient plus a sun term, the opacity is scaled by the layer's formation fade.
  struct LayerStyle {
    glm::dvec3 light;
    double alpha, tile_m;
    int type;  // slab type: altostratus, cirrus, low stratus
  };
  auto style = [&](const FlatLayer& l) {
    const int type = l.type == SpriteCloudType::cirrus ? 1 : l.type == SpriteCloudType::low_stratus ? 2 : 0;
    const glm::dvec3 light = glm::min(glm::dvec3(1.0), ambient + 0.15 * std::max(0.0, sun.direction.z) * sun.colour);
    return LayerStyle{light, double{l.opacity}, type == 1 ? 6000.0 : 3000.0, type};
  };
  std::vector<std::pair<Shading, std::size_t>> layer_runs;  // consecutive draws of one shader
  bool first_layer_above = false;                           // the first layer drawn is above the camera
  // Whether a ray of the frame comes within 45 degrees (plus a margin) of the nadir or the
  // zenith: only then does a layer on that side show its vertical view (its shader's weight of
  // the 45-degree view is 1 for every ray further from the vertical). The frustum's extreme
  // elevations lie on its boundary; it is sampled densely, with a degree to spare.
  bool steep_view[2] = {false, false};  // below, above
  const Target target = screen(cam, sun);
  {
    const Target& t = target;
    const glm::dvec3 f = glm::normalize(cam.forward), r = glm::normalize(glm::cross(f, cam.up)), u = glm::cross(r, f);
    const double limit = std::sin(44.0 * M_PI / 180);
    for (int k = 0; k < 4 * 64; ++k) {
      const double e = (k % 64) / 63.0 * 2 - 1;  // along an edge
      const double x = k < 64 ? e : k < 128 ? -e : k < 192 ? -1 : 1, y = k < 64 ? 1 : k < 128 ? -1 : e;
      const glm::dvec3 d = glm::normalize(
          f + x * t.tan_half_x * r + (0.5 * (t.tan_y_high + t.tan_y_low) + 0.5 * y * (t.tan_y_high - t.tan_y_low)) * u);
      steep_view[0] = steep_view[0] || d.z < -limit;
      steep_view[1] = steep_view[1] || d.z > limit;
    }
  }
  for (const bool above : {true, false}) {
    std::vector<const FlatLayer*> side;
    for (const auto& l : field.layers())
      if ((l.altitude_m > cam.position.z) == above) side.push_back(&l);
    std::sort(side.begin(), side.end(), [&](const FlatLayer* a, const FlatLayer* b) {
      return std::abs(a->altitude_m - cam.position.z) > std::abs(b->altitude_m - cam.position.z);
    });
    for (std::size_t i = 0; i < side.size(); ++i) {
      const FlatLayer* l = side[i];
      const FlatLayer* behind = nullptr;  // the farther layer of a pair
      const double dh = l->altitude_m - cam.position.z;
      // A pair needs equal extents: the shader masks the farther sheet at k times the nearer
      // one's half-width.
      if (m.merge_layers && i + 1 < side.size() && side[i + 1]->type == l->type &&
          side[i + 1]->extent_m == l->extent_m) {
        const double dh_near = side[i + 1]->altitude_m - cam.position.z;
        // Ratio of heights above the camera; a nearer sheet almost edge-on (more than 64 times
        // closer to the camera's altitude) is drawn alone, to keep the float texture coordinates.
        if (std::abs(dh) <= 64 * std::abs(dh_near)) behind = l, l = side[++i];
      }
      const LayerStyle st = style(*l);
      const double size = 2 * l->extent_m;
      // The sheet is centred on the camera but its pattern belongs to the air: the texture is
      // offset by where the camera is relative to the drifting air (in tiles; texture v runs
      // south), so that flying under a layer moves its pattern past, as it moves sprite clouds.
      const double u = cam_air.x / st.tile_m, v = -cam_air.y / st.tile_m;
      const double far_alpha = behind ? style(*behind).alpha : 0.0;
      const double far_ratio = behind ? (behind->altitude_m - cam.position.z) / (l->altitude_m - cam.position.z) : 0.0;
      // Distance fade (fragment shader): a pixel's footprint along the view on a sheet dh below or
      // above the camera, at horizontal distance D, is D^2 theta / |dh| (theta: the pixel's angle)
      // or D_tiles^2 tile_m theta / |dh| in tiles; in texels times sprite_texture_size. The texel fades
      // to the mean from fade_from to fade_to texels per pixel: fade = D_tiles^2 scale - offset.
      constexpr double fade_from = 1, fade_to = 4;
      const double theta = 2 * std::tan(0.5 * cam.fov_deg * M_PI / 180) / h_;
      const double scale = st.tile_m * sprite_texture_size * theta /
                           (std::max(std::abs(l->altitude_m - cam.position.z), 1.0) * (fade_to - fade_from));
      // The slab seen from below (the camera under the layer) or from above.
      const int layer = first_slab_layer + 2 * st.type + (above ? 0 : 1);
      push_instance(m.buffer, {0, 0, l->altitude_m - cam.position.z}, size, st.light, st.alpha, layer, size / st.tile_m,
                    {u - std::floor(u), v - std::floor(v), far_alpha},
                    {far_ratio, scale, fade_from / (fade_to - fade_from)}, 1.0);
      const bool slant =
          m.layer_views == LayerViews::slant || (m.layer_views == LayerViews::automatic && !steep_view[above ? 1 : 0]);
      const Shading shading = behind ? (slant ? Shading::layer_pair_slant : Shading::layer_pair)
                                     : (slant ? Shading::sheet_slant : Shading::sheet);
      if (layer_runs.empty()) first_layer_above = above;
      if (layer_runs.empty() || layer_runs.back().first != shading) layer_runs.push_back({shading, 0});
      ++layer_runs.back().second;
    }
  }
  // Sprites not in an impostor; during a crossfade a sprite in only one set is also drawn as a
  // sprite, fading against that set.
  std::vector<glm::dvec3> pos;
  struct Item {
    const SpriteCloud* cloud;
    const Sprite* sprite;
    std::uint32_t index;
    double alpha;
  };
  std::vector<Item> items;
  std::uint64_t lod_signature = 0;  // which clouds draw their LOD sprite, and which also their sprites
  std::vector<char> in_front, in_back;
  for (const auto& c : field.clouds()) {
    if (c.opacity <= 0) continue;
    bool held = false;  // some of its sprites are in an impostor set
    if (impostors && m.ring.valid) {
      held = captured_sprites(m.captured[m.front], c, in_front);
      if (fading_sets) held = captured_sprites(m.captured[back], c, in_back) || held;
    }
    // Opacity of sprite k drawn as a sprite: zero while an impostor set shows it alone; during a
    // crossfade a sprite in only one set fades against that set.
    auto alpha_of = [&](std::size_t k) {
      if (!held) return double{c.opacity};
      const bool f = in_front[k];
      if (!fading_sets) return f ? 0.0 : double{c.opacity};
      const bool b = in_back[k];
      if (f && b) return 0.0;
      return c.opacity * (f ? back_weight : 1.0) * (b ? 1 - back_weight : 1.0);
    };
    // Level of detail: across its distance the cloud's one sprite and its sprites cross-dissolve
    // (CloudField::lod_weight), so that a cloud does not change at once from one to the other.
    const double w_lod =
        held ? 0.0 : CloudField::lod_weight(glm::length(c.centre - cam.position), m.single_sprite_distance_m);
    if (w_lod > 0) {
      pos.push_back(c.centre + glm::dvec3(c.lod.offset));
      items.push_back({&c, &c.lod, lod_index, c.opacity * w_lod});
      lod_signature += (static_cast<std::uint64_t>(c.id) + 1) * 0x9e3779b97f4a7c15ull;
      if (w_lod >= 1) continue;
      lod_signature += (static_cast<std::uint64_t>(c.id) + 1) * 0xc2b2ae3d27d4eb4full;  // and its sprites
    }
    for (std::uint32_t k = 0; k < c.sprites.size(); ++k) {
      const double alpha = alpha_of(k) * (1 - w_lod);
      if (alpha <= 0) continue;
      pos.push_back(c.centre + glm::dvec3(c.sprites[k].offset));
      items.push_back({&c, &c.sprites[k], k, alpha});
    }
  }
  if (lod_signature != m.lod_signature) ++m.generation, m.lod_signature = lod_signature;
  if (sort || m.order.size() != items.size() || m.order_generation != m.generation) {
    m.order = back_to_front(pos, cam.position);
    m.order_generation = m.generation;
  }
  // Facing lock (MSFS 2004): a sprite the camera is within half its radius of keeps the
  // orientation it had when the camera came that close, instead of spinning around the camera.
  std::unordered_map<std::uint64_t, glm::vec3> locked;
  const glm::dvec3 front = glm::normalize(cam.forward);
  // Sprites beyond a flat layer first (back to front), then those in the camera's band.
  const std::size_t first_sprite = m.buffer.size() / 17;
  std::size_t beyond = 0;
  bool beyond_on_side[2] = {false, false};  // below, above the camera
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t k : m.order) {
      if (in_band(pos[k].z) == (pass == 0)) continue;
      if (pass == 0) ++beyond, beyond_on_side[pos[k].z > cam.position.z] = true;
      const Item& it = items[k];
      const Shade sh = shade_sprite(*it.cloud, *it.sprite, sun);
      const glm::dvec3 rel = pos[k] - cam.position;
      glm::dvec3 facing(0.0);
      if (glm::length(rel) < 0.25 * it.sprite->size_m) {
        const std::uint64_t key = (static_cast<std::uint64_t>(it.cloud->id) << 20) | it.index;
        const auto old = m.locked.find(key);
        const glm::vec3 f = old != m.locked.end() ? old->second : glm::vec3(front);
        locked.emplace(key, f);
        facing = glm::dvec3(f);
      }
      push_instance(m.buffer, rel, it.sprite->size_m, sh.colour, it.alpha, sprite_layer(*it.cloud, *it.sprite), 0.0,
                    sh.diffuse, facing, 1.0);
    }
  m.locked = std::move(locked);
  stats.locked_sprites = m.locked.size();

  // Draws: the sky, the sprites beyond a flat layer, the flat layers, the ring (one draw per
  // impostor set: each set is its own texture array), then the sprites in the camera's band in
  // one instanced call (the layers without the sprites' bent-normal term). The ring holds
  // sprite clouds of the camera's band, so it goes where they go: in front of the flat layers,
  // as when every cloud is drawn as sprites (a distant cumulus top in front of an overcast deck
  // above the horizon).
  submit(target, 0, 0, m.texture, true, Shading::plain);  // the sky
  submit(target, first_sprite, beyond, m.texture, false, Shading::bent_normal);
  // The first flat layer lies over nothing but the uniform sky (unless sprites beyond it were
  // drawn on its side of the horizon): it is composited with the sky in its shader and written
  // without blending, which spares llvmpipe reading and blending the frame under it (0.1-0.8 ms
  // of a 1280x720 frame under d400's deck; docs/PERFORMANCE.md).
  std::size_t first = 0;
  bool over_sky = m.first_layer_over_sky && !beyond_on_side[first_layer_above ? 1 : 0];
  for (const auto& [shading, count] : layer_runs) {
    std::size_t n = count;
    if (over_sky) {  // its first instance alone
      submit(target, first, 1, m.texture, false, shading, true);
      ++first, --n;
      over_sky = false;
    }
    submit(target, first, n, m.texture, false, shading);
    first += n;
  }
  submit_ring(target, 0, ring_vertex_count[0], m.imp_tex[m.front]);
  submit_ring(target, ring_vertex_count[0], ring_vertex_count[1], m.imp_tex[back]);
  submit(target, first_sprite + beyond, m.buffer.size() / 17 - first_sprite - beyond, m.texture, false,
         Shading::bent_normal);
  glFinish();
  stats.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  stats.sprites = items.size();
  return stats;
}

FrameStats SpriteRenderer::draw_points(const PointSprites& sp, const Camera& cam) {
  auto& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = sp.size();
  m.buffer.resize(17 * n);
  float* b = m.buffer.data();
  const auto cx = static_cast<float>(cam.position.x), cy = static_cast<float>(cam.position.y),
             cz = static_cast<float>(cam.position.z);
  const float layer = static_cast<float>(particle_layer);
  for (std::size_t i = 0; i < n; ++i, b += 17) {
    b[0] = sp.x[i] - cx, b[1] = sp.y[i] - cy, b[2] = sp.z[i] - cz, b[3] = sp.size_m[i];
    b[4] = b[5] = b[6] = sp.grey[i];
    b[7] = sp.alpha[i];
    b[8] = layer;
    std::fill(b + 9, b + 17, 0.0f);
    b[16] = 1;
  }
  SunLight none{{0, 0, 1}, {0, 0, 0}, 90};
  submit(screen(cam, none), 0, n, impl_->texture, true, Shading::plain);
  glFinish();
  FrameStats s;
  s.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  s.sprites = n;
  return s;
}

const ImpostorRing& SpriteRenderer::impostor_ring() const { return impl_->ring; }

void SpriteRenderer::set_single_sprite_distance(double distance_m) {
  if (!(distance_m >= 0))
    throw ValueError("the single-sprite distance must be >= 0 m (0: off)", {.key = "single_sprite_distance_m"});
  impl_->single_sprite_distance_m = distance_m;
}

void SpriteRenderer::set_merge_flat_layers(bool merge) { impl_->merge_layers = merge; }

void SpriteRenderer::set_trim_sprites(bool trim) { impl_->trim_sprites = trim; }

void SpriteRenderer::set_first_layer_over_sky(bool over_sky) { impl_->first_layer_over_sky = over_sky; }

void SpriteRenderer::set_layer_views(LayerViews views) { impl_->layer_views = views; }

void SpriteRenderer::set_trim_ring(bool trim) { impl_->trim_ring = trim; }

void SpriteRenderer::set_impostor_sprites_per_frame(std::size_t sprites) {
  if (sprites < 1)
    throw ValueError("the impostors' sprites per frame must be >= 1", {.key = "impostor_sprites_per_frame"});
  impl_->impostor_sprite_budget = sprites;
}

void SpriteRenderer::set_background(Background background) {
  impl_->transparent = background == Background::transparent;
}

void SpriteRenderer::set_impostor_radius(double radius_m) {
  if (!(radius_m > 0)) throw ValueError("the impostor ring radius must be > 0 m", {.key = "impostor_radius_m"});
  impl_->ring.radius_m = radius_m;
  impl_->ring.valid = false;
}

std::vector<std::uint8_t> read_framebuffer_rgba(unsigned framebuffer, int width, int height) {
  const std::size_t row = static_cast<std::size_t>(width) * 4;
  std::vector<std::uint8_t> px(row * static_cast<std::size_t>(height)), out(px.size());
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, px.data());
  for (int y = 0; y < height; ++y)  // GL rows start at the bottom
    std::copy_n(px.data() + static_cast<std::size_t>(height - 1 - y) * row, row,
                out.data() + static_cast<std::size_t>(y) * row);
  return out;
}

std::vector<std::uint8_t> straight_alpha(std::vector<std::uint8_t> rgba) {
  for (std::size_t p = 0; p + 3 < rgba.size(); p += 4) {
    const unsigned a = rgba[p + 3];
    for (std::size_t c = 0; c < 3; ++c)
      rgba[p + c] = a == 0 ? 0 : static_cast<std::uint8_t>(std::min(255u, (rgba[p + c] * 255u + a / 2) / a));
  }
  return rgba;
}

std::vector<std::uint8_t> SpriteRenderer::read_pixels() const { return read_framebuffer_rgba(impl_->fbo, w_, h_); }

void SpriteRenderer::present(int width, int height) const {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, impl_->fbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  glBlitFramebuffer(0, 0, w_, h_, 0, 0, width, height, GL_COLOR_BUFFER_BIT, GL_LINEAR);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

std::string SpriteRenderer::gl_version() const {
  const auto* v = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  return v ? v : "";
}

std::string SpriteRenderer::gl_renderer() const {
  const auto* v = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return v ? v : "";
}

}  // namespace nephos::realtime
