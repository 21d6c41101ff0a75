#pragma once
// Weather input for the real-time sprite clouds (the billboard-cloud thesis and MSFS 2004): Foreca weather symbol codes (hourly and daily JSON) and METAR cloud groups, decoded into
// a cloud recipe: how many sprite clouds of which type, in which altitude bands, clustered or
// spread, plus the flat layers (altostratus, cirrus, fog/low stratus).
#include <filesystem>
#include <string>
#include <vector>

#include "nephos/core/time.hpp"
#include "nephos/weather/masks.hpp"

namespace nephos::realtime {

/// Aviation's units: the international foot, and the knot as nephos has always converted it
/// (1852 / 3600 = 0.51444... m/s, rounded to six places; kept so that flights stay bit for bit).
inline constexpr double metres_per_foot = 0.3048, metres_per_second_per_knot = 0.514444;

enum class SpriteCloudType { cumulus, stratocumulus, altostratus, cirrus, low_stratus };
const char* name(SpriteCloudType t);

/// A Foreca weather symbol: letter d (day) or n (night) and three digits X Y Z:
///   X cloudiness 0 clear, 1 mostly clear, 2 partly cloudy, 3 cloudy, 4 overcast,
///     5 thin high clouds, 6 fog;
///   Y precipitation 0 none, 1 light/possible, 2 showers, 3 precipitation, 4 thunder;
///   Z precipitation type 0 rain, 1 sleet, 2 snow.
struct WeatherCode {
  bool day = true;
  int cloudiness = 0, precipitation = 0, type = 0;
  std::string text() const;      ///< "d210"
  std::string describe() const;  ///< "partly cloudy, showers, rain (day)"
};
/// Parses "d000".."n642"; ValueError naming the code and what is wrong otherwise.
WeatherCode parse_weather_code(const std::string& code);

/// One layer of cloud the renderer builds.
struct CloudLayerRecipe {
  SpriteCloudType type;
  int count;              ///< sprite clouds (cumulus, stratocumulus) or flat layers (max 2)
  double base_m, top_m;   ///< altitude band [m above ground]
  double coverage_oktas;  ///< 0..8
};

struct CloudRecipe {
  std::vector<CloudLayerRecipe> layers;
  double drift_east_m_s = 0, drift_north_m_s = 0;  ///< wind that moves the clouds (GFS recipes)
  bool clustered = false;  ///< thesis Appendix B.2: d300/d400 cluster; d100/d200 are spread apart (B.3)
  std::string source;      ///< what it was decoded from
  int sprite_clouds() const;
};

/// The thesis mapping (section 3.3.1) extended to every code: cloudiness 0/1/2/3/4 ->
/// 0/10/30/75/200 sprite clouds; 5 -> cirrus; 6 -> fog as low stratus; showers and thunder make
/// the sprites cumulus, continuous precipitation adds an altostratus layer.
CloudRecipe recipe_from_code(const WeatherCode& code);

/// METAR cloud groups: FEW/SCT/BKN/OVC with base in hundreds of feet and optional CB/TCU,
/// VVnnn (obscured sky), CAVOK/SKC/CLR/NSC/NCD (no cloud), up to the first trend or remarks
/// group (TEMPO, BECMG, NOSIG, PROBnn, INTER, RMK). Groups without a reported base (OVC///) are
/// left out with a warning; other groups are ignored. A malformed cloud group, or a report
/// without any usable cloud group, is a ValueError. Rules: docs/realtime.md.
CloudRecipe recipe_from_metar(const std::string& metar);

/// From real weather at the aircraft's position: the four weather masks (cloud fractions) give
/// the types and coverage (low cumulus -> cumulus sprites, low stratus -> stratocumulus sprites,
/// altostratus and cirrus -> flat layers above a fraction of 0.25), sprite counts scaled like
/// the thesis's codes (fraction 1 = 200 clouds); the 2000 m wind gives the drift.
CloudRecipe recipe_from_weather(const weather::WeatherMasks& masks, const weather::WeatherGrid& weather, double lat_deg,
                                double lon_deg);

/// Foreca JSON, hourly ("t" per entry) or daily ("d" per entry): the entry at or before `time`
/// (the first if none is). IoError / FormatError naming the file and the field otherwise.
WeatherCode code_from_foreca_json(const std::filesystem::path& path, const UtcTime& time);

}  // namespace nephos::realtime
