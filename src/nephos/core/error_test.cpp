#include "nephos/core/error.hpp"

#include <gtest/gtest.h>

namespace nephos {

TEST(Error, MessageNamesFileFieldAndKey) {
  const FormatError e("no isobaric levels", {.file = "a.grib2", .field = "gh", .line = 0});
  EXPECT_STREQ(e.what(), "a.grib2: field 'gh': no isobaric levels");
  EXPECT_EQ(e.message(), "no isobaric levels");
  const ConfigError c("unknown key", {.file = "c.toml", .key = "x.y", .line = 7});
  EXPECT_STREQ(c.what(), "c.toml:7: key 'x.y': unknown key");
  // All typed errors are catchable as nephos::Error.
  EXPECT_THROW(throw IoError("x"), Error);
}

}  // namespace nephos
