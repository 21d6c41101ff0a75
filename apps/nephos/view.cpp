#include "view.hpp"

#define GLFW_INCLUDE_NONE  // GL calls go through the realtime module
#include <GLFW/glfw3.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <vector>

#include "nephos/core/error.hpp"
#include "nephos/io/png.hpp"
#include "nephos/realtime/cloud_field.hpp"
#include "nephos/realtime/frame_logic.hpp"
#include "nephos/realtime/gl/hud.hpp"

namespace nephos::app {
namespace {

// GLFW reports errors through a callback; keep the last one for the exception message.
std::string& last_glfw_error() {
  static std::string e;
  return e;
}

struct Glfw {  // glfwInit / glfwTerminate, exception-safe
  Glfw() {
    glfwSetErrorCallback([](int, const char* msg) { last_glfw_error() = msg ? msg : ""; });
    if (!glfwInit())
      throw IoError("nephos view needs a window system (X11 or Wayland; DISPLAY is '" +
                    std::string(std::getenv("DISPLAY") ? std::getenv("DISPLAY") : "") + "'): " + last_glfw_error() +
                    ". For headless frames use nephos fly.");
  }
  ~Glfw() { glfwTerminate(); }
  Glfw(const Glfw&) = delete;
  Glfw& operator=(const Glfw&) = delete;
};

// Mouse-look state shared with the GLFW callbacks through the window's user pointer.
struct Input {
  bool dragging = false;
  double last_x = 0, last_y = 0, dx = 0, dy = 0;
  bool toggle_impostors = false;
};

double axis(GLFWwindow* w, int plus_a, int plus_b, int minus_a, int minus_b) {
  const bool p = glfwGetKey(w, plus_a) == GLFW_PRESS || glfwGetKey(w, plus_b) == GLFW_PRESS;
  const bool m = glfwGetKey(w, minus_a) == GLFW_PRESS || glfwGetKey(w, minus_b) == GLFW_PRESS;
  return (p ? 1.0 : 0.0) - (m ? 1.0 : 0.0);
}

}  // namespace

void write_rgb_png(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgba) {
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  std::vector<std::uint8_t> rgb(3 * n);
  for (std::size_t i = 0; i < n; ++i) std::copy_n(rgba.data() + 4 * i, 3, rgb.data() + 3 * i);
  io::write_png(path, width, height, 3, rgb);
}

int run_view(const ViewOptions& o) {
  Glfw glfw;
  if (o.api == realtime::GlApi::gl33) {
    glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  } else {
    glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_ES_API);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 0);
  }
  GLFWwindow* window = glfwCreateWindow(o.width, o.height, "nephos view", nullptr, nullptr);
  if (!window)
    throw IoError(fmt::format("cannot open a {}x{} window with an {} context: {}", o.width, o.height,
                              o.api == realtime::GlApi::gl33 ? "OpenGL 3.3 core" : "OpenGL ES 3.0", last_glfw_error()));
  const std::unique_ptr<GLFWwindow, void (*)(GLFWwindow*)> window_guard(window, glfwDestroyWindow);
  glfwMakeContextCurrent(window);
  glfwSwapInterval(o.frames > 0 ? 0 : 1);  // scripted runs go as fast as they can

  Input input;
  glfwSetWindowUserPointer(window, &input);
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int) {
    auto* in = static_cast<Input*>(glfwGetWindowUserPointer(w));
    if (button != GLFW_MOUSE_BUTTON_LEFT) return;
    in->dragging = action == GLFW_PRESS;
    glfwGetCursorPos(w, &in->last_x, &in->last_y);
  });
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double x, double y) {
    auto* in = static_cast<Input*>(glfwGetWindowUserPointer(w));
    if (!in->dragging) return;
    in->dx += x - in->last_x, in->dy += y - in->last_y;
    in->last_x = x, in->last_y = y;
  });
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int) {
    auto* in = static_cast<Input*>(glfwGetWindowUserPointer(w));
    if (action != GLFW_PRESS) return;
    if (key == GLFW_KEY_ESCAPE || key == GLFW_KEY_Q) glfwSetWindowShouldClose(w, GLFW_TRUE);
    if (key == GLFW_KEY_I) in->toggle_impostors = true;
  });

  // The renderer draws at the requested size off screen; present() scales it to the window.
  realtime::SpriteRenderer renderer(realtime::SpriteRenderer::UseCurrentContext{}, o.width, o.height, o.seed, o.api);
  renderer.set_impostor_radius(o.impostor_radius_m);
  renderer.set_single_sprite_distance(o.single_sprite_distance_m);
  spdlog::info("OpenGL: {} on {}; keys: arrows or A/D turn and climb, W/S speed, I impostors, Q/Esc quit; drag to look",
               renderer.gl_version(), renderer.gl_renderer());
  realtime::FlightControls flight;
  flight.speed_m_s = o.speed_m_s;
  glm::dvec3 position{0, 0, o.altitude_m};
  realtime::CloudField field(o.recipe, o.seed, position);
  const realtime::SunLight sun = realtime::sun_light(o.time, o.lat_deg, o.lon_deg);
  realtime::ResortPolicy policy;
  bool impostors = o.impostors;
  double sim_s = 0, shown_ms = 0, ms_sum = 0;
  int ms_count = 0;
  auto last = std::chrono::steady_clock::now();
  for (int frame = 0; !glfwWindowShouldClose(window) && (o.frames == 0 || frame < o.frames); ++frame) {
    glfwPollEvents();
    const auto now = std::chrono::steady_clock::now();
    // Scripted runs advance 1/30 s per frame (deterministic); interactive ones by the wall clock.
    const double dt = o.frames > 0 ? 1.0 / 30.0 : std::min(0.1, std::chrono::duration<double>(now - last).count());
    last = now;
    realtime::ControlInput in;
    in.turn = axis(window, GLFW_KEY_RIGHT, GLFW_KEY_D, GLFW_KEY_LEFT, GLFW_KEY_A);
    in.climb = axis(window, GLFW_KEY_UP, GLFW_KEY_UP, GLFW_KEY_DOWN, GLFW_KEY_DOWN);
    in.throttle = axis(window, GLFW_KEY_W, GLFW_KEY_W, GLFW_KEY_S, GLFW_KEY_S);
    in.look_yaw_deg = 0.2 * input.dx, in.look_pitch_deg = -0.2 * input.dy;  // 0.2 deg per pixel dragged
    input.dx = input.dy = 0;
    if (input.toggle_impostors) impostors = !impostors, input.toggle_impostors = false;
    flight.step(in, dt, position);
    sim_s += dt;

    field.advance_time(sim_s);
    realtime::Camera cam{position, flight.view_direction(), {0, 0, 1}, 60};
    field.follow_camera(cam.position, cam.forward);
    const realtime::FrameStats st = renderer.draw(field, cam, sun, policy.due(cam.position, cam.forward), impostors);
    int fb_w = 0, fb_h = 0;
    glfwGetFramebufferSize(window, &fb_w, &fb_h);
    renderer.present(fb_w, fb_h);
    // Frame time: CPU time of the frame around glFinish, averaged over half a second.
    ms_sum += st.milliseconds, ++ms_count;
    if (ms_count == 1 && shown_ms == 0) shown_ms = st.milliseconds;
    if (ms_count >= 15) shown_ms = ms_sum / ms_count, ms_sum = 0, ms_count = 0;
    const int scale = std::max(2, fb_h / 240);
    realtime::draw_hud_text(fmt::format("{:.1f} MS {:.0f} FPS", shown_ms, 1000.0 / std::max(shown_ms, 0.1)), scale * 2,
                            scale * 2, scale, fb_h);
    realtime::draw_hud_text(
        fmt::format("SPD {:.0f} KT ALT {:.0f} FT IMP {}", flight.speed_m_s / realtime::metres_per_second_per_knot,
                    position.z / realtime::metres_per_foot, impostors ? "ON" : "OFF"),
        scale * 2, scale * 10, scale, fb_h);
    const bool last_frame = o.frames > 0 && frame + 1 == o.frames;
    if (last_frame && !o.screenshot.empty())
      write_rgb_png(o.screenshot, fb_w, fb_h, realtime::read_framebuffer_rgba(0, fb_w, fb_h));
    glfwSwapBuffers(window);
  }
  std::cout << fmt::format("view: {:.1f} s of flight, last frame time {:.1f} ms ({})\n", sim_s, shown_ms,
                           realtime::name(o.api));
  return 0;
}

}  // namespace nephos::app
