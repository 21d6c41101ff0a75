#include "nephos/realtime/gl/passes.hpp"

#include <GLES3/gl3.h>
#include <fmt/format.h>

#include <string>

#include "nephos/core/error.hpp"
#include "nephos/realtime/gl/gl_program.hpp"

namespace nephos::realtime {

namespace shaders {
extern const char* const sprite_vert;
extern const char* const sprite_frag;
}  // namespace shaders

SpritePasses::SpritePasses(GlApi api, std::uint64_t seed) {
  // The one difference between the APIs' shaders: GLSL ES 3.00 and GLSL 3.30 share every
  // construct used here, and 3.30 accepts (and ignores) the precision statements.
  const std::string version = std::string(api == GlApi::gl33 ? "#version 330 core\n" : "#version 300 es\n") +
                              "precision highp float;\nprecision highp sampler2DArray;\n#define TRIM_LAYERS " +
                              std::to_string(texture_layer_count) + "\n";
  const auto pixels = bake_sprite_textures(seed);
  // Each flat-layer texture's mean texel, the value a fully filtered lookup converges to far out
  // on a sheet (a uniform per layer, read by the vertex shader).
  for (int l = 0; l < 2 * slab_types; ++l) {
    const std::array<float, 4> mean = layer_mean_texel(pixels, first_slab_layer + l);
    std::copy(mean.begin(), mean.end(), sheet_mean_.begin() + 4 * l);
  }
  const std::string sheet = "#define SHEET 1\n#define FIRST_SHEET_LAYER " + std::to_string(first_slab_layer) +
                            "\n#define SHEET_LAYERS " + std::to_string(2 * slab_types) + "\n#define EDGE_FADE " +
                            fmt::format("{:.9g}", 1 / (1 - 0.3 * 0.3)) + "\n";
  auto program = [&](Shading s) -> Program& { return programs_[static_cast<std::size_t>(s)]; };
  link(program(Shading::bent_normal), version, "#define BENT_NORMAL 1\n");
  link(program(Shading::plain), version, "");
  link(program(Shading::sheet), version, sheet);
  link(program(Shading::layer_pair), version, sheet + "#define LAYER_PAIR 1\n");
  link(program(Shading::sheet_slant), version, sheet + "#define SLANT_ONLY 1\n");
  link(program(Shading::layer_pair_slant), version, sheet + "#define SLANT_ONLY 1\n#define LAYER_PAIR 1\n");

  for (int l = 0; l < texture_layer_count; ++l) {
    const SpriteTrim t =
        sprite_trim(pixels.data() + static_cast<std::size_t>(l) * sprite_texture_size * sprite_texture_size * 4,
                    sprite_texture_size);
    trim_[3 * l] = t.a, trim_[3 * l + 1] = t.b, trim_[3 * l + 2] = t.c;
  }
  glGenTextures(1, &texture_);
  glBindTexture(GL_TEXTURE_2D_ARRAY, texture_);
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA8, sprite_texture_size, sprite_texture_size, texture_layer_count, 0,
               GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  // No mipmaps: on a software rasteriser they cost more than the shimmer of the tiled sheets
  // near the horizon is worth (docs/realtime.md).
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  // Repeat, for the tiled sheets; sprites stay in [0, 1] and fade to zero at their edges.
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_REPEAT);
  make_vertex_arrays();
}

void SpritePasses::link(Program& p, const std::string& version, const std::string& defines) {
  p.id = link_program(version + defines + shaders::sprite_vert, version + defines + shaders::sprite_frag);
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
    glUniform4fv(p.u_sheet_mean, 2 * slab_types, sheet_mean_.data());
  }
}

void SpritePasses::make_vertex_arrays() {
  glGenVertexArrays(1, &vao_);
  glBindVertexArray(vao_);
  // Vertices 0-7: the octagon |x| <= a, |y| <= b, |x| + |y| <= c as one triangle strip,
  // zigzagging between its right and left halves; per vertex the signs of x and y and whether it
  // ends an edge |x| = a (1) or |y| = b (0). Vertices 8-11: the whole quad (a = b = 1, c = 2),
  // for the other draws: for tiny sprites the octagon's four extra triangles cost more than the
  // pixels they spare (point sprites).
  // clang-format off
  const float mesh[12 * 3] = {1, 1, 1,   1, -1, 1,   1, 1, 0,    1, -1, 0,
                              -1, 1, 0,  -1, -1, 0,  -1, 1, 1,   -1, -1, 1,
                              -1, -1, 1, 1, -1, 1,   -1, 1, 1,   1, 1, 1};
  // clang-format on
  glGenBuffers(1, &quad_);
  glBindBuffer(GL_ARRAY_BUFFER, quad_);
  glBufferData(GL_ARRAY_BUFFER, sizeof mesh, mesh, GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glGenBuffers(1, &instances_);
  glBindBuffer(GL_ARRAY_BUFFER, instances_);
  // Per-instance attributes: location, component count, offset [floats].
  constexpr GLsizei stride = instance_floats * sizeof(float);
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
  glGenVertexArrays(1, &ring_vao_);
  glBindVertexArray(ring_vao_);
  glGenBuffers(1, &ring_vbo_);
  glBindBuffer(GL_ARRAY_BUFFER, ring_vbo_);
  constexpr GLsizei ring_stride = ring_vertex_floats * sizeof(float);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, ring_stride, nullptr);
  for (const auto& a : instance_attributes) {
    glEnableVertexAttribArray(a.location);
    glVertexAttribPointer(a.location, a.size, GL_FLOAT, GL_FALSE, ring_stride,
                          reinterpret_cast<void*>((3 + a.offset) * sizeof(float)));
  }
  glBindVertexArray(vao_);
}

void SpritePasses::clear(const PassTarget& target) {
  glBindFramebuffer(GL_FRAMEBUFFER, target.fbo);
  glViewport(0, 0, target.width, target.height);
  glClearColor(target.clear[0], target.clear[1], target.clear[2], target.clear[3]);
  glClear(GL_COLOR_BUFFER_BIT);
}

void SpritePasses::begin_pass(const PassTarget& target, unsigned texture, bool clear, Shading shading, bool over_sky,
                              bool trimmed, bool vertical_views) {
  const Frustum& fr = target.frustum;
  const Camera& cam = fr.camera;
  // Camera matrices (camera at the origin: positions are relative, which keeps float precision).
  const glm::dvec3 f = glm::normalize(cam.forward), r = glm::normalize(glm::cross(f, cam.up)), u = glm::cross(r, f);
  const double tlo = fr.tan_y_low, thi = fr.tan_y_high, tx = fr.tan_half_x, zn = 10, zf = cam.far_m;
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
  const Program& p = programs_[static_cast<std::size_t>(shading)];
  glUseProgram(p.id);
  glUniformMatrix4fv(p.u_view_proj, 1, GL_FALSE, &vp[0][0]);
  glUniform3f(p.u_right, static_cast<float>(r.x), static_cast<float>(r.y), static_cast<float>(r.z));
  glUniform3f(p.u_up, static_cast<float>(u.x), static_cast<float>(u.y), static_cast<float>(u.z));
  glUniform3f(p.u_front, static_cast<float>(f.x), static_cast<float>(f.y), static_cast<float>(f.z));
  glUniform3f(p.u_sun, static_cast<float>(fr.sun.x), static_cast<float>(fr.sun.y), static_cast<float>(fr.sun.z));
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
  glUniform3fv(p.u_trim, texture_layer_count, trimmed ? trim_.data() : whole_quads.data());
  if (p.u_view_scale >= 0) glUniform1f(p.u_view_scale, vertical_views ? 0.0f : 1.0f);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D_ARRAY, texture);
}

void SpritePasses::draw(const PassTarget& target, const float* instances, std::size_t count, unsigned texture,
                        bool clear, Shading shading, bool over_sky, bool trimmed, bool vertical_views) {
  trimmed = trimmed && shading == Shading::bent_normal;
  if (count == 0) {  // at most a clear (the sky)
    if (clear) SpritePasses::clear(target);
    return;
  }
  begin_pass(target, texture, clear, shading, over_sky, trimmed, vertical_views);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, instances_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(count * instance_floats * sizeof(float)), instances,
               GL_STREAM_DRAW);
  glDrawArraysInstanced(GL_TRIANGLE_STRIP, trimmed ? 0 : 8, trimmed ? 8 : 4, static_cast<GLsizei>(count));
}

void SpritePasses::draw_ring(const PassTarget& target, const float* vertices, std::size_t count, unsigned texture) {
  if (count == 0) return;
  begin_pass(target, texture, false, Shading::plain, false, false, false);
  glBindVertexArray(ring_vao_);
  glBindBuffer(GL_ARRAY_BUFFER, ring_vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(count * ring_vertex_floats * sizeof(float)), vertices,
               GL_STREAM_DRAW);
  glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(count));
}

}  // namespace nephos::realtime
