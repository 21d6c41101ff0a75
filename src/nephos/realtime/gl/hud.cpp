#include "nephos/realtime/gl/hud.hpp"

#include <GLES3/gl3.h>

#include <cctype>

namespace nephos::realtime {
namespace {

struct Glyph {
  char c;
  std::array<std::uint8_t, 5> rows;
};

// 3 x 5 cells; bit 2 is the left column.
constexpr Glyph glyphs[] = {
    {'0', {7, 5, 5, 5, 7}}, {'1', {2, 6, 2, 2, 7}}, {'2', {7, 1, 7, 4, 7}}, {'3', {7, 1, 7, 1, 7}},
    {'4', {5, 5, 7, 1, 1}}, {'5', {7, 4, 7, 1, 7}}, {'6', {7, 4, 7, 5, 7}}, {'7', {7, 1, 1, 2, 2}},
    {'8', {7, 5, 7, 5, 7}}, {'9', {7, 5, 7, 1, 7}}, {'.', {0, 0, 0, 0, 2}}, {':', {0, 2, 0, 2, 0}},
    {'-', {0, 0, 7, 0, 0}}, {' ', {0, 0, 0, 0, 0}}, {'M', {5, 7, 7, 5, 5}}, {'S', {3, 4, 2, 1, 6}},
    {'K', {5, 5, 6, 5, 5}}, {'T', {7, 2, 2, 2, 2}}, {'F', {7, 4, 6, 4, 4}}, {'P', {6, 5, 6, 4, 4}},
    {'A', {2, 5, 7, 5, 5}}, {'L', {4, 4, 4, 4, 7}}, {'D', {6, 5, 5, 5, 6}}, {'I', {7, 2, 2, 2, 7}},
    {'O', {2, 5, 5, 5, 2}}, {'N', {5, 7, 7, 7, 5}},
};

const Glyph* find(char c) {
  const char u = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  for (const Glyph& g : glyphs)
    if (g.c == u) return &g;
  return nullptr;
}

void fill(int x, int y, int w, int h, float r, float g, float b) {
  glScissor(x, y, w, h);
  glClearColor(r, g, b, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
}

}  // namespace

std::array<std::uint8_t, 5> hud_glyph(char c) {
  const Glyph* g = find(c);
  return g ? g->rows : std::array<std::uint8_t, 5>{};
}

bool hud_has_glyph(char c) { return find(c) != nullptr; }

void draw_hud_text(const std::string& text, int x, int y, int scale, int fb_height) {
  const int advance = 4 * scale, n = static_cast<int>(text.size());
  const int box_w = n * advance + scale, box_h = 7 * scale;
  glEnable(GL_SCISSOR_TEST);
  // GL's origin is the bottom-left corner.
  fill(x, fb_height - y - box_h, box_w, box_h, 0.05f, 0.05f, 0.08f);
  for (int i = 0; i < n; ++i) {
    const auto rows = hud_glyph(text[static_cast<std::size_t>(i)]);
    for (int r = 0; r < 5; ++r)
      for (int col = 0; col < 3; ++col)
        if (rows[static_cast<std::size_t>(r)] & (4 >> col))
          fill(x + scale + i * advance + col * scale, fb_height - y - (r + 2) * scale, scale, scale, 1.0f, 1.0f, 1.0f);
  }
  glDisable(GL_SCISSOR_TEST);
}

}  // namespace nephos::realtime
