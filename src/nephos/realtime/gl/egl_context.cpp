#include "nephos/realtime/gl/egl_context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <atomic>

#include "nephos/core/error.hpp"

namespace nephos::realtime {

GlApi gl_api_from_name(const std::string& name) {
  if (name == "gles3") return GlApi::gles30;
  if (name == "gl33") return GlApi::gl33;
  throw ValueError("expected gles3 (OpenGL ES 3.0) or gl33 (OpenGL 3.3 core), got '" + name + "'", {.key = "gl"});
}

const char* name(GlApi api) { return api == GlApi::gl33 ? "gl33" : "gles3"; }

namespace {
// Contexts alive: they share the EGL display (EGL hands out one per device), which
// eglTerminate would pull from under the others, so the last one terminates it.
std::atomic<int> live_contexts{0};
}  // namespace

EglContext::EglContext(GlApi api) : display_(EGL_NO_DISPLAY), context_(EGL_NO_CONTEXT) {
  auto get_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  EGLDisplay dpy =
      get_display ? get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr) : EGL_NO_DISPLAY;
  if (dpy == EGL_NO_DISPLAY) dpy = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  EGLint major = 0, minor = 0;
  if (dpy == EGL_NO_DISPLAY || !eglInitialize(dpy, &major, &minor))
    throw IoError("EGL: no display could be initialised");
  display_ = dpy;
  const bool desktop = api == GlApi::gl33;
  if (!eglBindAPI(desktop ? EGL_OPENGL_API : EGL_OPENGL_ES_API))
    throw IoError(desktop ? "EGL: the desktop OpenGL API is not available" : "EGL: OpenGL ES is not available");
  const EGLint cfg_attr[] = {EGL_RENDERABLE_TYPE, desktop ? EGL_OPENGL_BIT : EGL_OPENGL_ES3_BIT, EGL_NONE};
  EGLConfig cfg = nullptr;
  EGLint n = 0;
  eglChooseConfig(dpy, cfg_attr, &cfg, 1, &n);
  const EGLint es_attr[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0, EGL_NONE};
  const EGLint gl_attr[] = {
      EGL_CONTEXT_MAJOR_VERSION,           3,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  EGLContext ctx = eglCreateContext(dpy, n ? cfg : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, desktop ? gl_attr : es_attr);
  if (ctx == EGL_NO_CONTEXT || !eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx))
    throw IoError(desktop ? "EGL: cannot create an OpenGL 3.3 core context"
                          : "EGL: cannot create an OpenGL ES 3.0 context");
  context_ = ctx;
  ++live_contexts;
}

EglContext::~EglContext() {
  // Released only if it is this context: another may be current.
  if (eglGetCurrentContext() == context_) eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(display_, context_);
  if (--live_contexts == 0) eglTerminate(display_);
}

void EglContext::make_current() {
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    throw IoError("EGL: eglMakeCurrent failed for a sprite renderer's context");
}

void EglContext::release_current() {
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT))
    throw IoError("EGL: eglMakeCurrent failed to release a sprite renderer's context");
}

}  // namespace nephos::realtime
