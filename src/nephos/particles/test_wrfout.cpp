#include "test_wrfout.hpp"

#include <netcdf.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace nephos::particles::test_data {

namespace {
void ok(int st) {
  if (st != NC_NOERR) throw std::runtime_error(std::string("test wrfout: ") + nc_strerror(st));
}
}  // namespace

double pressure_pa(double z_m) { return 1e5 * std::exp(-z_m / 8000.0); }

void write_test_wrfout(const std::filesystem::path& path, const WrfoutSpec& s) {
  int nc = 0;
  ok(nc_create(path.c_str(), NC_CLOBBER, &nc));
  int d_t, d_str, d_x, d_y, d_z, d_xs, d_ys, d_zs;
  ok(nc_def_dim(nc, "Time", NC_UNLIMITED, &d_t));
  ok(nc_def_dim(nc, "DateStrLen", 19, &d_str));
  ok(nc_def_dim(nc, "west_east", static_cast<std::size_t>(s.nx), &d_x));
  ok(nc_def_dim(nc, "south_north", static_cast<std::size_t>(s.ny), &d_y));
  ok(nc_def_dim(nc, "bottom_top", static_cast<std::size_t>(s.nz), &d_z));
  ok(nc_def_dim(nc, "west_east_stag", static_cast<std::size_t>(s.nx + 1), &d_xs));
  ok(nc_def_dim(nc, "south_north_stag", static_cast<std::size_t>(s.ny + 1), &d_ys));
  ok(nc_def_dim(nc, "bottom_top_stag", static_cast<std::size_t>(s.nz + 1), &d_zs));
  if (!s.omit_dx) {
    const float dx = static_cast<float>(s.dx_m), dy = static_cast<float>(s.dy_m);
    ok(nc_put_att_float(nc, NC_GLOBAL, "DX", NC_FLOAT, 1, &dx));
    ok(nc_put_att_float(nc, NC_GLOBAL, "DY", NC_FLOAT, 1, &dy));
  }
  const std::string title = " OUTPUT FROM WRF V3.9.1 MODEL (nephos test file)";
  ok(nc_put_att_text(nc, NC_GLOBAL, "TITLE", title.size(), title.c_str()));
  int v_times = -1;
  const int times_dims[2] = {d_t, d_str};
  if (!s.omit_times) ok(nc_def_var(nc, "Times", NC_CHAR, 2, times_dims, &v_times));

  struct Def {
    const char* name;
    std::vector<int> dims;
    const char* units;
  };
  const std::vector<Def> defs = {
      {"XLAT", {d_t, d_y, d_x}, "degree_north"}, {"XLONG", {d_t, d_y, d_x}, "degree_east"},
      {"PH", {d_t, d_zs, d_y, d_x}, "m2 s-2"},   {"PHB", {d_t, d_zs, d_y, d_x}, "m2 s-2"},
      {"P", {d_t, d_z, d_y, d_x}, "Pa"},         {"PB", {d_t, d_z, d_y, d_x}, "Pa"},
      {"T", {d_t, d_z, d_y, d_x}, "K"},          {"QCLOUD", {d_t, d_z, d_y, d_x}, "kg kg-1"},
      {"QICE", {d_t, d_z, d_y, d_x}, "kg kg-1"}, {"U", {d_t, d_z, d_y, d_xs}, "m s-1"},
      {"V", {d_t, d_z, d_ys, d_x}, "m s-1"},     {"W", {d_t, d_zs, d_y, d_x}, "m s-1"},
  };
  std::vector<int> ids(defs.size(), -1);
  for (std::size_t n = 0; n < defs.size(); ++n) {
    const Def& d = defs[n];
    if (s.omit == d.name) continue;
    std::vector<int> dims = d.dims;
    if (s.swap_dims == d.name) std::swap(dims[1], dims[2]);
    ok(nc_def_var(nc, d.name, NC_FLOAT, static_cast<int>(dims.size()), dims.data(), &ids[n]));
    const std::string units = s.bad_units == d.name ? "g kg-1" : d.units;
    ok(nc_put_att_text(nc, ids[n], "units", units.size(), units.c_str()));
  }
  ok(nc_enddef(nc));

  const auto nx = static_cast<std::size_t>(s.nx), ny = static_cast<std::size_t>(s.ny),
             nz = static_cast<std::size_t>(s.nz);
  for (int t = 0; t < s.nt; ++t) {
    const auto ut = static_cast<std::size_t>(t);
    const std::string when = (s.bad_time ? "2011/01/10 " : "2011-01-10_") + std::to_string(12 + t) + ":00:00";
    const std::size_t ts[2] = {ut, 0}, tc[2] = {1, 19};
    if (v_times >= 0) ok(nc_put_vara_text(nc, v_times, ts, tc, when.c_str()));
    auto put = [&](std::size_t n, std::size_t a, std::size_t b, std::size_t c, auto value) {
      if (ids[n] < 0) return;
      std::vector<float> data;
      for (std::size_t k = 0; k < a; ++k)
        for (std::size_t j = 0; j < b; ++j)
          for (std::size_t i = 0; i < c; ++i) data.push_back(static_cast<float>(value(k, j, i)));
      if (c == 0) return;
      const std::size_t start[4] = {ut, 0, 0, 0};
      std::size_t count3[3] = {1, b, c}, count4[4] = {1, a, b, c};
      const bool swapped = s.swap_dims == defs[n].name;
      if (defs[n].dims.size() == 3) {
        if (swapped) std::swap(count3[1], count3[2]);
        ok(nc_put_vara_float(nc, ids[n], start, count3, data.data()));
      } else {
        if (swapped) std::swap(count4[1], count4[2]);
        ok(nc_put_vara_float(nc, ids[n], start, count4, data.data()));
      }
    };
    auto zmass = [](std::size_t k) {
      return 0.5 * (z_stag_m(static_cast<int>(k)) + z_stag_m(static_cast<int>(k) + 1));
    };
    put(0, 1, ny, nx, [](std::size_t, std::size_t j, std::size_t) { return 40 + 0.03 * static_cast<double>(j); });
    put(1, 1, ny, nx, [](std::size_t, std::size_t, std::size_t i) { return -100 + 0.04 * static_cast<double>(i); });
    put(2, nz + 1, ny, nx, [](std::size_t k, std::size_t, std::size_t) { return wrf_g * 20 * static_cast<double>(k); });
    put(3, nz + 1, ny, nx,
        [](std::size_t k, std::size_t, std::size_t) { return wrf_g * 980 * static_cast<double>(k); });
    put(4, nz, ny, nx, [](std::size_t, std::size_t, std::size_t) { return 500.0; });
    put(5, nz, ny, nx, [&](std::size_t k, std::size_t, std::size_t) { return pressure_pa(zmass(k)) - 500.0; });
    put(6, nz, ny, nx, [](std::size_t, std::size_t, std::size_t) { return 0.0; });
    put(7, nz, ny, nx,
        [&](std::size_t k, std::size_t j, std::size_t i) { return k == 1 && j == 3 && i == 2 ? 1e-3 * (1 + t) : 0.0; });
    put(8, nz, ny, nx,
        [](std::size_t k, std::size_t j, std::size_t i) { return k == 2 && j == 1 && i == 4 ? 2e-4 : 0.0; });
    put(9, nz, ny, nx + 1,
        [&](std::size_t, std::size_t, std::size_t i) { return 10.0 + static_cast<double>(i) + 2 * t; });
    put(10, nz, ny + 1, nx, [](std::size_t, std::size_t j, std::size_t) { return -5 + 0.5 * static_cast<double>(j); });
    put(11, nz + 1, ny, nx, [](std::size_t k, std::size_t, std::size_t) { return 0.1 * static_cast<double>(k); });
  }
  ok(nc_close(nc));
}

}  // namespace nephos::particles::test_data
