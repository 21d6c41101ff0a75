#include "nephos/weather/masks_job.hpp"

#include <spdlog/spdlog.h>

#include <string>

#include "nephos/clouds/cloud_model.hpp"
#include "nephos/core/atomic_file.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/weather/masks_io.hpp"

namespace nephos::weather {

void write_masks(const std::filesystem::path& out, const WeatherMasks& masks, const WeatherGrid& weather,
                 const MaskParams& params, int png_width) {
  ensure_directory(out);
  write_masks_netcdf(out / "masks.nc", masks, weather, params);
  for (int t = 0; t < cloud_type_count; ++t) {
    const auto type = static_cast<CloudType>(t);
    write_mask_png(out / (std::string(name(type)) + ".png"), masks.grid, masks[type], png_width);
  }
}

MasksResult run_masks(const MasksRequest& r) {
  require_range(r.png_width, min_png_width, max_png_width, "png_width", "the PNG previews' width [pixels]");
  const MaskParams params = clouds::read_model_config(r.config).masks;
  const WeatherGrid w = load_weather(r.weather, r.seed);
  MasksResult res;
  res.weather = w.metadata(), res.grid = w.grid();
  spdlog::info("valid {} (run {} + {:g} h), {}", res.weather.valid_time.iso(), res.weather.reference_time.iso(),
               res.weather.forecast_step_h, res.grid.describe());
  res.masks = compute_masks(w, params);
  write_masks(r.out, res.masks, w, params, r.png_width);
  for (int t = 0; t < cloud_type_count; ++t)
    res.cover[static_cast<std::size_t>(t)] = area_mean(res.masks.grid, res.masks[static_cast<CloudType>(t)]);
  res.agreement = compare_with_gfs_cloud_cover(res.masks, w);
  return res;
}

}  // namespace nephos::weather
