#pragma once
// Writing weather masks: a CF-NetCDF file with one variable per cloud type (plus GFS's own
// cloud cover when present, for comparison) and one equirectangular PNG per type.
#include <filesystem>

#include "nephos/weather/masks.hpp"

namespace nephos::weather {

/// masks.nc: variables low_stratus, low_cumulus, altostratus, cirrus on (latitude, longitude),
/// and gfs_tcc_low/middle/high when the weather has them. Written atomically.
void write_masks_netcdf(const std::filesystem::path& path, const WeatherMasks& masks, const WeatherGrid& weather,
                        const MaskParams& params);

/// An equirectangular greyscale PNG (black 0 .. white 1), longitude -180..180 left to right,
/// north up, `width` x width/2 pixels (bilinear from the grid), with a 30-degree graticule.
void write_mask_png(const std::filesystem::path& path, const LatLonGrid& grid, const std::vector<float>& mask,
                    int width = 1440);

}  // namespace nephos::weather
