#include "nephos/core/atomic_file.hpp"
#include "nephos/core/test_support.hpp"

#include <gtest/gtest.h>

#include <fstream>

namespace nephos {

TEST(AtomicFile, NothingAppearsWithoutCommit) {
  const auto dir = test_support::temp_path("atomic_test");
  ensure_directory(dir);
  const auto dest = dir / "out.txt";
  std::filesystem::remove(dest);
  {
    AtomicFile f(dest);
    std::ofstream(f.temp_path()) << "partial";
    // no commit: as if an exception unwound the writer
  }
  EXPECT_FALSE(std::filesystem::exists(dest));
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  {
    AtomicFile f(dest);
    std::ofstream(f.temp_path()) << "whole";
    f.commit();
  }
  EXPECT_TRUE(std::filesystem::exists(dest));
  std::filesystem::remove_all(dir);
}

}  // namespace nephos
