#include "nephos/realtime/gl/hud.hpp"

#include <gtest/gtest.h>

#include <fmt/format.h>

namespace nephos::realtime {

TEST(Hud, EveryCharacterOfTheOverlayHasAGlyph) {
  // The view's overlay line, with extreme values.
  for (const std::string& line :
       {fmt::format("{:.1f} MS {:.0f} FPS SPD {:.0f} KT ALT {:.0f} FT IMP ON", 123.4, 59.0, 250.0, 8000.0),
        std::string("0123456789.:- IMP OFF")})
    for (char c : line) EXPECT_TRUE(hud_has_glyph(c)) << "'" << c << "'";
  EXPECT_FALSE(hud_has_glyph('#'));
}

TEST(Hud, GlyphsAreDistinctAndFitThreeColumns) {
  const std::string digits = "0123456789";
  for (char a : digits) {
    for (auto row : hud_glyph(a)) EXPECT_LT(row, 8);  // three columns
    for (char b : digits)
      if (a != b) {
        EXPECT_NE(hud_glyph(a), hud_glyph(b)) << a << " " << b;
      }
  }
  EXPECT_EQ(hud_glyph('m'), hud_glyph('M'));  // case-insensitive
}

}  // namespace nephos::realtime
