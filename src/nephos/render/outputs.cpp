#include "nephos/render/outputs.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfThreading.h>

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <limits>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/io/netcdf_writer.hpp"
#include "nephos/io/png.hpp"
#include "nephos/optics/optics.hpp"

namespace nephos::render {

namespace {
// render.nc and render.exr hold every output: an image rendered without some (an L1b job's) is refused.
void require_every_output(const RenderImage& img, const std::filesystem::path& path) {
  const auto npx = static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height);
  bool whole = img.cloud_fraction.size() == npx;
  for (std::size_t b = 0; b < img.bands.size(); ++b)
    whole = whole && (!optics::band(img.bands[b]).thermal || img.brightness_temperature[b].size() == npx);
  if (!whole)
    throw ValueError("the image lacks its cloud fields or brightness temperatures (rendered for an L1b file)",
                     {.file = path.string()});
}
}  // namespace

void write_render_netcdf(const std::filesystem::path& path, const RenderImage& img, const FrameMetadata& meta) {
  require_every_output(img, path);
  io::NetcdfWriter nc(path);
  nc.add_dimension("y", static_cast<std::size_t>(img.height));
  nc.add_dimension("x", static_cast<std::size_t>(img.width));
  const std::vector<std::string> dims{"y", "x"};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  auto float_var = [&](const std::string& name, const std::string& units, const std::string& long_name,
                       const std::string& standard_name) {
    const int v = nc.add_variable(name, io::NcType::f32, dims);
    nc.put_attribute_f32(v, "_FillValue", {nan});
    nc.put_attribute(v, "units", units);
    nc.put_attribute(v, "long_name", long_name);
    if (!standard_name.empty()) nc.put_attribute(v, "standard_name", standard_name);
    if (name != "latitude" && name != "longitude") nc.put_attribute(v, "coordinates", "latitude longitude");
    return v;
  };
  const int lat =
      float_var("latitude", "degrees_north", "latitude of the nearest cloud surface or Earth point", "latitude");
  const int lon =
      float_var("longitude", "degrees_east", "longitude of the nearest cloud surface or Earth point", "longitude");
  std::vector<int> rad, bt;
  for (std::size_t b = 0; b < img.bands.size(); ++b) {
    const optics::Band& band = optics::band(img.bands[b]);
    rad.push_back(float_var("radiance_" + band.name, "W m-2 sr-1 um-1",
                            fmt::format("band-mean spectral radiance at the sensor, {} ({:g}-{:g} um), no atmosphere",
                                        band.description, band.lo_um, band.hi_um),
                            ""));
    bt.push_back(band.thermal ? float_var("brightness_temperature_" + band.name, "K",
                                          "brightness temperature of the band radiance (inverse band-mean Planck)",
                                          "brightness_temperature")
                              : -1);
  }
  const int top = float_var("cloud_top_altitude", "m", "altitude above mean sea level of the nearest cloud surface",
                            "cloud_top_altitude");
  const int tau = float_var("cloud_optical_depth", "1", "visible (0.64 um) cloud optical depth along the line of sight",
                            "atmosphere_optical_thickness_due_to_cloud");
  const int fraction = float_var("cloud_fraction", "1", "share of the pixel's rays (sub-pixel samples) that meet cloud",
                                 "cloud_area_fraction");
  const int type = nc.add_variable("cloud_type", io::NcType::i8, dims);
  nc.put_attribute_i8(type, "_FillValue", {-1});
  nc.put_attribute(type, "long_name", "type of the nearest cloud surface");
  nc.put_attribute_i8(type, "flag_values", {0, 1, 2, 3});
  nc.put_attribute(type, "flag_meanings", "low_stratus low_cumulus altostratus cirrus");
  nc.put_attribute(type, "coordinates", "latitude longitude");
  nc.put_attribute(io::NetcdfWriter::global, "Conventions", "CF-1.8");
  nc.put_attribute(io::NetcdfWriter::global, "title", "nephos 3D fractal cloud render");
  nc.put_attribute(io::NetcdfWriter::global, "source", meta.weather_source);
  nc.put_attribute(io::NetcdfWriter::global, "sensor", meta.sensor);
  nc.put_attribute(io::NetcdfWriter::global, "time", meta.time_iso);
  nc.put_attribute(io::NetcdfWriter::global, "subsolar_point_deg",
                   std::vector<double>{meta.sun_subsolar_lat_deg, meta.sun_subsolar_lon_deg});
  nc.put_attribute_u64(io::NetcdfWriter::global, "seed", meta.seed);  // exact: a double rounds beyond 2^53
  nc.put_attribute(io::NetcdfWriter::global, "ray_marching_steps", static_cast<double>(meta.steps));
  nc.put_attribute(io::NetcdfWriter::global, "texture_size", static_cast<double>(meta.texture_size));
  nc.put_attribute(io::NetcdfWriter::global, "rays_per_pixel", static_cast<double>(meta.rays_per_pixel));
  nc.put_attribute(io::NetcdfWriter::global, "sub_pixel_sampling", meta.sub_pixel_sampling);
  std::string types;
  for (const auto& t : meta.types) types += (types.empty() ? "" : " ") + t;
  nc.put_attribute(io::NetcdfWriter::global, "cloud_types", types);
  nc.end_definitions();
  nc.write(lat, img.latitude_deg.data());
  nc.write(lon, img.longitude_deg.data());
  for (std::size_t b = 0; b < img.bands.size(); ++b) {
    nc.write(rad[b], img.radiance[b].data());
    if (bt[b] >= 0) nc.write(bt[b], img.brightness_temperature[b].data());
  }
  nc.write(top, img.cloud_top_altitude_m.data());
  nc.write(tau, img.cloud_optical_depth.data());
  nc.write(fraction, img.cloud_fraction.data());
  nc.write(type, img.cloud_type.data());
  nc.close();
}

void write_render_exr(const std::filesystem::path& path, const RenderImage& img) {
  require_every_output(img, path);
  AtomicFile out(path);
  try {
    Imf::Header header(img.width, img.height);
    Imf::FrameBuffer fb;
    const std::size_t xs = sizeof(float), ys = xs * static_cast<std::size_t>(img.width);
    auto add = [&](const std::string& name, const std::vector<float>& data) {
      header.channels().insert(name, Imf::Channel(Imf::FLOAT));
      fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(data.data())), xs, ys));
    };
    for (std::size_t b = 0; b < img.bands.size(); ++b) {
      add("radiance." + img.bands[b], img.radiance[b]);
      if (!img.brightness_temperature[b].empty())
        add("brightness_temperature." + img.bands[b], img.brightness_temperature[b]);
    }
    add("cloud_top_altitude", img.cloud_top_altitude_m);
    add("cloud_optical_depth", img.cloud_optical_depth);
    add("cloud_fraction", img.cloud_fraction);
    // Compressed by OpenEXR's own thread pool, one thread per OpenMP thread: the ZIP blocks of
    // 16 scan lines are independent, and the file's bytes do not depend on the thread count.
    if (Imf::globalThreadCount() < thread_count()) Imf::setGlobalThreadCount(thread_count());
    Imf::OutputFile file(out.temp_path().c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(img.height);
  } catch (const std::exception& e) {
    throw IoError(std::string("OpenEXR: ") + e.what(), {.file = path.string()});
  }
  out.commit();
}

void write_render_previews(const std::filesystem::path& dir, const RenderImage& img) {
  const std::size_t npx = static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height);
  for (std::size_t b = 0; b < img.bands.size(); ++b) {
    const optics::Band& band = optics::band(img.bands[b]);
    std::vector<std::uint8_t> px(npx);
    for (std::size_t i = 0; i < npx; ++i) {
      double v;
      if (band.thermal) {
        v = (310.0 - img.brightness_temperature[b][i]) / 120.0;
      } else {
        v = std::pow(std::max(0.0, M_PI * img.radiance[b][i] / band.solar_irradiance), 1 / 2.2);
      }
      px[i] = static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(v, 0.0, 1.0)));
    }
    io::write_png(dir / (band.name + ".png"), img.width, img.height, 1, px);
  }
}

}  // namespace nephos::render
