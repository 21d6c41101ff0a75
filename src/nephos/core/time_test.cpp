#include "nephos/core/time.hpp"

#include <gtest/gtest.h>

#include "nephos/core/error.hpp"

namespace nephos {

TEST(UtcTime, KnownEpochs) {
  EXPECT_EQ(UtcTime::from_civil(1970, 1, 1).unix_s, 0);
  // 2000-01-01T12:00:00Z is J2000.0 = Unix 946728000 (published value).
  EXPECT_EQ(UtcTime::from_civil(2000, 1, 1, 12).unix_s, 946728000);
  EXPECT_EQ(UtcTime::from_civil(2000, 1, 1, 12).days_since_j2000(), 0.0);
  // 2011-01-15T12:00:00Z: Unix 1295092800 (date -u -d @1295092800).
  EXPECT_EQ(UtcTime::from_civil(2011, 1, 15, 12).unix_s, 1295092800);
}

TEST(UtcTime, ParseAndFormatRoundTrip) {
  EXPECT_EQ(UtcTime::parse("2011-01-15T12:00:00Z").iso(), "2011-01-15T12:00:00Z");
  EXPECT_EQ(UtcTime::parse("2024-02-29T23:59").iso(), "2024-02-29T23:59:00Z");
  EXPECT_EQ(UtcTime::parse("1969-12-31").iso(), "1969-12-31T00:00:00Z");
  EXPECT_THROW(UtcTime::parse("15/01/2011"), ValueError);
  EXPECT_THROW(UtcTime::parse("2011-13-01"), ValueError);
}

TEST(UtcTime, DaysBeyondTheMonthAreErrorsNotTheNextMonth) {
  // Gregorian leap years: divisible by 4, except centuries not divisible by 400.
  EXPECT_EQ(UtcTime::parse("2000-02-29").iso(), "2000-02-29T00:00:00Z");
  EXPECT_THROW(UtcTime::parse("1900-02-29"), ValueError);
  EXPECT_THROW(UtcTime::parse("2023-02-29"), ValueError);
  EXPECT_THROW(UtcTime::parse("2024-02-30"), ValueError);
  EXPECT_THROW(UtcTime::parse("2024-04-31"), ValueError);
  EXPECT_EQ(UtcTime::parse("2024-12-31").iso(), "2024-12-31T00:00:00Z");
  try {
    UtcTime::parse("2024-06-31T10:00:00Z");
    FAIL();
  } catch (const ValueError& e) {
    EXPECT_EQ(e.context().key, "time");
  }
}

}  // namespace nephos
