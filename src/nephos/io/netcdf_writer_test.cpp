#include "nephos/io/netcdf_writer.hpp"

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

}  // namespace nephos::io
