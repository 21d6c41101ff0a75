#include "nephos/core/parse.hpp"

#include <gtest/gtest.h>

#include "nephos/core/error.hpp"

namespace nephos {

TEST(ParseNumbers, ExactCountAndStrictNumbers) {
  EXPECT_EQ(parse_numbers("135,45", 2, "--sun", "AZ,EL"), (std::vector<double>{135, 45}));
  EXPECT_EQ(parse_numbers("-5,-30.5,700,12", 4, "--sensor", "leo"), (std::vector<double>{-5, -30.5, 700, 12}));
  EXPECT_THROW(parse_numbers("135", 2, "--sun", "AZ,EL"), ValueError);        // too few
  EXPECT_THROW(parse_numbers("1,2,3", 2, "--sun", "AZ,EL"), ValueError);      // too many
  EXPECT_THROW(parse_numbers("12abc,3", 2, "--sun", "AZ,EL"), ValueError);    // trailing junk
  try {
    parse_numbers("x,1", 2, "--sun", "AZ,EL");
    FAIL();
  } catch (const ValueError& e) {
    EXPECT_EQ(e.context().key, "--sun");
  }
}

}  // namespace nephos
