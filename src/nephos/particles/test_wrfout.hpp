#pragma once
// Writes small wrfout files for the tests, with WRF's variable names, dimensions, staggering and
// units exactly (ARW User's Guide ch. 5), and fields simple enough to check by hand:
//   heights of the staggered levels z_k = 1000 k m (PH = g 20 k, PHB = g 980 k, g = 9.81)
//   PB = 1e5 exp(-z / 8000) - 500 Pa at mass levels, P = 500 Pa; T = 0 (theta = 300 K)
//   QCLOUD = 1e-3 (times (1 + t)) in layer 1 of column (i=2, j=3); QICE = 2e-4 in layer 2 of (4, 1)
//   U = 10 + i_stag + 2 t, V = -5 + 0.5 j_stag, W = 0.1 k_stag [m/s]
//   XLAT = 40 + 0.03 j, XLONG = -100 + 0.04 i; Times hourly from 2011-01-10_12:00:00
#include <filesystem>
#include <string>

namespace nephos::particles::test_data {

struct WrfoutSpec {
  int nx = 6, ny = 5, nz = 4, nt = 2;
  double dx_m = 3000, dy_m = 3000;
  std::string omit;       ///< a variable to leave out
  std::string bad_units;  ///< a variable written with wrong units
  std::string swap_dims;  ///< a variable written with its two middle dimensions swapped
  bool omit_dx = false;
  bool omit_times = false;  ///< no Times variable
  bool bad_time = false;    ///< Times written as "2011/01/10 12:00:00"
};

inline constexpr double wrf_g = 9.81;
inline double z_stag_m(int k) { return 1000.0 * k; }
double pressure_pa(double z_m);  ///< P + PB at height z

void write_test_wrfout(const std::filesystem::path& path, const WrfoutSpec& spec = {});

}  // namespace nephos::particles::test_data
