# Writes OUT, a C++ source defining one string per shader file of IN_FILES (comma-separated):
# nephos::realtime::shaders::<name> for <name>.glsl with '.' as '_' (sprite.vert.glsl: sprite_vert).
string(REPLACE "," ";" IN_FILES "${IN_FILES}")
set(code "// Generated from the .glsl files by embed.cmake; edit those.\nnamespace nephos::realtime::shaders {\n")
foreach(file IN LISTS IN_FILES)
  get_filename_component(name "${file}" NAME_WLE)
  string(REPLACE "." "_" name "${name}")
  file(READ "${file}" text)
  string(APPEND code "extern const char* const ${name};\nconst char* const ${name} = R\"glsl(${text})glsl\";\n")
endforeach()
string(APPEND code "}  // namespace nephos::realtime::shaders\n")
file(WRITE "${OUT}.tmp" "${code}")
file(RENAME "${OUT}.tmp" "${OUT}")
