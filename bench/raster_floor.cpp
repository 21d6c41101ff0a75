// nephos_raster_floor: what a pixel costs the OpenGL implementation at hand (on the CI machine,
// Mesa's llvmpipe), for the kinds of pixel a sprite-cloud frame is made of: the clear, a
// constant colour, one or two bilinear fetches from a 2D array texture (the impostor ring's,
// the flat-layer pair's), blended or not, and one textured quad cut into columns (the ring's
// trim). Each case fills the whole 1280 x 720 frame REPS times (default 200), timed on the CPU
// around glFinish as `nephos bench fly` times its frames; the figure per pixel is what a
// frame's part costs per pixel it covers at best, the floor that docs/PERFORMANCE.md compares
// the sprite frame's parts with.
//   nephos_raster_floor [REPS]
#include <GLES3/gl3.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "nephos/core/error.hpp"
#include "nephos/realtime/gl/gl_program.hpp"
#include "nephos/realtime/gl/sprite_renderer.hpp"

namespace {

constexpr int width = 1280, height = 720;

// A program whose fragment shader is `body`; texture coordinates run over the quad, and with
// `perspective` the quad's w grows from 1 at its bottom to 5 at its top, as a plane seen at a
// slant (the interpolation then divides per pixel).
GLuint program(const std::string& body, bool perspective) {
  const std::string vs =
      std::string("#version 300 es\nlayout(location = 0) in vec2 p;\nout vec2 uv;\nout vec4 shade;\n") +
      "void main() {\n  uv = p * 0.5 + 0.5;\n  shade = vec4(uv, 0.5, 0.5);\n  float w = " +
      (perspective ? "1.0 + 2.0 * (p.y + 1.0)" : "1.0") + ";\n  gl_Position = vec4(p * w, 0.0, w);\n}\n";
  const std::string fs =
      "#version 300 es\nprecision highp float;\nprecision highp sampler2DArray;\nin vec2 uv;\nin vec4 shade;\n"
      "uniform sampler2DArray small;  // 64 x 64 x 16, as the sprite textures\n"
      "uniform sampler2DArray large;  // 256 x 256 x 8, as an impostor set\nout vec4 frag;\nvoid main() {\n  " +
      body + "\n}\n";
  const GLuint p = nephos::realtime::link_program(vs, fs);
  glUseProgram(p);
  glUniform1i(glGetUniformLocation(p, "small"), 0);
  glUniform1i(glGetUniformLocation(p, "large"), 1);
  return p;
}

// A 2D array texture of `size`^2 x `layers` RGBA8 texels of hashed (non-repeating) content,
// linearly filtered and clamped, in texture unit `unit`.
void texture_array(int unit, int size, int layers) {
  std::vector<std::uint8_t> texels(4 * static_cast<std::size_t>(size) * size * layers);
  for (std::size_t i = 0; i < texels.size(); ++i)
    texels[i] = static_cast<std::uint8_t>((static_cast<std::uint32_t>(i) * 2654435761u) >> 24);
  GLuint t = 0;
  glGenTextures(1, &t);
  glActiveTexture(GL_TEXTURE0 + unit);
  glBindTexture(GL_TEXTURE_2D_ARRAY, t);
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA8, size, size, layers, 0, GL_RGBA, GL_UNSIGNED_BYTE, texels.data());
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
}

// The whole frame as `columns` side by side, two triangles each (the ring's trimmed columns
// have uneven bottoms: so do these, within the frame's lowest 10 %, so that the diagonals slant).
std::vector<float> quad(int columns) {
  if (columns <= 1) return {-1, -1, 1, -1, -1, 1, -1, 1, 1, -1, 1, 1};
  std::vector<float> v;
  for (int k = 0; k < columns; ++k) {
    const float x0 = -1 + 2.0f * static_cast<float>(k) / static_cast<float>(columns);
    const float x1 = -1 + 2.0f * static_cast<float>(k + 1) / static_cast<float>(columns);
    const float b0 = -1 + 0.05f * static_cast<float>((7 * k) % 5),
                b1 = -1 + 0.05f * static_cast<float>((7 * (k + 1)) % 5);
    v.insert(v.end(), {x0, b0, x1, b1, x0, 1, x0, 1, x1, b1, x1, 1});
  }
  return v;
}

struct Case {
  const char* name;
  const char* shader;  // fragment shader body; nullptr: the clear alone
  bool blend;
  bool perspective;
  int columns;
};

}  // namespace

int main(int argc, char** argv) try {
  const std::string arg = argc > 1 ? argv[1] : "200";
  if (arg.empty() || arg.size() > 6 || arg.find_first_not_of("0123456789") != std::string::npos || std::stoi(arg) < 1)
    throw nephos::ValueError("expected a whole number of frames from 1 to 999999, got '" + arg + "'", {.key = "REPS"});
  const int reps = std::stoi(arg);
  // The sprite renderer's headless context (EGL, surfaceless), drawn into a framebuffer of our own.
  nephos::realtime::SpriteRenderer context(width, height, 1);
  context.make_current();
  GLuint fbo = 0, colour = 0;
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glGenRenderbuffers(1, &colour);
  glBindRenderbuffer(GL_RENDERBUFFER, colour);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw nephos::IoError("framebuffer incomplete");
  glViewport(0, 0, width, height);
  texture_array(0, 64, 16);
  texture_array(1, 256, 8);
  GLuint vao = 0, vbo = 0;
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glGenBuffers(1, &vbo);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);  // premultiplied, as every blended draw of the renderer

  const char* one = "frag = texture(large, vec3(uv, 3.0));";
  const Case cases[] = {
      {"clear alone", nullptr, false, false, 1},
      {"constant colour", "frag = vec4(0.3);", false, false, 1},
      {"constant colour, blended", "frag = vec4(0.3);", true, false, 1},
      {"interpolated colour, blended, perspective", "frag = shade;", true, true, 1},
      {"one fetch (64^2 array)", "frag = texture(small, vec3(uv, 3.0));", false, false, 1},
      {"one fetch (256^2 array)", one, false, false, 1},
      {"one fetch (256^2 array), blended", one, true, false, 1},
      {"one fetch, blended, perspective", one, true, true, 1},
      {"two fetches (the layer pair's)", "frag = texture(large, vec3(uv, 3.0)) + texture(large, vec3(uv * 1.7, 2.0));",
       false, false, 1},
      {"one fetch, blended, 32 columns (40 px)", one, true, false, 32},
      {"one fetch, blended, 64 columns (20 px)", one, true, false, 64},
      {"one fetch, blended, 128 columns (10 px)", one, true, false, 128},
  };
  std::printf("nephos_raster_floor: %dx%d, %d frames per case, %s on %s\n", width, height, reps,
              context.gl_version().c_str(), context.gl_renderer().c_str());
  std::printf("%-44s %9s %9s %9s\n", "case", "mean ms", "min ms", "ns/px");
  for (const Case& c : cases) {
    const GLuint p = c.shader ? program(c.shader, c.perspective) : 0;
    if (c.blend)
      glEnable(GL_BLEND);
    else
      glDisable(GL_BLEND);
    const std::vector<float> v = quad(c.columns);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
    double sum = 0, best = 1e300;
    for (int r = -5; r < reps; ++r) {  // five untimed frames first: llvmpipe compiles a variant on first use
      const auto t0 = std::chrono::steady_clock::now();
      glClearColor(0.2f, 0.3f, 0.4f, 1.0f);
      glClear(GL_COLOR_BUFFER_BIT);
      if (c.shader) glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(v.size() / 2));
      glFinish();
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (r >= 0) sum += ms, best = std::min(best, ms);
    }
    if (p) glDeleteProgram(p);
    const double mean = sum / reps;
    std::printf("%-44s %9.3f %9.3f %9.2f\n", c.name, mean, best, 1e6 * mean / (width * height));
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "nephos_raster_floor: %s\n", e.what());
  return 1;
}
