#pragma once
// A GLSL program from its two shaders, for the sprite renderer and the programs that measure
// the OpenGL implementation under it (bench/raster_floor.cpp). Needs a current context.
#include <string>

namespace nephos::realtime {

/// Compiles `vertex` and `fragment` (whole GLSL sources, #version line first) and links them;
/// returns the program's name (a GLuint). Throws IoError with the compiler's log if a shader
/// does not compile, or if the program does not link.
unsigned link_program(const std::string& vertex, const std::string& fragment);

}  // namespace nephos::realtime
