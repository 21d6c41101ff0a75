#pragma once
// A minimal on-screen text overlay for the window view (frame time, speed, altitude): a 3 x 5
// pixel bitmap font drawn with scissored clears, so it needs no font file, texture or shader
// and works the same on OpenGL ES 3.0 and OpenGL 3.3.
#include <array>
#include <cstdint>
#include <string>

namespace nephos::realtime {

/// The 3 x 5 bitmap of `c` (rows top to bottom, bit 2 = left column); digits, '.', ':', '-',
/// ' ', and the letters of "ms kt ft fps ALT SPD IMP ON OFF". Other characters: an empty cell.
std::array<std::uint8_t, 5> hud_glyph(char c);
/// True if `c` has a glyph (not the empty fallback).
bool hud_has_glyph(char c);

/// Draws `text` into the bound draw framebuffer with its top-left corner at (x, y) pixels from
/// the top-left of a `fb_height`-pixel-high framebuffer, each font pixel `scale` x `scale`
/// pixels, white on a dark box. Leaves the scissor test off.
void draw_hud_text(const std::string& text, int x, int y, int scale, int fb_height);

}  // namespace nephos::realtime
