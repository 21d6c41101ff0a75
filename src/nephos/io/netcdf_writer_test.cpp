#include "nephos/io/netcdf_writer.hpp"

#include <algorithm>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>
#include <netcdf.h>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"

namespace nephos::io {

TEST(NetcdfWriter, WritesReadableVariablesAndAttributes) {
  const auto path = test_support::temp_path("nc_test.nc");
  {
    NetcdfWriter w(path);
    w.add_dimension("x", 3);
    const int v = w.add_variable("field", NcType::f32, {"x"});
    w.put_attribute(v, "units", "K");
    w.put_attribute(NetcdfWriter::global, "Conventions", "CF-1.8");
    w.end_definitions();
    const float data[3] = {1.5f, 2.5f, -3.0f};
    w.write(v, data);
    w.close();
  }
  int nc = 0, var = 0;
  ASSERT_EQ(nc_open(path.c_str(), NC_NOWRITE, &nc), NC_NOERR);
  ASSERT_EQ(nc_inq_varid(nc, "field", &var), NC_NOERR);
  float back[3];
  ASSERT_EQ(nc_get_var_float(nc, var, back), NC_NOERR);
  EXPECT_EQ(back[2], -3.0f);
  char units[8] = {};
  ASSERT_EQ(nc_get_att_text(nc, var, "units", units), NC_NOERR);
  EXPECT_STREQ(units, "K");
  nc_close(nc);
  std::filesystem::remove(path);
}

TEST(NetcdfWriter, AbandonedWriterLeavesNoFile) {
  const auto path = test_support::temp_path("nc_abandoned.nc");
  std::filesystem::remove(path);
  {
    NetcdfWriter w(path);
    w.add_dimension("x", 3);
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  for (const auto& e : std::filesystem::directory_iterator(std::filesystem::temp_directory_path()))
    EXPECT_EQ(e.path().filename().string().rfind(path.filename().string(), 0), std::string::npos) << e.path();
}

TEST(NetcdfWriter, ChunksAndCompressesGriddedVariables) {
  // Chunks as asked, each clamped to its dimension; every gridded variable, bytes too, shuffled
  // and deflated, and read back as written. Faults caught: the chunks ignored or not clamped
  // (netCDF-C refuses a chunk longer than a fixed dimension), a type left uncompressed.
  const auto path = test_support::temp_path("nc_chunks.nc");
  std::vector<std::int8_t> flags(300 * 500);
  for (std::size_t i = 0; i < flags.size(); ++i) flags[i] = static_cast<std::int8_t>(i % 7 == 0 ? -1 : 0);
  {
    NetcdfWriter w(path);
    w.add_dimension("y", 300), w.add_dimension("x", 500);
    const int v = w.add_variable("DQF", NcType::i8, {"y", "x"}, {226, 226});
    const int u = w.add_variable("wide", NcType::f32, {"y", "x"}, {1000, 10});
    EXPECT_THROW(w.add_variable("bad", NcType::f32, {"y", "x"}, {226}), ValueError);
    w.end_definitions();
    w.write(v, flags.data());
    const std::vector<float> zeros(flags.size());
    w.write(u, zeros.data());
    w.close();
  }
  int nc = 0, var = 0, storage = 0, shuffle = 0, deflate = 0, level = 0;
  std::size_t chunks[2] = {};
  ASSERT_EQ(nc_open(path.c_str(), NC_NOWRITE, &nc), NC_NOERR);
  ASSERT_EQ(nc_inq_varid(nc, "DQF", &var), NC_NOERR);
  ASSERT_EQ(nc_inq_var_chunking(nc, var, &storage, chunks), NC_NOERR);
  EXPECT_EQ(storage, NC_CHUNKED);
  EXPECT_EQ(chunks[0], 226u);
  EXPECT_EQ(chunks[1], 226u);
  ASSERT_EQ(nc_inq_var_deflate(nc, var, &shuffle, &deflate, &level), NC_NOERR);
  EXPECT_EQ(shuffle, 1);
  EXPECT_EQ(deflate, 1);
  EXPECT_EQ(level, 1);
  std::vector<signed char> back(flags.size());
  ASSERT_EQ(nc_get_var_schar(nc, var, back.data()), NC_NOERR);
  EXPECT_TRUE(std::equal(back.begin(), back.end(), flags.begin()));
  ASSERT_EQ(nc_inq_varid(nc, "wide", &var), NC_NOERR);
  ASSERT_EQ(nc_inq_var_chunking(nc, var, &storage, chunks), NC_NOERR);
  EXPECT_EQ(chunks[0], 300u);
  EXPECT_EQ(chunks[1], 10u);
  nc_close(nc);
  std::filesystem::remove(path);
}

}  // namespace nephos::io
