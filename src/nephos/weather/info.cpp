#include "nephos/weather/info.hpp"

#include <fmt/format.h>

#include "nephos/weather/grib_reader.hpp"

namespace nephos::weather {
namespace {
std::string levels_text(const WeatherGrid& w, Field f) {
  const auto ks = w.levels_of(f);
  if (ks.empty()) return "absent";
  std::string s = fmt::format("{:2d} level{}:", ks.size(), ks.size() == 1 ? "" : "s");
  for (int k : ks) s += fmt::format(" {:g}", w.pressure_levels_pa()[static_cast<std::size_t>(k)] / 100.0);
  s += " hPa";
  if (static_cast<int>(ks.size()) < w.level_count()) {
    s += "  (missing at";
    for (int k = 0; k < w.level_count(); ++k)
      if (!w.has(f, k)) s += fmt::format(" {:g}", w.pressure_levels_pa()[static_cast<std::size_t>(k)] / 100.0);
    s += ")";
  }
  return s;
}
std::string capability(const std::vector<std::string>& missing) {
  return missing.empty() ? "yes" : fmt::format("no: missing {}", fmt::join(missing, ", "));
}
}  // namespace

std::string describe_weather_file(const std::filesystem::path& path) {
  const std::vector<WeatherGrid> times = open_weather_times(path);
  const WeatherGrid& w = times.front();  // described; a file may hold more valid times
  const auto inv = inventory_grib(path);
  const auto& m = w.metadata();
  std::string out;
  out += fmt::format("file           {}\n", path.string());
  out += fmt::format("format         GRIB edition {}, {} message{} holding {} field{} ({} not used by nephos)\n",
                     inv.editions_mask == 6 ? std::string("1+2") : std::to_string(m.grib_edition), inv.messages,
                     inv.messages == 1 ? "" : "s", inv.fields, inv.fields == 1 ? "" : "s", inv.unused_fields);
  out += fmt::format("producer       {}\n", m.producer);
  out += fmt::format("reference time {}\n", m.reference_time.iso());
  out += fmt::format("forecast step  {:g} h\n", m.forecast_step_h);
  out += fmt::format("valid time     {}\n", m.valid_time.iso());
  if (times.size() > 1) {
    std::vector<std::string> later;
    for (std::size_t t = 1; t < times.size(); ++t) later.push_back(times[t].metadata().valid_time.iso());
    out += fmt::format(
        "later times    {} (described: the first; nephos particles reads them all, other commands "
        "the first)\n",
        fmt::join(later, ", "));
  }
  out += fmt::format("grid           {}\n", w.grid().describe());
  out += fmt::format("levels         {} isobaric level{}, {:g}..{:g} hPa\n", w.level_count(),
                     w.level_count() == 1 ? "" : "s", w.pressure_levels_pa().front() / 100.0,
                     w.pressure_levels_pa().back() / 100.0);
  out += "fields on isobaric levels:\n";
  for (const auto& fi : all_fields())
    out +=
        fmt::format("  {:<6} {:<46} [{}] {}\n", fi.grib_short_name, fi.long_name, fi.units, levels_text(w, fi.field));
  out += "cloud cover (tcc) layers:";
  bool any = false;
  for (int l = 0; l < cloud_layer_count; ++l)
    if (w.has_cloud_cover(static_cast<CloudLayer>(l))) {
      out += fmt::format(" {}", name(static_cast<CloudLayer>(l)));
      any = true;
    }
  out += any ? "\n" : " none\n";
  out += fmt::format("orography      {}\n", w.has_orography() ? "present" : "absent (the ground is taken at 0 m)");
  std::vector<std::string> single;
  for (const auto& si : all_surface_fields())
    if (w.has(si.field)) single.push_back(fmt::format("{}@{}", si.grib_short_name, si.grib_level_type));
  out += fmt::format("single-level   {}\n",
                     single.empty() ? std::string("none") : fmt::format("{}", fmt::join(single, " ")));
  out += "capabilities:\n";
  out += fmt::format("  weather masks (nephos masks)            {}\n", capability(missing_for_masks(w)));
  std::vector<std::string> cw;
  if (!w.has(Field::cloud_water)) cw.push_back("clwmr (masks fall back to a humidity ramp)");
  out += fmt::format("  condensate-based cloud fraction         {}\n", capability(cw));
  out += fmt::format("  wind displacement (render)              {}\n", capability(missing_for_winds(w)));
  std::vector<std::string> val;
  for (CloudLayer l : {CloudLayer::low, CloudLayer::middle, CloudLayer::high})
    if (!w.has_cloud_cover(l)) val.push_back(std::string("tcc ") + name(l));
  out += fmt::format("  mask validation against GFS cloud cover {}\n", capability(val));
  return out;
}

}  // namespace nephos::weather
