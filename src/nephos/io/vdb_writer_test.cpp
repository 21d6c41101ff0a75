#include "nephos/io/vdb_writer.hpp"

#include <gtest/gtest.h>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"

namespace nephos::io {

TEST(Vdb, RoundTripsASparseDensity) {
  const auto path = test_support::temp_path("vdb_test.vdb");
  const int nx = 10, ny = 8, nz = 6;
  std::vector<float> d(static_cast<std::size_t>(nx) * ny * nz, 0.0f);
  d[(2 * ny + 3) * nx + 4] = 0.75f;  // (4, 3, 2)
  d[(5 * ny + 7) * nx + 9] = 0.25f;  // (9, 7, 5)
  write_vdb(path, {{"density", nx, ny, nz, &d, 0.5}});
  std::size_t active = 0;
  const auto back = read_vdb_dense(path, "density", nx, ny, nz, &active);
  EXPECT_EQ(back, d);
  EXPECT_EQ(active, 2u);  // zeros stay inactive background
  std::filesystem::remove(path);
  EXPECT_THROW(read_vdb_dense(path, "density", nx, ny, nz), IoError);
}

}  // namespace nephos::io
