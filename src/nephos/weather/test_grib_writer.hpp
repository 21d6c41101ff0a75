#pragma once
// Test helper: writes small GRIB1/GRIB2 files with ecCodes, so reader tests use files whose
// every value is known (no golden files from our own code).
#include <filesystem>
#include <functional>
#include <string>

namespace nephos::weather::testing {

struct GribGridSpec {
  int edition = 2;
  int ni = 8, nj = 5;
  double lat_first = 60, dlat = 30;  ///< first row latitude; rows step by dlat towards lat_first + (nj-1)*step
  double lon_first = 0, dlon = 45;
  bool j_scans_positively = false;  ///< false: north to south
  bool i_scans_negatively = false;  ///< true: east to west
};

/// Appends one message with value f(lat, lon) at every point.
void append_grib(const std::filesystem::path& path, const GribGridSpec& spec, const std::string& short_name,
                 const std::string& type_of_level, long level, const std::function<double(double, double)>& f,
                 long data_date = 20110110, long data_time = 1200, long step_h = 120);

/// Appends a 500 hPa message built from an ecCodes sample (e.g. "polar_stereographic_pl_grib2").
void append_grib_from_sample(const std::filesystem::path& path, const std::string& sample,
                             const std::string& short_name);

}  // namespace nephos::weather::testing
