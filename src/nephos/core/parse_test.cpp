#include "nephos/core/parse.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "nephos/core/error.hpp"

namespace nephos {

TEST(ParseNumbers, ExactCountAndStrictNumbers) {
  EXPECT_EQ(parse_numbers("135,45", 2, "--sun", "AZ,EL"), (std::vector<double>{135, 45}));
  EXPECT_EQ(parse_numbers("-5,-30.5,700,12", 4, "--sensor", "leo"), (std::vector<double>{-5, -30.5, 700, 12}));
  EXPECT_THROW(parse_numbers("135", 2, "--sun", "AZ,EL"), ValueError);      // too few
  EXPECT_THROW(parse_numbers("1,2,3", 2, "--sun", "AZ,EL"), ValueError);    // too many
  EXPECT_THROW(parse_numbers("12abc,3", 2, "--sun", "AZ,EL"), ValueError);  // trailing junk
  EXPECT_THROW(parse_numbers("nan,3", 2, "--sun", "AZ,EL"), ValueError);    // not finite
  EXPECT_THROW(parse_numbers("1,-inf", 2, "--sun", "AZ,EL"), ValueError);
  EXPECT_THROW(parse_numbers("1e400,1", 2, "--sun", "AZ,EL"), ValueError);  // overflows a double
  try {
    parse_numbers("x,1", 2, "--sun", "AZ,EL");
    FAIL();
  } catch (const ValueError& e) {
    EXPECT_EQ(e.context().key, "--sun");
  }
}

TEST(RequireRange, ClosedIntervalAndNaNFails) {
  EXPECT_NO_THROW(require_range(-90, -90, 90, "--position", "latitude [deg]"));
  EXPECT_NO_THROW(require_range(90, -90, 90, "--position", "latitude [deg]"));
  EXPECT_THROW(require_range(90.5, -90, 90, "--position", "latitude [deg]"), ValueError);
  EXPECT_THROW(require_range(std::nan(""), -90, 90, "--position", "latitude [deg]"), ValueError);
  try {
    require_range(95, -90, 90, "--position", "latitude [deg]");
    FAIL();
  } catch (const ValueError& e) {
    EXPECT_EQ(e.context().key, "--position");
    EXPECT_NE(std::string(e.what()).find("latitude [deg] must be in [-90, 90], got 95"), std::string::npos) << e.what();
  }
}

TEST(RequireRange, AboveExcludesItsLowerBound) {
  EXPECT_NO_THROW(require_range_above(1e-9, 0, 10, "--impostor-radius-km", "radius [km]"));
  EXPECT_NO_THROW(require_range_above(10, 0, 10, "--impostor-radius-km", "radius [km]"));
  EXPECT_THROW(require_range_above(0, 0, 10, "--impostor-radius-km", "radius [km]"), ValueError);
  EXPECT_THROW(require_range_above(10.5, 0, 10, "--impostor-radius-km", "radius [km]"), ValueError);
  EXPECT_THROW(require_range_above(std::nan(""), 0, 10, "--impostor-radius-km", "radius [km]"), ValueError);
  try {
    require_range_above(-3, 0, 10, "--impostor-radius-km", "radius [km]");
    FAIL();
  } catch (const ValueError& e) {
    EXPECT_EQ(e.context().key, "--impostor-radius-km");
    EXPECT_NE(std::string(e.what()).find("radius [km] must be in (0, 10], got -3"), std::string::npos) << e.what();
  }
}

TEST(RequireMemory, MoreThanThePhysicalMemoryIsAResourceError) {
  const double have = physical_memory_bytes();
  EXPECT_GT(have, 64.0 * (1 << 20));  // any machine that runs the tests has more than 64 MiB
  EXPECT_NO_THROW(require_memory(0.5 * have, "--grid", "the lattice"));
  try {
    require_memory(2 * have, "--grid", "the lattice");
    FAIL();
  } catch (const ResourceError& e) {
    EXPECT_EQ(e.context().key, "--grid");
  }
}

}  // namespace nephos
