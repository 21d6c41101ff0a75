#pragma once
// A headless OpenGL ES 3.0 or OpenGL 3.3 core context through EGL (Mesa's surfaceless
// platform: llvmpipe without a GPU, the GPU's driver with one), for the sprite renderer.
#include <string>

namespace nephos::realtime {

/// Which OpenGL: ES 3.0 or desktop 3.3 core profile.
enum class GlApi { gles30, gl33 };
/// "gles3" or "gl33" (ValueError naming "gl" and the accepted values otherwise).
GlApi gl_api_from_name(const std::string& name);
const char* name(GlApi api);

class EglContext {
 public:
  /// Creates a context of `api` and makes it current. Throws IoError naming the EGL step that
  /// failed (no display, API not available, no context).
  explicit EglContext(GlApi api);
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;
  /// Makes the context current in the calling thread (EGL lets a context be current in one
  /// thread at a time). IoError if EGL refuses.
  void make_current();
  /// Detaches the context from the calling thread. IoError if EGL refuses.
  void release_current();

 private:
  void* display_;  // EGLDisplay
  void* context_;  // EGLContext
};

}  // namespace nephos::realtime
