#include "nephos/particles/particles_io.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "nephos/io/netcdf_writer.hpp"
#include "nephos/io/ply.hpp"

namespace nephos::particles {

void write_particles_ply(const std::filesystem::path& path, const Particles& p, const std::vector<float>& grey,
                         const ParticleWeather& w, const UtcTime& time) {
  io::PlyPoints out;
  out.x = p.x, out.y = p.y, out.z = p.z, out.radius = p.radius_m;
  out.rgba.resize(4 * p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto g = static_cast<std::uint8_t>(std::lround(255 * std::clamp(grey[i], 0.0f, 1.0f)));
    out.rgba[4 * i] = out.rgba[4 * i + 1] = out.rgba[4 * i + 2] = g;
    out.rgba[4 * i + 3] = static_cast<std::uint8_t>(std::lround(255 * std::clamp(p.opacity[i], 0.0f, 1.0f)));
  }
  out.comments = {"nephos particle clouds (particle system from WRF/GFS cloud columns)", fmt::format("time {}", time.iso()),
                  fmt::format("x east, y north, z above mean sea level, metres; plane centred at lat {:.4f} lon {:.4f}",
                              w.grid.centre_lat_deg, w.grid.centre_lon_deg),
                  "red=green=blue: illumination grey value; alpha: opacity; radius: sprite radius [m]",
                  "source " + w.source};
  io::write_ply(path, out);
}

void write_columns_netcdf(const std::filesystem::path& path, const ParticleWeather& w, std::size_t frame) {
  const PlanarGrid& g = w.grid;
  const WeatherFrame& f = w.frames.at(frame);
  io::NetcdfWriter nc(path);
  nc.put_attribute(io::NetcdfWriter::global, "Conventions", "CF-1.8");
  nc.put_attribute(io::NetcdfWriter::global, "title", "nephos particle-system cloud columns (cloud base, top and optical thickness)");
  nc.put_attribute(io::NetcdfWriter::global, "source", w.source);
  nc.put_attribute(io::NetcdfWriter::global, "time", f.valid_time.iso());
  nc.put_attribute(io::NetcdfWriter::global, "plane_centre_latitude", g.centre_lat_deg);
  nc.put_attribute(io::NetcdfWriter::global, "plane_centre_longitude", g.centre_lon_deg);
  nc.add_dimension("y", static_cast<std::size_t>(g.rows));
  nc.add_dimension("x", static_cast<std::size_t>(g.cols));
  const int vx = nc.add_variable("x", io::NcType::f64, {"x"}), vy = nc.add_variable("y", io::NcType::f64, {"y"});
  nc.put_attribute(vx, "units", "m");
  nc.put_attribute(vx, "long_name", "distance east of the plane centre");
  nc.put_attribute(vy, "units", "m");
  nc.put_attribute(vy, "long_name", "distance north of the plane centre");
  const int vbase = nc.add_variable("cloud_base_height", io::NcType::f32, {"y", "x"});
  const int vtop = nc.add_variable("cloud_top_height", io::NcType::f32, {"y", "x"});
  const int vtau = nc.add_variable("cloud_optical_thickness", io::NcType::f32, {"y", "x"});
  nc.put_attribute(vbase, "units", "m");
  nc.put_attribute(vbase, "long_name", "cloud base height above mean sea level");
  nc.put_attribute(vtop, "units", "m");
  nc.put_attribute(vtop, "long_name", "cloud top height above mean sea level");
  nc.put_attribute(vtau, "units", "1");
  nc.put_attribute(vtau, "standard_name", "atmosphere_optical_thickness_due_to_cloud");
  for (int v : {vbase, vtop}) nc.put_attribute_f32(v, "_FillValue", {std::nanf("")});
  nc.end_definitions();
  std::vector<double> xs(static_cast<std::size_t>(g.cols)), ys(static_cast<std::size_t>(g.rows));
  for (int i = 0; i < g.cols; ++i) xs[static_cast<std::size_t>(i)] = g.x(i);
  for (int j = 0; j < g.rows; ++j) ys[static_cast<std::size_t>(j)] = g.y(j);
  nc.write(vx, xs.data());
  nc.write(vy, ys.data());
  nc.write(vbase, f.columns.base_m.data());
  nc.write(vtop, f.columns.top_m.data());
  nc.write(vtau, f.columns.tau.data());
  nc.close();
}

}  // namespace nephos::particles
