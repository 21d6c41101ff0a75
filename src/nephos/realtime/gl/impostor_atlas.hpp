#pragma once
// The impostor ring's images on the GPU (MSFS 2004: eight 256 x 256 impostors): two texture
// arrays of eight layers, the front set drawn while the back one is rebuilt, and one scratch
// framebuffer each impostor is rendered into, a part per frame, before it is read back and
// copied into its set's layer. The frame planner decides what goes in (FramePlanner).
#include "nephos/realtime/frame_plan.hpp"
#include "nephos/realtime/gl/passes.hpp"

namespace nephos::realtime {

class ImpostorAtlas final : public ImpostorCanvas {
 public:
  /// Allocates both sets (2 MiB each) and the scratch framebuffer; IoError if it is incomplete.
  /// Draws with `passes` as `options` say (sprite trimming).
  ImpostorAtlas(SpritePasses& passes, const RenderOptions& options);
  void render(const Frustum& frustum, const float* instances, std::size_t count, bool clear) override;
  /// Reading the image back waits for its rendering, which the frame's glFinish would wait for
  /// anyway; the same texels then go into the set's layer (a texture filled by an upload and
  /// attached to no framebuffer is sampled faster by llvmpipe than a render target).
  ColumnSpans store(int set, int sector, bool& any) override;
  /// The texture array of set `set` (0 or 1).
  unsigned texture(int set) const { return textures_[set]; }

 private:
  SpritePasses& passes_;
  const RenderOptions& options_;
  unsigned textures_[2] = {0, 0}, fbo_ = 0, scratch_ = 0;
};

}  // namespace nephos::realtime
