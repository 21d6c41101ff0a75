#include "nephos/realtime/gl/sprite_renderer.hpp"

#include <GLES3/gl3.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>

#include "nephos/core/error.hpp"
#include "nephos/realtime/gl/impostor_atlas.hpp"
#include "nephos/realtime/gl/passes.hpp"

namespace nephos::realtime {

struct SpriteRenderer::Impl {
  GLuint fbo = 0, colour = 0;  // the frame
  std::unique_ptr<SpritePasses> passes;
  FramePlanner planner;
  std::unique_ptr<ImpostorAtlas> atlas;
  bool transparent = false;  // set_background
};

std::array<std::uint8_t, 4> SpriteRenderer::sky_colour() { return SpritePasses::sky_colour(); }

SpriteRenderer::SpriteRenderer(int width, int height, std::uint64_t seed, GlApi api)
    : context_(std::make_unique<EglContext>(api)), impl_(std::make_unique<Impl>()), w_(width), h_(height), api_(api) {
  init_gl(seed);
}

SpriteRenderer::SpriteRenderer(UseCurrentContext, int width, int height, std::uint64_t seed, GlApi api)
    : impl_(std::make_unique<Impl>()), w_(width), h_(height), api_(api) {
  init_gl(seed);
}

SpriteRenderer::~SpriteRenderer() = default;

void SpriteRenderer::make_current() {
  if (context_) context_->make_current();
}

void SpriteRenderer::release_current() {
  if (context_) context_->release_current();
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
  m.passes = std::make_unique<SpritePasses>(api_, seed);
  m.atlas = std::make_unique<ImpostorAtlas>(*m.passes, m.planner.options);
}

namespace {
// The frame's target: the sky colour, or transparent.
PassTarget frame_target(const Frustum& frustum, unsigned fbo, int width, int height, bool transparent) {
  const auto sky = SpritePasses::sky_colour();
  return {frustum, fbo, width, height,
          transparent ? std::array<float, 4>{0, 0, 0, 0}
                      : std::array<float, 4>{sky[0] / 255.0f, sky[1] / 255.0f, sky[2] / 255.0f, 1.0f}};
}
}  // namespace

FrameStats SpriteRenderer::draw(const CloudField& field, const Camera& cam, const SunLight& sun, bool sort,
                                bool impostors) {
  auto& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  const FramePlan plan = m.planner.plan(field, cam, sun, sort, impostors, w_, h_, *m.atlas);
  const RenderOptions& o = m.planner.options;
  const bool vertical = o.layer_views == LayerViews::vertical;
  const PassTarget target = frame_target(plan.screen, m.fbo, w_, h_, m.transparent);
  const float* inst = plan.instances.data();
  auto instances = [&](std::size_t first, std::size_t count, Shading shading, bool over_sky) {
    m.passes->draw(target, inst + first * instance_floats, count, m.passes->sprite_texture(), false, shading, over_sky,
                   o.trim_sprites, vertical);
  };
  // The sky, the sprites beyond a flat layer, the flat layers (the first over the sky alone,
  // written without blending), the ring (one draw per impostor set: each set is its own
  // texture array), then the sprites in the camera's band. The ring holds sprite clouds of the
  // camera's band, so it goes where they go: in front of the flat layers, as when every cloud
  // is drawn as sprites.
  SpritePasses::clear(target);
  instances(plan.first_sprite, plan.beyond, Shading::bent_normal, false);
  std::size_t first = 0;
  bool over_sky = plan.first_over_sky;
  for (const auto& [shading, count] : plan.layer_runs) {
    std::size_t n = count;
    if (over_sky) {  // its first instance alone
      instances(first, 1, shading, true);
      ++first, --n;
      over_sky = false;
    }
    instances(first, n, shading, false);
    first += n;
  }
  m.passes->draw_ring(target, plan.ring_vertices.data(), plan.ring_vertex_count[0], m.atlas->texture(plan.front));
  m.passes->draw_ring(target, plan.ring_vertices.data() + plan.ring_vertex_count[0] * ring_vertex_floats,
                      plan.ring_vertex_count[1], m.atlas->texture(plan.back));
  const std::size_t band_first = plan.first_sprite + plan.beyond;
  instances(band_first, plan.instances.size() / instance_floats - band_first, Shading::bent_normal, false);
  glFinish();
  FrameStats stats = plan.stats;
  stats.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return stats;
}

FrameStats SpriteRenderer::draw_points(const PointSprites& sp, const Camera& cam) {
  auto& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = sp.size();
  std::vector<float> buffer(instance_floats * n);
  float* b = buffer.data();
  const auto cx = static_cast<float>(cam.position.x), cy = static_cast<float>(cam.position.y),
             cz = static_cast<float>(cam.position.z);
  const float layer = static_cast<float>(particle_layer);
  for (std::size_t i = 0; i < n; ++i, b += instance_floats) {
    b[0] = sp.x[i] - cx, b[1] = sp.y[i] - cy, b[2] = sp.z[i] - cz, b[3] = sp.size_m[i];
    b[4] = b[5] = b[6] = sp.grey[i];
    b[7] = sp.alpha[i];
    b[8] = layer;
    std::fill(b + 9, b + instance_floats, 0.0f);
    b[16] = 1;
  }
  Frustum f;
  f.camera = cam;
  f.tan_y_high = std::tan(0.5 * cam.fov_deg * M_PI / 180);
  f.tan_y_low = -f.tan_y_high;
  f.tan_half_x = f.tan_y_high * w_ / h_;
  f.sun = {0, 0, 1};
  m.passes->draw(frame_target(f, m.fbo, w_, h_, m.transparent), buffer.data(), n, m.passes->sprite_texture(), true,
                 Shading::plain, false, false, false);
  glFinish();
  FrameStats s;
  s.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  s.sprites = n;
  return s;
}

RenderOptions& SpriteRenderer::options() { return impl_->planner.options; }
const ImpostorRing& SpriteRenderer::impostor_ring() const { return impl_->planner.impostor_ring(); }
void SpriteRenderer::set_impostor_radius(double radius_m) { impl_->planner.set_impostor_radius(radius_m); }
void SpriteRenderer::set_single_sprite_distance(double d) { impl_->planner.set_single_sprite_distance(d); }
void SpriteRenderer::set_impostor_sprites_per_frame(std::size_t n) { impl_->planner.set_impostor_sprites_per_frame(n); }
void SpriteRenderer::set_background(Background background) {
  impl_->transparent = background == Background::transparent;
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
