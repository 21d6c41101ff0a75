#include "nephos/realtime/gl/impostor_atlas.hpp"

#include <GLES3/gl3.h>

#include <vector>

#include "nephos/core/error.hpp"

namespace nephos::realtime {

ImpostorAtlas::ImpostorAtlas(SpritePasses& passes, const RenderOptions& options) : passes_(passes), options_(options) {
  // 2 sets x 8 sectors x 256 x 256 RGBA8 (premultiplied).
  glGenTextures(2, textures_);
  for (GLuint t : textures_) {
    glBindTexture(GL_TEXTURE_2D_ARRAY, t);
    glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGBA8, impostor_size, impostor_size, 8, 0, GL_RGBA, GL_UNSIGNED_BYTE,
                 nullptr);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  glGenFramebuffers(1, &fbo_);
  glGenRenderbuffers(1, &scratch_);
  glBindRenderbuffer(GL_RENDERBUFFER, scratch_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, impostor_size, impostor_size);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, scratch_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw IoError("OpenGL ES: impostor framebuffer incomplete");
}

void ImpostorAtlas::render(const Frustum& frustum, const float* instances, std::size_t count, bool clear) {
  const PassTarget target{frustum, fbo_, impostor_size, impostor_size, {0, 0, 0, 0}};
  passes_.draw(target, instances, count, passes_.sprite_texture(), clear, Shading::bent_normal, false,
               options_.trim_sprites, false);
}

ColumnSpans ImpostorAtlas::store(int set, int sector, bool& any) {
  static thread_local std::vector<std::uint8_t> rgba;
  rgba.resize(4 * static_cast<std::size_t>(impostor_size) * impostor_size);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glReadPixels(0, 0, impostor_size, impostor_size, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());  // rows from the bottom
  glBindTexture(GL_TEXTURE_2D_ARRAY, textures_[set]);
  glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, sector, impostor_size, impostor_size, 1, GL_RGBA, GL_UNSIGNED_BYTE,
                  rgba.data());
  return column_spans(rgba.data(), any);
}

}  // namespace nephos::realtime
