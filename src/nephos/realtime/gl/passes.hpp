#pragma once
// The GL submits of the sprite renderer: its shader programs (one per Shading, compiled from
// the embedded sprite.vert.glsl/sprite.frag.glsl with that shading's defines), the sprite texture array,
// and the draws of instances and of the impostor ring's triangles into a target. Needs a
// current context.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "nephos/realtime/frame_plan.hpp"
#include "nephos/realtime/gl/egl_context.hpp"
#include "nephos/realtime/sprite_textures.hpp"

namespace nephos::realtime {

/// Where a pass draws: a frustum into a framebuffer of a size, cleared to a colour.
struct PassTarget {
  Frustum frustum;
  unsigned fbo = 0;
  int width = 0, height = 0;
  std::array<float, 4> clear{};
};

class SpritePasses {
 public:
  /// The programs for `api`, and the sprite textures baked from `seed` and uploaded.
  SpritePasses(GlApi api, std::uint64_t seed);
  SpritePasses(const SpritePasses&) = delete;
  SpritePasses& operator=(const SpritePasses&) = delete;

  /// Clears `target` to its colour.
  static void clear(const PassTarget& target);
  /// Draws `count` instances (instance_floats each) with `shading` from `texture` into
  /// `target`, cleared first if `clear`, blended over it (premultiplied alpha) or, with
  /// `over_sky`, composited with the target's clear colour in the shader and written without
  /// blending (flat layers only: ValueError naming "shading" otherwise). Sprites (bent-normal
  /// shading) cover their layer's octagon if `trimmed`; `vertical_views` shows flat layers'
  /// vertical view everywhere. With no instances, at most the clear.
  void draw(const PassTarget& target, const float* instances, std::size_t count, unsigned texture, bool clear,
            Shading shading, bool over_sky, bool trimmed, bool vertical_views);
  /// Draws `count` vertices (ring_vertex_floats each) of the impostor ring's triangles from
  /// `texture`, flat shaded, blended over `target`.
  void draw_ring(const PassTarget& target, const float* vertices, std::size_t count, unsigned texture);
  /// The sprite texture array (sprite_textures.hpp's layers).
  unsigned sprite_texture() const { return texture_; }
  /// The sky colour the frames are cleared to (RGBA8).
  static std::array<std::uint8_t, 4> sky_colour() { return {110, 160, 225, 255}; }

 private:
  struct Program {
    unsigned id = 0;
    int u_view_proj = -1, u_right = -1, u_up = -1, u_sprites = -1, u_sun = -1, u_front = -1, u_trim = -1, u_under = -1,
        u_sheet_mean = -1, u_view_scale = -1;
  };
  void link(Program& p, const std::string& version, const std::string& defines);
  void make_vertex_arrays();
  void begin_pass(const PassTarget& target, unsigned texture, bool clear, Shading shading, bool over_sky, bool trimmed,
                  bool vertical_views);
  // Programs from the same source, each compiled with only what its draws need (on llvmpipe a
  // shader pays for a branch's body on every fragment).
  std::array<Program, 6> programs_;                     // by Shading
  std::array<float, 3 * texture_layer_count> trim_{};   // SpriteTrim per texture layer (a, b, c)
  std::array<float, 4 * 2 * slab_types> sheet_mean_{};  // mean texel of each flat-layer texture
  unsigned texture_ = 0, vao_ = 0, quad_ = 0, instances_ = 0, ring_vao_ = 0, ring_vbo_ = 0;
};

}  // namespace nephos::realtime
