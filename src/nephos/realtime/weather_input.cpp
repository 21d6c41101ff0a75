#include "nephos/realtime/weather_input.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/weather/sampler.hpp"

namespace nephos::realtime {

const char* name(SpriteCloudType t) {
  static const char* n[] = {"cumulus", "stratocumulus", "altostratus", "cirrus", "low_stratus"};
  return n[static_cast<int>(t)];
}

std::string WeatherCode::text() const {
  return fmt::format("{}{}{}{}", day ? 'd' : 'n', cloudiness, precipitation, type);
}

std::string WeatherCode::describe() const {
  static const char* cl[] = {"clear", "mostly clear", "partly cloudy", "cloudy", "overcast", "thin high clouds", "fog"};
  static const char* pr[] = {"no precipitation", "light precipitation", "showers", "precipitation", "thunderstorms"};
  static const char* ty[] = {"rain", "sleet", "snow"};
  return fmt::format("{}, {}{}{} ({})", cl[cloudiness], pr[precipitation], precipitation > 0 ? ", " : "",
                     precipitation > 0 ? ty[type] : "", day ? "day" : "night");
}

WeatherCode parse_weather_code(const std::string& code) {
  static const std::regex re("([dn])([0-6])([0-4])([0-2])");
  std::smatch m;
  const std::string c = [&] {
    std::string s = code;
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    return s;
  }();
  if (!std::regex_match(c, m, re))
    throw ValueError(
        fmt::format("weather code '{}' is not d|n + cloudiness 0-6 + precipitation 0-4 + type 0-2 (e.g. d210)", code),
        {.key = "code"});
  return {m[1] == "d", m[2].str()[0] - '0', m[3].str()[0] - '0', m[4].str()[0] - '0'};
}

int CloudRecipe::sprite_clouds() const {
  int n = 0;
  for (const auto& l : layers)
    if (l.type == SpriteCloudType::cumulus || l.type == SpriteCloudType::stratocumulus) n += l.count;
  return n;
}

namespace {
// Altitude bands [m above ground] of the thesis's four types plus fog.
constexpr double cu_base = 600, cu_top = 2500, sc_base = 500, sc_top = 2000;
constexpr double as_base = 3000, as_top = 5000, ci_base = 7000, ci_top = 11000;
}  // namespace

CloudRecipe recipe_from_code(const WeatherCode& c) {
  CloudRecipe r;
  r.source = "weather code " + c.text();
  static const int sprites[] = {0, 10, 30, 75, 200};  // thesis section 3.3.1 (d000..d400)
  static const double oktas[] = {0, 2, 4, 6, 8};
  if (c.cloudiness <= 4) {
    const int n = sprites[c.cloudiness];
    r.clustered = c.cloudiness >= 3;
    const bool convective = c.precipitation == 2 || c.precipitation == 4;
    if (n > 0) {
      if (convective) {
        r.layers.push_back({SpriteCloudType::cumulus, n, cu_base, cu_top, oktas[c.cloudiness]});
      } else {  // half cumulus, half stratocumulus; overcast is mostly stratocumulus
        const int cu = c.cloudiness >= 4 ? n / 4 : n / 2;
        r.layers.push_back({SpriteCloudType::cumulus, cu, cu_base, cu_top, oktas[c.cloudiness]});
        r.layers.push_back({SpriteCloudType::stratocumulus, n - cu, sc_base, sc_top, oktas[c.cloudiness]});
      }
    }
    if (c.precipitation == 3 || (c.cloudiness >= 4 && c.precipitation != 2 && c.precipitation != 4))
      r.layers.push_back({SpriteCloudType::altostratus, c.cloudiness >= 4 ? 2 : 1, as_base, as_top, 8});
  } else if (c.cloudiness == 5) {  // thin high clouds
    r.layers.push_back({SpriteCloudType::cirrus, 2, ci_base, ci_top, 4});
  } else {  // fog
    r.layers.push_back({SpriteCloudType::low_stratus, 1, 0, 300, 8});
  }
  return r;
}

CloudRecipe recipe_from_metar(const std::string& metar) {
  CloudRecipe r;
  r.source = "METAR";
  std::istringstream in(metar);
  std::string tok;
  bool any = false;
  std::vector<std::string> unreported;  // groups whose base (or cover) the station did not report
  static const std::regex layer("(FEW|SCT|BKN|OVC)(\\d{3})(CB|TCU|///)?");
  static const std::regex layer_no_base("(FEW|SCT|BKN|OVC|///)(///)(CB|TCU|///)?");
  static const std::regex layer_like("(FEW|SCT|BKN|OVC|VV).*");
  static const std::regex vv("VV(\\d{3}|///)");
  while (in >> tok) {
    std::smatch m;
    // The report's observed part ends here: what follows is a forecast trend (TEMPO, BECMG,
    // NOSIG, PROBnn, INTER) or remarks (RMK), whose cloud groups do not describe the sky now.
    if (tok == "TEMPO" || tok == "BECMG" || tok == "NOSIG" || tok == "RMK" || tok == "INTER" || tok == "PROB30" ||
        tok == "PROB40")
      break;
    if (tok == "CAVOK" || tok == "SKC" || tok == "CLR" || tok == "NSC" || tok == "NCD") {
      any = true;
      continue;
    }
    if (std::regex_match(tok, m, vv)) {  // sky obscured: fog or low stratus from the ground up
      any = true;
      const double top = m[1] == "///" ? 60.0 : std::stoi(m[1]) * 30.48;
      r.layers.push_back({SpriteCloudType::low_stratus, 1, 0, std::max(30.0, top), 8});
      continue;
    }
    if (std::regex_match(tok, m, layer_no_base)) {  // automatic stations: base above the ceilometer or unknown
      unreported.push_back(tok);
      continue;
    }
    if (!std::regex_match(tok, m, layer)) {
      if (std::regex_match(tok, layer_like))
        throw ValueError("cloud group '" + tok +
                             "' is malformed: expected FEW|SCT|BKN|OVC and a 3-digit base in hundreds of feet, "
                             "optionally CB or TCU (e.g. BKN025CB), or VV and 3 digits",
                         {.key = "metar"});
      continue;  // wind, visibility, weather, temperature, pressure groups
    }
    any = true;
    const std::string cover = m[1];
    const double base_m = std::stoi(m[2]) * 100 * metres_per_foot;  // hundreds of feet
    const std::string extra = m[3];
    // Coverage: mid-points of the oktas each group stands for.
    const double oktas = cover == "FEW" ? 1.5 : cover == "SCT" ? 3.5 : cover == "BKN" ? 6 : 8;
    const int sprites = cover == "FEW" ? 10 : cover == "SCT" ? 30 : cover == "BKN" ? 75 : 200;
    if (extra == "CB" || extra == "TCU") {  // convective towers whatever the base
      r.layers.push_back({SpriteCloudType::cumulus, sprites, base_m, base_m + (extra == "CB" ? 9000 : 4000), oktas});
      r.clustered = r.clustered || cover == "BKN" || cover == "OVC";
    } else if (base_m < 2000) {  // low: cumulus when broken up, stratocumulus/stratus when closed
      if (cover == "FEW" || cover == "SCT") {
        r.layers.push_back({SpriteCloudType::cumulus, sprites, base_m, base_m + 1500, oktas});
      } else if (base_m < 300) {
        r.layers.push_back({SpriteCloudType::low_stratus, 1, base_m, base_m + 400, oktas});
      } else {
        r.layers.push_back({SpriteCloudType::stratocumulus, sprites, base_m, base_m + 800, oktas});
        r.clustered = true;
      }
    } else if (base_m < 6000) {  // middle
      r.layers.push_back(
          {SpriteCloudType::altostratus, cover == "OVC" || cover == "BKN" ? 2 : 1, base_m, base_m + 1500, oktas});
    } else {  // high
      r.layers.push_back({SpriteCloudType::cirrus, cover == "FEW" ? 1 : 2, base_m, base_m + 2000, oktas});
    }
  }
  std::string skipped;
  for (const auto& u : unreported) skipped += (skipped.empty() ? "" : " ") + u;
  if (!any)
    throw ValueError("no cloud group (FEW/SCT/BKN/OVC/VV/CAVOK/SKC/CLR/NSC/NCD) with a reported base in METAR '" +
                         metar + "'" + (skipped.empty() ? "" : " (without a base: " + skipped + ")"),
                     {.key = "metar"});
  if (!skipped.empty()) spdlog::warn("METAR: cloud groups without a reported base are left out: {}", skipped);
  return r;
}

CloudRecipe recipe_from_weather(const weather::WeatherMasks& masks, const weather::WeatherGrid& w, double lat_deg,
                                double lon_deg) {
  using weather::CloudType;
  CloudRecipe r;
  r.source = fmt::format("weather at {:.2f}, {:.2f}", lat_deg, lon_deg);
  auto frac = [&](CloudType t) {
    const float v = weather::sample_bilinear(masks.grid, masks[t], lat_deg, lon_deg);
    return std::isnan(v) ? 0.0 : std::clamp(static_cast<double>(v), 0.0, 1.0);
  };
  // A position off a regional grid would otherwise give a clear sky without a word.
  const CloudType all_types[] = {CloudType::low_stratus, CloudType::low_cumulus, CloudType::altostratus,
                                 CloudType::cirrus};
  if (std::all_of(std::begin(all_types), std::end(all_types), [&](CloudType t) {
        return std::isnan(weather::sample_bilinear(masks.grid, masks[t], lat_deg, lon_deg));
      }))
    throw ValueError(fmt::format("no weather at {:.2f}, {:.2f}: outside the weather grid ({}) or missing there",
                                 lat_deg, lon_deg, masks.grid.describe()),
                     {.file = w.metadata().source, .key = "position"});
  const double cu = frac(CloudType::low_cumulus), st = frac(CloudType::low_stratus);
  const double as = frac(CloudType::altostratus), ci = frac(CloudType::cirrus);
  const int n_cu = static_cast<int>(std::lround(200 * cu)), n_st = static_cast<int>(std::lround(200 * st));
  if (n_cu > 0) r.layers.push_back({SpriteCloudType::cumulus, n_cu, cu_base, cu_top, 8 * cu});
  if (n_st > 0) r.layers.push_back({SpriteCloudType::stratocumulus, n_st, sc_base, sc_top, 8 * st});
  if (as > 0.25) r.layers.push_back({SpriteCloudType::altostratus, as > 0.6 ? 2 : 1, as_base, as_top, 8 * as});
  if (ci > 0.25) r.layers.push_back({SpriteCloudType::cirrus, ci > 0.6 ? 2 : 1, ci_base, ci_top, 8 * ci});
  r.clustered = cu + st > 0.45;  // like d300/d400: the sky is more than half covered
  weather::warn_if_winds_missing(w, "the clouds' drift");
  const weather::WeatherSample s = weather::WeatherSampler(w).sample(lat_deg, lon_deg, 2000);
  r.drift_east_m_s = std::isnan(s.u_m_s) ? 0 : s.u_m_s;
  r.drift_north_m_s = std::isnan(s.v_m_s) ? 0 : s.v_m_s;
  return r;
}

WeatherCode code_from_foreca_json(const std::filesystem::path& path, const UtcTime& time) {
  require_input_file(path, "a Foreca JSON file");
  std::ifstream in(path);
  if (!in) throw IoError("cannot open Foreca JSON", {.file = path.string()});
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    throw FormatError(std::string("not valid JSON: ") + e.what(), {.file = path.string()});
  }
  if (!j.is_object() || !j.contains("weather") || !j["weather"].is_array() || j["weather"].empty())
    throw FormatError("expected an object with a non-empty \"weather\" array",
                      {.file = path.string(), .field = "weather"});
  std::string best;
  UtcTime best_time{std::numeric_limits<std::int64_t>::min()};
  for (const auto& e : j["weather"]) {
    if (!e.is_object() || !e.contains("s") || !e["s"].is_string())
      throw FormatError("every entry needs a symbol \"s\"", {.file = path.string(), .field = "weather[].s"});
    UtcTime t{std::numeric_limits<std::int64_t>::min()};
    if (e.contains("t") && e["t"].is_string())
      t = UtcTime::parse(e["t"].get<std::string>());  // hourly
    else if (e.contains("d") && e["d"].is_string())
      t = UtcTime::parse(e["d"].get<std::string>());  // daily
    else
      throw FormatError("entry has neither an hourly \"t\" nor a daily \"d\" time",
                        {.file = path.string(), .field = "weather[]"});
    if (best.empty() || (t <= time && t > best_time) || (best_time > time && t < best_time)) {
      best = e["s"].get<std::string>();
      best_time = t;
    }
  }
  try {
    return parse_weather_code(best);
  } catch (const ValueError& e) {
    throw FormatError(e.message(), {.file = path.string(), .field = "weather[].s"});
  }
}

}  // namespace nephos::realtime
