#include "nephos/realtime/gl/gl_program.hpp"

#include <GLES3/gl3.h>

#include <optional>

#include "nephos/core/error.hpp"

namespace nephos::realtime {

namespace {

// The log of shader or program `object` if its `status` (GL_COMPILE_STATUS, GL_LINK_STATUS)
// is false; nothing if it is true. `get` and `get_log` are the shader's or the program's queries.
template <class Get, class GetLog>
std::optional<std::string> failure(GLuint object, GLenum status, Get get, GetLog get_log) {
  GLint ok = 0;
  get(object, status, &ok);
  if (ok) return std::nullopt;
  char log[2048] = {};
  get_log(object, sizeof log, nullptr, log);
  return std::string(log);
}

GLuint compile(GLenum type, const std::string& source) {
  const GLuint s = glCreateShader(type);
  const char* p = source.c_str();
  glShaderSource(s, 1, &p, nullptr);
  glCompileShader(s);
  if (const auto log = failure(s, GL_COMPILE_STATUS, glGetShaderiv, glGetShaderInfoLog)) {
    glDeleteShader(s);
    throw IoError(std::string(type == GL_VERTEX_SHADER ? "vertex" : "fragment") +
                  " shader compilation failed: " + *log);
  }
  return s;
}

}  // namespace

unsigned link_program(const std::string& vertex, const std::string& fragment) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertex);
  GLuint fs = 0;
  try {
    fs = compile(GL_FRAGMENT_SHADER, fragment);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  const GLuint p = glCreateProgram();
  glAttachShader(p, vs);
  glAttachShader(p, fs);
  glLinkProgram(p);
  // The program keeps what it linked; the shader objects go when it does.
  glDeleteShader(vs);
  glDeleteShader(fs);
  if (const auto log = failure(p, GL_LINK_STATUS, glGetProgramiv, glGetProgramInfoLog)) {
    glDeleteProgram(p);
    throw IoError("shader program does not link: " + *log);
  }
  return p;
}

}  // namespace nephos::realtime
