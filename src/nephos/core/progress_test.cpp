#include "nephos/core/progress.hpp"

#include <gtest/gtest.h>

#include <cstdlib>

#include "nephos/core/error.hpp"

namespace nephos {

TEST(Progress, BarShowsTheFractionDoneAndTheTimeLeft) {
  // 25 of 100 after 10 s: a quarter of the 30-character bar, and 30 s left at that rate.
  EXPECT_EQ(Progress::line("render", 25, 100, "", 10.0, false),
            "render             [#######.......................]  25.0%    10.0 s  eta   30.0 s");
  // The final line: full bar, no time left, a newline.
  EXPECT_EQ(Progress::line("render", 100, 100, "", 40.0, true),
            "render             [##############################] 100.0%    40.0 s  eta    0.0 s\n");
}

TEST(Progress, OpenEndedWorkCountsStepsAndShowsItsDetail) {
  // Iterations to convergence: no bar or time left, the steps and what decides the end, padded
  // so that a shorter detail overwrites a longer one on the same line.
  EXPECT_EQ(Progress::line("lighting", 42, 0, "residual 3.1e-04 (to 1e-05)", 1.5, false),
            "lighting               42 steps  residual 3.1e-04 (to 1e-05)        1.5 s");
  EXPECT_EQ(Progress::line("lighting", 42, 0, "a", 1.5, false).size(),
            Progress::line("lighting", 42, 0, "residual 3.1e-04 (to 1e-05)", 1.5, false).size());
}

TEST(Progress, DelayFromTheEnvironmentIsCheckedAndNamed) {
  ::setenv("NEPHOS_PROGRESS_DELAY_S", "soon", 1);
  try {
    Progress p("x", 10);
    FAIL() << "a delay that is not a number must be refused";
  } catch (const ValueError& e) {
    EXPECT_NE(std::string(e.what()).find("NEPHOS_PROGRESS_DELAY_S"), std::string::npos) << e.what();
  }
  ::setenv("NEPHOS_PROGRESS_DELAY_S", "0", 1);
  EXPECT_NO_THROW(Progress("x", Progress::OpenEnded{}));
  ::unsetenv("NEPHOS_PROGRESS_DELAY_S");
}

}  // namespace nephos
