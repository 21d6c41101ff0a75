#include "nephos/weather/masks_io.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>

#include "nephos/io/netcdf_writer.hpp"
#include "nephos/io/png.hpp"

namespace nephos::weather {

void write_masks_netcdf(const std::filesystem::path& path, const WeatherMasks& masks, const WeatherGrid& weather,
                        const MaskParams& params) {
  const LatLonGrid& g = masks.grid;
  io::NetcdfWriter nc(path);
  nc.add_dimension("latitude", static_cast<std::size_t>(g.nlat));
  nc.add_dimension("longitude", static_cast<std::size_t>(g.nlon));
  const int lat = nc.add_variable("latitude", io::NcType::f64, {"latitude"});
  nc.put_attribute(lat, "standard_name", "latitude");
  nc.put_attribute(lat, "long_name", "latitude");
  nc.put_attribute(lat, "units", "degrees_north");
  nc.put_attribute(lat, "axis", "Y");
  const int lon = nc.add_variable("longitude", io::NcType::f64, {"longitude"});
  nc.put_attribute(lon, "standard_name", "longitude");
  nc.put_attribute(lon, "long_name", "longitude");
  nc.put_attribute(lon, "units", "degrees_east");
  nc.put_attribute(lon, "axis", "X");
  const int time = nc.add_variable("time", io::NcType::f64, {});
  nc.put_attribute(time, "standard_name", "time");
  nc.put_attribute(time, "long_name", "valid time of the weather data");
  nc.put_attribute(time, "units", "seconds since 1970-01-01 00:00:00");
  nc.put_attribute(time, "calendar", "proleptic_gregorian");
  const int ref = nc.add_variable("forecast_reference_time", io::NcType::f64, {});
  nc.put_attribute(ref, "standard_name", "forecast_reference_time");
  nc.put_attribute(ref, "units", "seconds since 1970-01-01 00:00:00");
  nc.put_attribute(ref, "calendar", "proleptic_gregorian");

  std::vector<int> vars;
  for (int t = 0; t < cloud_type_count; ++t) {
    const auto type = static_cast<CloudType>(t);
    const auto& tp = params[type];
    const int v = nc.add_variable(name(type), io::NcType::f32, {"latitude", "longitude"});
    nc.put_attribute(v, "long_name", long_name(type));
    nc.put_attribute(v, "units", "1");
    nc.put_attribute(v, "coordinates", "time");
    nc.put_attribute_f32(v, "valid_range", {0.0f, 1.0f});
    nc.put_attribute(
        v, "comment",
        fmt::format("nephos weather mask: cloud fraction of this type gathered over {:g}-{:g} m above mean "
                    "sea level with maximum-random overlap (docs/weather.md)",
                    tp.band_bottom_m, tp.band_top_m));
    vars.push_back(v);
  }
  std::vector<std::pair<int, CloudLayer>> tcc_vars;
  for (CloudLayer l : {CloudLayer::low, CloudLayer::middle, CloudLayer::high}) {
    if (!weather.has_cloud_cover(l)) continue;
    const int v = nc.add_variable(fmt::format("gfs_tcc_{}", name(l)), io::NcType::f32, {"latitude", "longitude"});
    nc.put_attribute(v, "standard_name", "cloud_area_fraction_in_atmosphere_layer");
    nc.put_attribute(v, "long_name",
                     fmt::format("GFS total cloud cover of the {} cloud layer (from the input file)", name(l)));
    nc.put_attribute(v, "units", "1");
    nc.put_attribute(v, "coordinates", "time");
    tcc_vars.emplace_back(v, l);
  }
  const auto& m = weather.metadata();
  nc.put_attribute(io::NetcdfWriter::global, "Conventions", "CF-1.8");
  nc.put_attribute(io::NetcdfWriter::global, "title", "nephos cloud weather masks");
  nc.put_attribute(io::NetcdfWriter::global, "institution", "nephos");
  nc.put_attribute(io::NetcdfWriter::global, "source", m.source);
  nc.put_attribute(io::NetcdfWriter::global, "history", "created by nephos masks");
  nc.put_attribute(io::NetcdfWriter::global, "references",
                   "Table 1 decision procedure (3D fractal cloud renderer for ASSET); cloud fraction after Xu and "
                   "Randall (1996) as in GFS");
  nc.end_definitions();

  std::vector<double> lats(static_cast<std::size_t>(g.nlat)), lons(static_cast<std::size_t>(g.nlon));
  for (int j = 0; j < g.nlat; ++j) lats[static_cast<std::size_t>(j)] = g.lat(j);
  for (int i = 0; i < g.nlon; ++i) lons[static_cast<std::size_t>(i)] = g.lon(i);
  nc.write(lat, lats.data());
  nc.write(lon, lons.data());
  const double tv = static_cast<double>(m.valid_time.unix_s), rv = static_cast<double>(m.reference_time.unix_s);
  nc.write(time, &tv);
  nc.write(ref, &rv);
  for (int t = 0; t < cloud_type_count; ++t)
    nc.write(vars[static_cast<std::size_t>(t)], masks.value[static_cast<std::size_t>(t)].data());
  for (const auto& [v, l] : tcc_vars) nc.write(v, weather.cloud_cover(l).data());
  nc.close();
}

void write_mask_png(const std::filesystem::path& path, const LatLonGrid& grid, const std::vector<float>& mask,
                    int width) {
  const int height = width / 2;
  std::vector<std::uint8_t> px(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    const double lat = 90.0 - (y + 0.5) * 180.0 / height;
    for (int x = 0; x < width; ++x) {
      const double lon = -180.0 + (x + 0.5) * 360.0 / width;
      const float v = sample_bilinear(grid, mask, lat, lon);
      double grey = std::isnan(v) ? 0.0 : std::clamp(static_cast<double>(v), 0.0, 1.0) * 255.0;
      // Graticule every 30 degrees, drawn dim so it never reads as cloud.
      const bool line = std::fmod(std::abs(lat) + 0.5 * 180.0 / height, 30.0) < 180.0 / height ||
                        std::fmod(std::abs(lon) + 0.5 * 360.0 / width, 30.0) < 360.0 / width;
      if (line) grey = std::max(grey, 48.0);
      px[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)] =
          static_cast<std::uint8_t>(std::lround(grey));
    }
  }
  io::write_png(path, width, height, 1, px);
}

}  // namespace nephos::weather
