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

TEST(Error, BytesThatAreNotTextAreEscaped) {
  // A parser quoting what it read from a binary file: control bytes, a lone continuation byte, a
  // truncated sequence, an overlong encoding of '/' (C0 AF) and a UTF-16 surrogate (ED A0 80) are
  // not UTF-8 text (RFC 3629) and are shown as \xNN; real UTF-8 (degree sign, micro sign, a
  // 4-byte emoji) and tabs and newlines pass unchanged.
  const FormatError e(std::string("last read: '\x01\x8f\x7f' \xe2\x82 \xc0\xaf \xed\xa0\x80") +
                          " 10.3 \xc2\xb5m, 45\xc2\xb0, \xf0\x9f\x8c\xa7\ta\nb",
                      {.file = std::string("f\x1b.json")});
  EXPECT_EQ(std::string(e.what()),
            "f\\x1b.json: last read: '\\x01\\x8f\\x7f' \\xe2\\x82 \\xc0\\xaf \\xed\\xa0\\x80 10.3 \xc2\xb5m, "
            "45\xc2\xb0, \xf0\x9f\x8c\xa7\ta\nb");
  EXPECT_EQ(e.message().substr(0, 25), "last read: '\\x01\\x8f\\x7f'");
}

}  // namespace nephos
