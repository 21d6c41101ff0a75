#pragma once
// `nephos masks` as a typed request and its runner: the weather read, its four cloud masks
// (Table 1) computed, written as masks.nc and a PNG per type, and compared with GFS's own cloud
// cover. The command line and the Python module fill in the request; errors name its fields.
#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "nephos/weather/masks.hpp"
#include "nephos/weather/source.hpp"

namespace nephos::weather {

/// The PNG previews' width lies in [min_png_width, max_png_width] [pixels].
inline constexpr int min_png_width = 16, max_png_width = 16384;

struct MasksRequest {
  WeatherSource weather;  ///< a file (by default the embedded sample), one of its times, or synthetic
  /// A model configuration, as `nephos render --config` reads it (clouds::read_model_config):
  /// its [cloud_fraction] and [masks.*] tables; its other keys are checked, not used. Empty: the
  /// defaults.
  std::filesystem::path config;
  int png_width = 1440;  ///< the PNG previews' width [pixels] (height: half)
  std::filesystem::path out = "out";
  std::uint64_t seed = 1;  ///< of synthetic weather
};

struct MasksResult {
  WeatherMetadata weather;  ///< what was read
  LatLonGrid grid;
  WeatherMasks masks;
  std::array<double, cloud_type_count> cover{};  ///< each mask's area-weighted mean, in [0, 1]
  std::vector<LayerAgreement> agreement;         ///< against GFS's cloud cover, where the file has it
};

/// masks.nc and <type>.png (`png_width` wide) of `masks` in `out` (created if need be), each
/// written atomically.
void write_masks(const std::filesystem::path& out, const WeatherMasks& masks, const WeatherGrid& weather,
                 const MaskParams& params, int png_width);

/// Checks `request` (the PNG width; the configuration's keys and ranges), reads the weather,
/// computes and writes the masks. ValueError naming "png_width"; ConfigError naming the key.
MasksResult run_masks(const MasksRequest& request);

}  // namespace nephos::weather
