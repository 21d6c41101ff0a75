#include "nephos/io/png.hpp"

#include <gtest/gtest.h>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"

namespace nephos::io {

TEST(Png, RoundTripsPixelsExactly) {
  const auto path = test_support::temp_path("png_test.png");
  std::vector<std::uint8_t> px(7 * 5 * 3);
  for (std::size_t i = 0; i < px.size(); ++i) px[i] = static_cast<std::uint8_t>(i * 37);
  write_png(path, 7, 5, 3, px);
  int w = 0, h = 0, c = 0;
  EXPECT_EQ(read_png(path, w, h, c), px);
  EXPECT_EQ(w, 7);
  EXPECT_EQ(h, 5);
  EXPECT_EQ(c, 3);
  std::filesystem::remove(path);
}

TEST(Png, BadSizeThrowsAndWritesNothing) {
  const auto path = test_support::temp_path("png_bad.png");
  std::filesystem::remove(path);
  EXPECT_THROW(write_png(path, 4, 4, 3, std::vector<std::uint8_t>(5)), ValueError);
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_THROW(write_png("/nonexistent-dir/x.png", 1, 1, 1, {0}), IoError);
}

}  // namespace nephos::io
