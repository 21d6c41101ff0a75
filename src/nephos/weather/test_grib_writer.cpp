#include "test_grib_writer.hpp"

#include <eccodes.h>

#include <stdexcept>
#include <vector>

namespace nephos::weather::testing {
namespace {
void ok(int err, const char* what) {
  if (err != 0) throw std::runtime_error(std::string("ecCodes: ") + what + ": " + codes_get_error_message(err));
}
}  // namespace

void append_grib(const std::filesystem::path& path, const GribGridSpec& s, const std::string& short_name,
                 const std::string& type_of_level, long level, const std::function<double(double, double)>& f,
                 long data_date, long data_time, long step_h) {
  codes_handle* h =
      codes_handle_new_from_samples(nullptr, s.edition == 1 ? "regular_ll_pl_grib1" : "regular_ll_pl_grib2");
  if (!h) throw std::runtime_error("ecCodes sample missing");
  const double lat_last = s.lat_first + (s.j_scans_positively ? 1 : -1) * (s.nj - 1) * s.dlat;
  const double lon_last = s.lon_first + (s.i_scans_negatively ? -1 : 1) * (s.ni - 1) * s.dlon;
  ok(codes_set_long(h, "Ni", s.ni), "Ni");
  ok(codes_set_long(h, "Nj", s.nj), "Nj");
  ok(codes_set_long(h, "jScansPositively", s.j_scans_positively), "jScansPositively");
  ok(codes_set_long(h, "iScansNegatively", s.i_scans_negatively), "iScansNegatively");
  ok(codes_set_double(h, "latitudeOfFirstGridPointInDegrees", s.lat_first), "lat1");
  ok(codes_set_double(h, "longitudeOfFirstGridPointInDegrees", s.lon_first), "lon1");
  ok(codes_set_double(h, "latitudeOfLastGridPointInDegrees", lat_last), "lat2");
  ok(codes_set_double(h, "longitudeOfLastGridPointInDegrees", lon_last), "lon2");
  ok(codes_set_double(h, "iDirectionIncrementInDegrees", s.dlon), "di");
  ok(codes_set_double(h, "jDirectionIncrementInDegrees", s.dlat), "dj");
  size_t len = short_name.size();
  ok(codes_set_string(h, "shortName", short_name.c_str(), &len), "shortName");
  len = type_of_level.size();
  ok(codes_set_string(h, "typeOfLevel", type_of_level.c_str(), &len), "typeOfLevel");
  ok(codes_set_long(h, "level", level), "level");
  ok(codes_set_long(h, "dataDate", data_date), "dataDate");
  ok(codes_set_long(h, "dataTime", data_time), "dataTime");
  ok(codes_set_long(h, "step", step_h), "step");
  std::vector<double> values;
  for (int r = 0; r < s.nj; ++r) {
    const double lat = s.lat_first + (s.j_scans_positively ? 1 : -1) * r * s.dlat;
    for (int c = 0; c < s.ni; ++c) values.push_back(f(lat, s.lon_first + (s.i_scans_negatively ? -1 : 1) * c * s.dlon));
  }
  ok(codes_set_long(h, "bitsPerValue", 24), "bitsPerValue");
  ok(codes_set_double_array(h, "values", values.data(), values.size()), "values");
  ok(codes_write_message(h, path.c_str(), "a"), "write");
  codes_handle_delete(h);
}

void append_grib_from_sample(const std::filesystem::path& path, const std::string& sample,
                             const std::string& short_name) {
  codes_handle* h = codes_handle_new_from_samples(nullptr, sample.c_str());
  if (!h) throw std::runtime_error("ecCodes sample missing: " + sample);
  size_t len = short_name.size();
  ok(codes_set_string(h, "shortName", short_name.c_str(), &len), "shortName");
  const std::string level_type = "isobaricInhPa";
  len = level_type.size();
  ok(codes_set_string(h, "typeOfLevel", level_type.c_str(), &len), "typeOfLevel");
  ok(codes_set_long(h, "level", 500), "level");
  ok(codes_write_message(h, path.c_str(), "a"), "write");
  codes_handle_delete(h);
}

}  // namespace nephos::weather::testing
