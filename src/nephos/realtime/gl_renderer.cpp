#include "nephos/realtime/gl_renderer.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <string>

#include "nephos/core/error.hpp"
#include "nephos/noise/fractal_texture.hpp"

namespace nephos::realtime {
namespace {

constexpr int tex_size = 64, layers_per_type = 5;
constexpr int sheet_layer = 2 * layers_per_type;  // tileable sheet for flat layers
constexpr int particle_layer = sheet_layer + 1;   // soft round particle
constexpr int texture_layers = particle_layer + 1;

// Sprite textures baked from a 3D density: an ellipsoidal puff modulated by a tileable Perlin
// fractal, seen from five elevations (-60..60 deg); opacity 1 - exp(-kappa * column density),
// premultiplied white (the shading colours it per vertex).
std::vector<std::uint8_t> bake_sprites(std::uint64_t seed) {
  const noise::Texture3D tex = noise::bake({noise::FractalKind::perlin, 4, 3, 0.5, false}, seed, 32);
  std::vector<std::uint8_t> out(static_cast<std::size_t>(texture_layers) * tex_size * tex_size * 4);
  for (int type = 0; type < 2; ++type)
    for (int l = 0; l < layers_per_type; ++l) {
      const double el = (-60.0 + 30.0 * l) * M_PI / 180;
      const double flat = type == 0 ? 1.0 : 0.45;  // cumulus round, stratocumulus flat
      const glm::dvec3 view{0, std::cos(el), std::sin(el)}, right{1, 0, 0};
      const glm::dvec3 up = glm::cross(right, view);
      for (int y = 0; y < tex_size; ++y)
        for (int x = 0; x < tex_size; ++x) {
          const double u = (x + 0.5) / tex_size * 2 - 1, v = 1 - (y + 0.5) / tex_size * 2;
          double column = 0;
          for (int k = 0; k < 32; ++k) {
            const double t = (k + 0.5) / 32 * 2 - 1;
            const glm::dvec3 p = u * right + v * up + t * view;
            const double r2 = p.x * p.x + p.y * p.y + (p.z / flat) * (p.z / flat);
            if (r2 >= 1) continue;
            const double n = tex.sample(static_cast<float>(p.x * 0.5 + 7), static_cast<float>(p.y * 0.5 + 3),
                                        static_cast<float>(p.z * 0.5 + 5));
            column += std::max(0.0, (1 - r2) * (0.4 + n) - 0.35) * (2.0 / 32);
          }
          const double alpha = 1 - std::exp(-4 * column);
          const std::size_t q =
              ((static_cast<std::size_t>(type * layers_per_type + l) * tex_size + y) * tex_size + x) * 4;
          const auto a = static_cast<std::uint8_t>(std::lround(255 * alpha));
          out[q] = out[q + 1] = out[q + 2] = a;  // premultiplied white
          out[q + 3] = a;
        }
    }
  // A tileable sheet for the flat layers: a horizontal slice of the (periodic) fractal, opacity
  // rising smoothly above its median.
  for (int y = 0; y < tex_size; ++y)
    for (int x = 0; x < tex_size; ++x) {
      const double n = tex.sample(static_cast<float>(x) / tex_size, static_cast<float>(y) / tex_size, 0.5f);
      const double alpha = std::clamp((n - 0.42) / 0.2, 0.0, 1.0);
      const std::size_t q = ((static_cast<std::size_t>(sheet_layer) * tex_size + y) * tex_size + x) * 4;
      const auto a = static_cast<std::uint8_t>(std::lround(255 * alpha));
      out[q] = out[q + 1] = out[q + 2] = a;
      out[q + 3] = a;
    }
  // A soft round particle: opacity (1 - r^2)^2, smooth to zero at the rim.
  for (int y = 0; y < tex_size; ++y)
    for (int x = 0; x < tex_size; ++x) {
      const double u = (x + 0.5) / tex_size * 2 - 1, v = (y + 0.5) / tex_size * 2 - 1;
      const double r2 = std::min(1.0, u * u + v * v);
      const std::size_t q = ((static_cast<std::size_t>(particle_layer) * tex_size + y) * tex_size + x) * 4;
      const auto a = static_cast<std::uint8_t>(std::lround(255 * (1 - r2) * (1 - r2)));
      out[q] = out[q + 1] = out[q + 2] = a;
      out[q + 3] = a;
    }
  return out;
}

// One shader body for GLSL ES 3.00 and GLSL 3.30 core; only the version line differs.
const char* vertex_body = R"(
layout(location = 0) in vec2 corner;       // -1..1
layout(location = 1) in vec4 pos_size;     // position relative to the camera [m], size [m]
layout(location = 2) in vec4 colour_alpha; // shaded colour, alpha (fade)
layout(location = 3) in vec2 layer_tiles;  // texture layer; 0 = camera-facing sprite, else a
                                           // horizontal sheet repeating the texture this often
uniform mat4 view_proj;
uniform vec3 cam_right;
uniform vec3 cam_up;
out vec3 v_uvl;
out vec4 v_colour;
void main() {
  bool sheet = layer_tiles.y > 0.0;
  vec3 ax = sheet ? vec3(1.0, 0.0, 0.0) : cam_right;
  vec3 ay = sheet ? vec3(0.0, 1.0, 0.0) : cam_up;
  vec3 p = pos_size.xyz + 0.5 * pos_size.w * (corner.x * ax + corner.y * ay);
  gl_Position = view_proj * vec4(p, 1.0);
  vec2 uv = corner * vec2(0.5, -0.5) + 0.5;
  v_uvl = vec3(sheet ? uv * layer_tiles.y : uv, layer_tiles.x);
  v_colour = colour_alpha;
}
)";
const char* fragment_body = R"(
uniform highp sampler2DArray sprites;
in vec3 v_uvl;
in vec4 v_colour;
out vec4 frag;
void main() {
  vec4 t = texture(sprites, v_uvl);           // premultiplied
  frag = vec4(t.rgb * v_colour.rgb, t.a) * v_colour.a;
}
)";

GLuint compile(GLenum type, const std::string& src) {
  const GLuint s = glCreateShader(type);
  const char* p = src.c_str();
  glShaderSource(s, 1, &p, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    throw IoError(std::string("shader compilation failed: ") + log);
  }
  return s;
}

}  // namespace

struct SpriteRenderer::Impl {
  EGLDisplay dpy = EGL_NO_DISPLAY;
  EGLContext ctx = EGL_NO_CONTEXT;
  GLuint fbo = 0, colour = 0, depth = 0, program = 0, vao = 0, quad = 0, instances = 0, texture = 0;
  std::vector<std::size_t> order;
  std::vector<float> buffer;
};

std::array<std::uint8_t, 4> SpriteRenderer::sky_colour() { return {110, 160, 225, 255}; }

SpriteRenderer::SpriteRenderer(int width, int height, std::uint64_t seed)
    : impl_(std::make_unique<Impl>()), w_(width), h_(height) {
  auto& m = *impl_;
  auto get_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  m.dpy = get_display ? get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr) : EGL_NO_DISPLAY;
  if (m.dpy == EGL_NO_DISPLAY) m.dpy = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  EGLint major = 0, minor = 0;
  if (m.dpy == EGL_NO_DISPLAY || !eglInitialize(m.dpy, &major, &minor))
    throw IoError("EGL: no display could be initialised");
  eglBindAPI(EGL_OPENGL_ES_API);
  const EGLint cfg_attr[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_NONE};
  EGLConfig cfg = nullptr;
  EGLint n = 0;
  eglChooseConfig(m.dpy, cfg_attr, &cfg, 1, &n);
  const EGLint ctx_attr[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0, EGL_NONE};
  m.ctx = eglCreateContext(m.dpy, n ? cfg : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, ctx_attr);
  if (m.ctx == EGL_NO_CONTEXT || !eglMakeCurrent(m.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, m.ctx))
    throw IoError("EGL: cannot create an OpenGL ES 3.0 context");

  glGenFramebuffers(1, &m.fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glGenRenderbuffers(1, &m.colour);
  glBindRenderbuffer(GL_RENDERBUFFER, m.colour);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w_, h_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, m.colour);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw IoError("OpenGL ES: framebuffer incomplete");

  const std::string version = "#version 300 es\nprecision highp float;\nprecision highp sampler2DArray;\n";
  m.program = glCreateProgram();
  glAttachShader(m.program, compile(GL_VERTEX_SHADER, version + vertex_body));
  glAttachShader(m.program, compile(GL_FRAGMENT_SHADER, version + fragment_body));
  glLinkProgram(m.program);
  GLint ok = 0;
  glGetProgramiv(m.program, GL_LINK_STATUS, &ok);
  if (!ok) throw IoError("OpenGL ES: shader program does not link");

  const auto pixels = bake_sprites(seed);
  glGenTextures(1, &m.texture);
  glBindTexture(GL_TEXTURE_2D_ARRAY, m.texture);
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA8, tex_size, tex_size, texture_layers, 0, GL_RGBA, GL_UNSIGNED_BYTE,
               pixels.data());
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  // Repeat, for the tiled sheets; sprites stay in [0, 1] and fade to zero at their edges.
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_REPEAT);

  glGenVertexArrays(1, &m.vao);
  glBindVertexArray(m.vao);
  const float corners[8] = {-1, -1, 1, -1, -1, 1, 1, 1};
  glGenBuffers(1, &m.quad);
  glBindBuffer(GL_ARRAY_BUFFER, m.quad);
  glBufferData(GL_ARRAY_BUFFER, sizeof corners, corners, GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
  glGenBuffers(1, &m.instances);
  glBindBuffer(GL_ARRAY_BUFFER, m.instances);
  constexpr GLsizei stride = 10 * sizeof(float);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, stride, nullptr);
  glVertexAttribDivisor(1, 1);
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(4 * sizeof(float)));
  glVertexAttribDivisor(2, 1);
  glEnableVertexAttribArray(3);
  glVertexAttribPointer(3, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(8 * sizeof(float)));
  glVertexAttribDivisor(3, 1);
}

SpriteRenderer::~SpriteRenderer() {
  auto& m = *impl_;
  if (m.dpy != EGL_NO_DISPLAY) {
    eglMakeCurrent(m.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (m.ctx != EGL_NO_CONTEXT) eglDestroyContext(m.dpy, m.ctx);
    eglTerminate(m.dpy);
  }
}

FrameStats SpriteRenderer::draw(const CloudField& field, const Camera& cam, const SunLight& sun, bool sort) {
  auto& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  // Sprites in world space, then (optionally) sorted back to front.
  std::vector<glm::dvec3> pos;
  struct Item {
    const SpriteCloud* cloud;
    const Sprite* sprite;
  };
  std::vector<Item> items;
  for (const auto& c : field.clouds())
    for (const auto& s : c.sprites) {
      pos.push_back(c.centre + glm::dvec3(s.offset));
      items.push_back({&c, &s});
    }
  if (sort || m.order.size() != items.size()) m.order = back_to_front(pos, cam.position);
  // Shading (MSFS 2004): five colour levels by height within the cloud (dark base, white top),
  // times a time-of-day ambient factor, plus a directional term per shading group.
  static const glm::dvec3 levels[5] = {
      {0.45, 0.48, 0.55}, {0.58, 0.61, 0.67}, {0.72, 0.74, 0.78}, {0.86, 0.87, 0.89}, {0.97, 0.97, 0.98}};
  const double ambient = 0.35 + 0.65 * std::clamp(sun.elevation_deg / 30.0, 0.0, 1.0);
  m.buffer.clear();
  // Flat layers (altostratus, cirrus, fog) first, farthest altitude first: wide horizontal
  // sheets centred under/over the camera, drawn behind the sprite clouds.
  std::vector<const FlatLayer*> flats;
  for (const auto& l : field.layers()) flats.push_back(&l);
  std::sort(flats.begin(), flats.end(), [&](const FlatLayer* a, const FlatLayer* b) {
    return std::abs(a->altitude_m - cam.position.z) > std::abs(b->altitude_m - cam.position.z);
  });
  for (const FlatLayer* l : flats) {
    const bool cirrus = l->type == SpriteCloudType::cirrus, fog = l->type == SpriteCloudType::low_stratus;
    const double grey = cirrus ? 1.0 : fog ? 0.85 : 0.78, alpha = cirrus ? 0.45 : fog ? 0.9 : 0.7;
    const glm::dvec3 c = glm::min(glm::dvec3(1.0), ambient * grey + 0.15 * std::max(0.0, sun.direction.z) * sun.colour);
    const float size = static_cast<float>(2 * l->extent_m);
    const float v[10] = {0,
                         0,
                         static_cast<float>(l->altitude_m - cam.position.z),
                         size,
                         static_cast<float>(c.r),
                         static_cast<float>(c.g),
                         static_cast<float>(c.b),
                         static_cast<float>(alpha),
                         static_cast<float>(sheet_layer),
                         size / (cirrus ? 6000.0f : 3000.0f)};
    m.buffer.insert(m.buffer.end(), v, v + 10);
  }
  for (std::size_t k : m.order) {
    const Item& it = items[k];
    const double h = std::clamp((it.sprite->offset.z + 300.0) / 1500.0, 0.0, 0.999) * 4;
    const int lo = static_cast<int>(h);
    const glm::dvec3 level = levels[lo] + (h - lo) * (levels[std::min(lo + 1, 4)] - levels[lo]);
    const glm::dvec3 g =
        glm::dvec3(it.sprite->offset - it.cloud->group_centres[static_cast<std::size_t>(it.sprite->shading_group)]);
    const double dir = glm::length(g) > 1e-6 ? std::max(0.0, glm::dot(glm::normalize(g), sun.direction)) : 0.0;
    const glm::dvec3 colour = glm::min(glm::dvec3(1.0), ambient * level + 0.35 * dir * sun.colour);
    const glm::dvec3 rel = pos[k] - cam.position;
    const float v[10] = {static_cast<float>(rel.x),
                         static_cast<float>(rel.y),
                         static_cast<float>(rel.z),
                         it.sprite->size_m,
                         static_cast<float>(colour.r),
                         static_cast<float>(colour.g),
                         static_cast<float>(colour.b),
                         1.0f,
                         static_cast<float>((it.cloud->type == SpriteCloudType::cumulus ? 0 : layers_per_type) +
                                            it.sprite->texture_layer % layers_per_type),
                         0.0f};  // camera-facing sprite (no tiling)
    m.buffer.insert(m.buffer.end(), v, v + 10);
  }
  submit(items.size() + flats.size(), cam);
  FrameStats s;
  s.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  s.sprites = items.size();
  return s;
}

void SpriteRenderer::submit(std::size_t instances, const Camera& cam) {
  auto& m = *impl_;
  // Camera matrices (camera at the origin: positions are relative, which keeps float precision).
  const glm::dvec3 f = glm::normalize(cam.forward), r = glm::normalize(glm::cross(f, cam.up)), u = glm::cross(r, f);
  const double t = std::tan(0.5 * cam.fov_deg * M_PI / 180), a = static_cast<double>(w_) / h_, zn = 10, zf = cam.far_m;
  glm::mat4 view(1.0f), proj(0.0f);
  for (int i = 0; i < 3; ++i) {
    view[i][0] = static_cast<float>(r[i]);
    view[i][1] = static_cast<float>(u[i]);
    view[i][2] = static_cast<float>(-f[i]);
  }
  proj[0][0] = static_cast<float>(1 / (a * t));
  proj[1][1] = static_cast<float>(1 / t);
  proj[2][2] = static_cast<float>(-(zf + zn) / (zf - zn));
  proj[2][3] = -1;
  proj[3][2] = static_cast<float>(-2 * zf * zn / (zf - zn));
  const glm::mat4 vp = proj * view;

  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glViewport(0, 0, w_, h_);
  const auto sky = sky_colour();
  glClearColor(sky[0] / 255.0f, sky[1] / 255.0f, sky[2] / 255.0f, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);  // premultiplied alpha
  glUseProgram(m.program);
  glUniformMatrix4fv(glGetUniformLocation(m.program, "view_proj"), 1, GL_FALSE, &vp[0][0]);
  glUniform3f(glGetUniformLocation(m.program, "cam_right"), static_cast<float>(r.x), static_cast<float>(r.y),
              static_cast<float>(r.z));
  glUniform3f(glGetUniformLocation(m.program, "cam_up"), static_cast<float>(u.x), static_cast<float>(u.y),
              static_cast<float>(u.z));
  glUniform1i(glGetUniformLocation(m.program, "sprites"), 0);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D_ARRAY, m.texture);
  glBindVertexArray(m.vao);
  glBindBuffer(GL_ARRAY_BUFFER, m.instances);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m.buffer.size() * sizeof(float)), m.buffer.data(),
               GL_STREAM_DRAW);
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, static_cast<GLsizei>(instances));  // one draw call
  glFinish();
}

FrameStats SpriteRenderer::draw_points(const PointSprites& sp, const Camera& cam) {
  auto& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = sp.size();
  m.buffer.resize(10 * n);
  float* b = m.buffer.data();
  const auto cx = static_cast<float>(cam.position.x), cy = static_cast<float>(cam.position.y),
             cz = static_cast<float>(cam.position.z);
  const float layer = static_cast<float>(particle_layer);
  for (std::size_t i = 0; i < n; ++i, b += 10) {
    b[0] = sp.x[i] - cx, b[1] = sp.y[i] - cy, b[2] = sp.z[i] - cz, b[3] = sp.size_m[i];
    b[4] = b[5] = b[6] = sp.grey[i];
    b[7] = sp.alpha[i];
    b[8] = layer, b[9] = 0;
  }
  submit(n, cam);
  FrameStats s;
  s.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  s.sprites = n;
  return s;
}

std::vector<std::uint8_t> SpriteRenderer::read_pixels() const {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(w_) * h_ * 4), out(px.size());
  glBindFramebuffer(GL_FRAMEBUFFER, impl_->fbo);
  glReadPixels(0, 0, w_, h_, GL_RGBA, GL_UNSIGNED_BYTE, px.data());
  const std::size_t row = static_cast<std::size_t>(w_) * 4;
  for (int y = 0; y < h_; ++y)  // GL rows start at the bottom
    std::copy_n(px.data() + static_cast<std::size_t>(h_ - 1 - y) * row, row,
                out.data() + static_cast<std::size_t>(y) * row);
  return out;
}

}  // namespace nephos::realtime
