#pragma once
// Writing a rendered frame: CF-NetCDF (render.nc), a multi-channel OpenEXR (render.exr) and
// tone-mapped PNG previews per band (vis.png, nir.png, lwir.png). All written atomically.
#include <filesystem>
#include <string>
#include <vector>

#include "nephos/render/renderer.hpp"

namespace nephos::render {

struct FrameMetadata {
  std::string weather_source, sensor, time_iso;
  double sun_subsolar_lat_deg = 0, sun_subsolar_lon_deg = 0;
  std::uint64_t seed = 0;
  int steps = 0, texture_size = 0;
  int rays_per_pixel = 1;
  std::string sub_pixel_sampling = "centre";  ///< "centre" (one ray), "grid" or "stratified"
  std::vector<std::string> types;
};

void write_render_netcdf(const std::filesystem::path& path, const RenderImage& img, const FrameMetadata& meta);
void write_render_exr(const std::filesystem::path& path, const RenderImage& img);
/// One PNG per band. Solar bands: reflectance factor pi L / E_sun with gamma 1/2.2 (white =
/// a perfect Lambertian reflector under an overhead Sun). Thermal bands: brightness temperature
/// mapped 310 K -> black, 190 K -> white (the usual satellite IR convention: cold clouds bright).
void write_render_previews(const std::filesystem::path& dir, const RenderImage& img);

}  // namespace nephos::render
