// GRIB edition 1 and 2 through ecCodes. Only regular latitude-longitude grids are accepted
// (any scanning mode, any longitude convention): each value is placed by the per-point
// coordinates ecCodes computes, so the scanning flags can never be misread. Other grid types
// are refused with their name. A GRIB2 message may hold several fields (NCEP packs u and v
// wind in one message): every field is read (ecCodes' multi-field support), not only a
// message's first.
#include <eccodes.h>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <set>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/weather/grib2_sections.hpp"
#include "nephos/weather/grib_reader.hpp"

namespace nephos::weather {
namespace {

struct FileCloser {
  void operator()(FILE* f) const { std::fclose(f); }
};
struct HandleDeleter {
  void operator()(codes_handle* h) const { codes_handle_delete(h); }
};
using Handle = std::unique_ptr<codes_handle, HandleDeleter>;

std::unique_ptr<FILE, FileCloser> open_file(const std::filesystem::path& path) {
  require_input_file(path, "a GRIB file");
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw IoError("cannot open for reading", {.file = path.string()});
  return std::unique_ptr<FILE, FileCloser>(f);
}

std::string get_string(codes_handle* h, const char* key) {
  char buf[256];
  size_t len = sizeof buf;
  if (codes_get_string(h, key, buf, &len) != 0) return {};
  return std::string(buf);
}
long get_long(codes_handle* h, const char* key, long fallback = 0) {
  long v = fallback;
  return codes_get_long(h, key, &v) == 0 ? v : fallback;
}

// Where each of a message's values goes on the normalised grid (see weather_grid.hpp).
struct Geometry {
  LatLonGrid grid;
  std::vector<std::uint32_t> destination;  // value index in the message -> j*nlon + i
};

// The keys that fix a regular_ll message's point layout; messages that agree on all of them
// share one Geometry, so per-point coordinates are computed once per file, not per message.
std::string geometry_key(codes_handle* h) {
  std::string key;
  for (const char* k :
       {"Ni", "Nj", "iScansNegatively", "jScansPositively", "jPointsAreConsecutive", "alternativeRowScanning"})
    key += std::to_string(get_long(h, k, -1)) + ",";
  for (const char* k : {"latitudeOfFirstGridPointInDegrees", "longitudeOfFirstGridPointInDegrees",
                        "latitudeOfLastGridPointInDegrees", "longitudeOfLastGridPointInDegrees"}) {
    double v = 0;
    codes_get_double(h, k, &v);
    key += fmt::format("{:.6f},", v);
  }
  return key;
}

Geometry compute_geometry(codes_handle* h, size_t n, long ni, long nj, const std::string& file,
                          const std::string& field) {
  std::vector<double> lats(n), lons(n), vals(n);
  if (const int err = codes_grib_get_data(h, lats.data(), lons.data(), vals.data()); err != 0)
    throw FormatError(std::string("cannot decode coordinates: ") + codes_get_error_message(err),
                      {.file = file, .field = field});
  // Latitude rows.
  const auto [lat_min_it, lat_max_it] = std::minmax_element(lats.begin(), lats.end());
  const double lat_min = *lat_min_it, lat_max = *lat_max_it;
  const double dlat = (lat_max - lat_min) / static_cast<double>(nj - 1);
  // Longitude columns: normalise to [0, 360), then start after the largest gap (so a regional
  // grid crossing 0 or 180 stays contiguous; a global grid starts at its smallest longitude).
  std::set<double> ulon;
  for (double l : lons) ulon.insert(std::round(earth::wrap_lon_360(l) * 1e6) / 1e6);
  std::vector<double> sl(ulon.begin(), ulon.end());
  if (static_cast<long>(sl.size()) != ni)
    throw FormatError(fmt::format("expected {} distinct longitudes, found {}", ni, sl.size()),
                      {.file = file, .field = field});
  // Spacing: the smallest step between neighbouring columns (the cyclic step included), so a
  // regional grid's gap across its edges is never taken for the spacing.
  double dlon = 360.0 - (sl.back() - sl.front());
  for (size_t i = 1; i < sl.size(); ++i) dlon = std::min(dlon, sl[i] - sl[i - 1]);
  double lon0 = sl.front();
  if (std::abs(static_cast<double>(ni) * dlon - 360.0) > 1e-3) {  // regional: start after the largest gap
    double best_gap = 360.0 - (sl.back() - sl.front());
    for (size_t i = 1; i < sl.size(); ++i)
      if (sl[i] - sl[i - 1] > best_gap) {
        best_gap = sl[i] - sl[i - 1];
        lon0 = sl[i];
      }
  }
  Geometry g;
  g.grid = {static_cast<int>(nj), static_cast<int>(ni), lat_min, dlat, lon0, dlon};
  g.destination.resize(n);
  std::vector<char> filled(n, 0);
  for (size_t p = 0; p < n; ++p) {
    const double fj = (lats[p] - lat_min) / dlat;
    const double fi = earth::wrap_lon_360(lons[p] - lon0) / dlon;
    const long j = std::lround(fj), i = std::lround(fi) % ni;
    if (std::abs(fj - static_cast<double>(j)) > 1e-3 || std::abs(fi - std::round(fi)) > 1e-3 || j < 0 || j >= nj)
      throw FormatError(fmt::format("point {} at ({}, {}) is not on a regular lat-lon lattice", p, lats[p], lons[p]),
                        {.file = file, .field = field});
    const size_t q = static_cast<size_t>(j * ni + i);
    if (filled[q]) throw FormatError("two values at the same grid point", {.file = file, .field = field});
    filled[q] = 1;
    g.destination[p] = static_cast<std::uint32_t>(q);
  }
  return g;
}

// One message's values on the normalised grid.
struct Decoded {
  LatLonGrid grid;
  std::vector<float> values;    // nlat*nlon, j south->north, i east from lon0; NaN = missing
  std::size_t undecodable = 0;  // points the message does not mark missing whose value is no number
};

Decoded decode_regular_ll(codes_handle* h, const std::string& file, const std::string& field,
                          std::map<std::string, Geometry>& geometry_cache) {
  const std::string grid_type = get_string(h, "gridType");
  if (grid_type != "regular_ll")
    throw FormatError(fmt::format("grid type '{}' is not supported (only regular_ll, a regular latitude-longitude "
                                  "grid); regrid it first, e.g. with cdo remapbil or wgrib2 -new_grid",
                                  grid_type),
                      {.file = file, .field = field});
  size_t n = 0;
  if (codes_get_size(h, "values", &n) != 0 || n == 0)
    throw FormatError("message has no values", {.file = file, .field = field});
  const long ni = get_long(h, "Ni"), nj = get_long(h, "Nj");
  if (ni < 2 || nj < 2 || static_cast<size_t>(ni * nj) != n)
    throw FormatError(fmt::format("Ni x Nj = {} x {} does not match {} values", ni, nj, n),
                      {.file = file, .field = field});
  const std::string key = geometry_key(h);
  auto it = geometry_cache.find(key);
  if (it == geometry_cache.end()) it = geometry_cache.emplace(key, compute_geometry(h, n, ni, nj, file, field)).first;
  const Geometry& geo = it->second;

  std::vector<double> vals(n);
  size_t len = n;
  if (const int err = codes_get_double_array(h, "values", vals.data(), &len); err != 0 || len != n)
    throw FormatError(std::string("cannot decode values: ") + codes_get_error_message(err),
                      {.file = file, .field = field});
  double missing = 9999;
  codes_get_double(h, "missingValue", &missing);
  const bool has_bitmap = get_long(h, "bitmapPresent") != 0;
  Decoded d;
  d.grid = geo.grid;
  d.values.assign(n, std::numeric_limits<float>::quiet_NaN());
  for (size_t p = 0; p < n; ++p)
    if (!(has_bitmap && vals[p] == missing)) {
      d.values[geo.destination[p]] = static_cast<float>(vals[p]);
      d.undecodable += std::isnan(vals[p]);
    }
  return d;
}

// The range a quantity can physically take, in its stored unit (weather_grid.cpp's tables).
struct ValidRange {
  float min, max;
  const char* units;
};
constexpr ValidRange cloud_cover_range{-0.01f, 1.01f, "1"};
constexpr ValidRange orography_range{-1000, 10000, "m"};  // the Dead Sea's shore is at -430 m

// A field's values (scaled to the stored unit) against the range its quantity can take: one
// outside it, or one that decodes to no number, is damaged data (a bit flipped in the packing's
// reference value, for instance), refused with the first such point.
void check_range(const Decoded& d, const ValidRange& r, const std::string& file, const std::string& field) {
  if (d.undecodable > 0)
    throw FormatError(
        fmt::format("{} of its {} values decode to no number (damaged data)", d.undecodable, d.values.size()),
        {.file = file, .field = field});
  std::size_t outside = 0, first = 0;
  for (std::size_t p = 0; p < d.values.size(); ++p) {
    const float v = d.values[p];
    if (!std::isnan(v) && !(v >= r.min && v <= r.max) && outside++ == 0) first = p;
  }
  if (outside == 0) return;
  const auto j = static_cast<int>(first / static_cast<std::size_t>(d.grid.nlon));
  const auto i = static_cast<int>(first % static_cast<std::size_t>(d.grid.nlon));
  throw FormatError(
      fmt::format("{} of its {} values lie outside {:g}..{:g} {}, the range it can take (damaged "
                  "data?), e.g. {:g} at {:g} N {:g} E",
                  outside, d.values.size(), r.min, r.max, r.units, d.values[first], d.grid.lat(j), d.grid.lon(i)),
      {.file = file, .field = field});
}

// ECMWF's models (IFS, ERA5) give geopotential z [m2 s-2] where NCEP's give geopotential
// height gh [gpm]: gh = z / g0, g0 = 9.80665 m s-2 being the standard gravity that defines the
// geopotential metre (WMO). Either makes the levels' heights.
constexpr double standard_gravity_m_s2 = 9.80665;

// Physical conversion from the GRIB unit to the WeatherGrid unit.
float scale_for(const std::string& short_name) {
  if (short_name == "r" || short_name == "tcc") return 0.01f;                   // percent -> fraction
  if (short_name == "z") return static_cast<float>(1 / standard_gravity_m_s2);  // m2 s-2 -> gpm
  return 1.0f;
}

// Cloud condensate is liquid plus ice, as GFS's cloud-fraction diagnostic takes it (Xu &
// Randall 1996 in GFS's radiation). Its parts: NCEP's cloud (clwmr) and ice (icmr) water mixing
// ratios (GFS since FV3, 2019, writes them apart; GFS 2011's clwmr already held both) and
// ECMWF's specific cloud liquid (clwc) and ice (ciwc) water contents (per kg of moist rather
// than dry air: a difference under 2 %). The parts present at a level are summed.
bool condensate_part(const std::string& short_name) {
  return short_name == "clwmr" || short_name == "icmr" || short_name == "clwc" || short_name == "ciwc";
}

std::optional<Field> field_for(const std::string& short_name) {
  for (const auto& fi : all_fields())
    if (short_name == fi.grib_short_name) return fi.field;
  if (short_name == "z") return Field::geopotential_height;
  if (condensate_part(short_name)) return Field::cloud_water;
  return std::nullopt;
}

// ECMWF's low, medium and high cloud cover (lcc, mcc, hcc: fractions 0-1, single-level fields)
// where NCEP gives tcc in % on its cloud layers: both validate the masks (docs/weather.md).
std::optional<CloudLayer> ecmwf_cloud_layer(const std::string& short_name, const std::string& level_type) {
  if (level_type != "surface" && level_type != "entireAtmosphere") return std::nullopt;
  if (short_name == "lcc") return CloudLayer::low;
  if (short_name == "mcc") return CloudLayer::middle;
  if (short_name == "hcc") return CloudLayer::high;
  return std::nullopt;
}

// The ground's height: NCEP's orography (orog, m) or ECMWF's surface geopotential (z at the
// surface, m2 s-2; its geopotential height is the orography to within 0.1 %).
bool orography_field(const std::string& short_name, const std::string& level_type) {
  return level_type == "surface" && (short_name == "orog" || short_name == "z");
}

std::optional<SurfaceField> surface_field_for(const std::string& short_name, const std::string& level_type) {
  for (const auto& si : all_surface_fields())
    if (short_name == si.grib_short_name && level_type == si.grib_level_type) return si.field;
  return std::nullopt;
}

std::optional<CloudLayer> cloud_layer_for(const std::string& level_type) {
  for (int l = 0; l < cloud_layer_count; ++l)
    if (level_type == grib_level_type(static_cast<CloudLayer>(l))) return static_cast<CloudLayer>(l);
  if (level_type == "entireAtmosphere") return CloudLayer::total;
  return std::nullopt;
}

// The instant of a GRIB date (yyyymmdd) and time (hhmm); a FormatError naming the file, the field
// and which time it is (`what`) if they are no calendar date and time of day.
UtcTime time_from(long yyyymmdd, long hhmm, const std::string& file, const std::string& field, const char* what) {
  if (const auto t = UtcTime::try_from_civil(static_cast<int>(yyyymmdd / 10000), static_cast<int>(yyyymmdd / 100 % 100),
                                             static_cast<int>(yyyymmdd % 100), static_cast<int>(hhmm / 100),
                                             static_cast<int>(hhmm % 100)))
    return *t;
  throw FormatError(
      fmt::format("field '{}' has {} {:08d} {:04d}, no calendar date and time", field, what, yyyymmdd, hhmm),
      {.file = file});
}

// Whether `unit` is a unit of time a forecast step may be given in: GRIB1's code table 4 (with
// ECMWF's 13, 15 minutes, and 14, 30 minutes) or GRIB2's code table 4.4. From any other code
// ecCodes 2.28 computes no validity time: it loops forever (GRIB2 255, 16, 41, ...) or divides by
// zero (GRIB1 16, 39, ...), so such a field is refused before it is asked for one.
bool known_time_unit(long edition, long unit) {
  if ((unit >= 0 && unit <= 7) || (unit >= 10 && unit <= 13)) return true;
  return edition == 1 && (unit == 14 || unit == 254);
}

// A field's validity time (ecCodes' validityDate and validityTime), its unit of time first checked.
UtcTime validity_time(codes_handle* h, const std::string& file, const std::string& field) {
  const long edition = get_long(h, "editionNumber"), unit = get_long(h, "indicatorOfUnitOfTimeRange", 1);
  if (!known_time_unit(edition, unit))
    throw FormatError(fmt::format("field '{}' gives its forecast time in units of code {}, which GRIB{}'s code "
                                  "table {} does not define",
                                  field, unit, edition, edition == 1 ? "4" : "4.4"),
                      {.file = file});
  long date = 0, time = 0;
  int err = codes_get_long(h, "validityDate", &date);
  if (err == 0) err = codes_get_long(h, "validityTime", &time);
  if (err != 0)
    throw FormatError(fmt::format("field '{}' has no validity time: {}", field, codes_get_error_message(err)),
                      {.file = file});
  return time_from(date, time, file, field, "the validity time");
}

// The file being read, for assertion_failed().
thread_local const std::filesystem::path* reading = nullptr;

// ecCodes aborts the process when a damaged message breaks one of its internal assertions
// (complex packing whose group counts overrun the values): instead, a FormatError naming the
// file, thrown through ecCodes' frames (it is built with unwind tables) to the caller. The
// buffer ecCodes was decoding into is left allocated (a field's values: 84 KB at 2.5 degrees),
// once per damaged message: the price of an error instead of the end of the process.
void assertion_failed(const char* message) {
  throw FormatError(fmt::format("damaged GRIB data ({})", message),
                    {.file = reading ? reading->string() : std::string()});
}

// ecCodes' own messages (it prints an error it then returns as a code, which the caller reports
// in its one line naming the file and field) at debug level (-v), not on stderr beside that line.
void eccodes_message(const codes_context*, int level, const char* message) {
  spdlog::debug("ecCodes{}: {}", level == GRIB_LOG_ERROR || level == GRIB_LOG_FATAL ? " error" : "", message);
}

// ecCodes keeps the position within a multi-field message per FILE*, in its default context;
// the state is dropped when the file is done with (also on an exception), so that a later file
// opened at the same address starts afresh. Weather files are read from one thread. The scope
// also names the file to assertion_failed().
struct MultiFieldScope {
  FILE* file;
  const std::filesystem::path* previous = reading;
  MultiFieldScope(FILE* f, const std::filesystem::path& path) : file(f) {
    static const bool on = [] {
      codes_grib_multi_support_on(nullptr);
      codes_set_codes_assertion_failed_proc(assertion_failed);
      codes_context_set_logging_proc(codes_context_get_default(), eccodes_message);
      return true;
    }();
    (void)on;
    reading = &path;
  }
  ~MultiFieldScope() {
    codes_grib_multi_support_reset_file(nullptr, file);
    reading = previous;
  }
  MultiFieldScope(const MultiFieldScope&) = delete;
  MultiFieldScope& operator=(const MultiFieldScope&) = delete;
};

// Every GRIB2 message's section structure, checked before ecCodes parses any of them
// (grib2_sections.hpp): each message's bytes as ecCodes' reader frames them (it skips what lies
// between messages). A message it cannot frame (cut short, or stating a length no memory holds)
// is an error too, so that no message after it is parsed unchecked.
void check_sections(const std::filesystem::path& path) {
  auto file = open_file(path);
  for (int k = 1;; ++k) {
    std::size_t size = 0;
    off_t offset = 0;
    int err = 0;
    const std::unique_ptr<unsigned char, decltype(&std::free)> message(
        static_cast<unsigned char*>(wmo_read_grib_from_file_malloc(file.get(), 0, &size, &offset, &err)), &std::free);
    if (err == GRIB_END_OF_FILE) return;
    if (err != 0 || !message)
      throw FormatError(fmt::format("GRIB message {} is corrupt: {}", k, codes_get_error_message(err)),
                        {.file = path.string()});
    if (const std::string e = grib2_section_error(message.get(), size); !e.empty())
      throw FormatError(fmt::format("GRIB message {} (at byte {}) is corrupt: it {}", k, offset, e),
                        {.file = path.string()});
  }
}

// Calls fn(handle, field number) for every field of every message, in file order.
template <class Fn>
void for_each_field(const std::filesystem::path& path, Fn&& fn) {
  check_sections(path);
  auto file = open_file(path);
  const MultiFieldScope multi(file.get(), path);
  int count = 0;
  for (;;) {
    int err = 0;
    Handle h(codes_handle_new_from_file(nullptr, file.get(), PRODUCT_GRIB, &err));
    if (err != 0)
      throw FormatError(fmt::format("GRIB field {} is corrupt: {}", count + 1, codes_get_error_message(err)),
                        {.file = path.string()});
    if (!h) break;
    ++count;
    fn(h.get(), count);
  }
  if (count == 0) throw FormatError("not a GRIB file (no GRIB messages found)", {.file = path.string()});
}

struct PendingLevel {
  Field field;
  double pressure_pa;
  std::vector<float> values;
};

// The fields of one valid time.
struct TimeSlice {
  std::vector<PendingLevel> pending;
  // Duplicates: (field, or a condensate part's own name; pressure in mPa).
  std::set<std::pair<std::string, long long>> seen;
  std::map<CloudLayer, std::vector<float>> cloud;
  std::map<SurfaceField, std::vector<float>> surface;
  WeatherMetadata meta;  // from its first pressure-level field
};

// The grid of one time: its levels are those with geopotential height.
WeatherGrid build(const std::string& file, const LatLonGrid& grid, TimeSlice& slice,
                  const std::vector<float>& orography) {
  std::set<double, std::greater<>> gh_levels, other_levels;
  for (const auto& p : slice.pending)
    (p.field == Field::geopotential_height ? gh_levels : other_levels).insert(p.pressure_pa);
  if (gh_levels.empty())
    throw FormatError(fmt::format("no geopotential height (gh) or geopotential (z) on isobaric levels at {}: "
                                  "cannot place levels in altitude",
                                  slice.meta.valid_time.iso()),
                      {.file = file, .field = "gh"});
  for (double p : other_levels)
    if (!gh_levels.count(p))
      spdlog::warn("{}: level {:g} hPa has no gh at {}; its fields are ignored", file, p / 100,
                   slice.meta.valid_time.iso());

  WeatherGrid w(grid, std::vector<double>(gh_levels.begin(), gh_levels.end()));
  const auto& levels = w.pressure_levels_pa();
  for (auto& p : slice.pending) {
    const auto it = std::find(levels.begin(), levels.end(), p.pressure_pa);
    if (it == levels.end()) continue;
    const int k = static_cast<int>(it - levels.begin());
    const bool add = p.field == Field::cloud_water && w.has(p.field, k);  // a second condensate part
    float* dst = w.level_data(p.field, k);
    if (add)
      for (std::size_t i = 0; i < p.values.size(); ++i) dst[i] += p.values[i];
    else
      std::copy(p.values.begin(), p.values.end(), dst);
  }
  for (auto& [layer, v] : slice.cloud) w.cloud_cover_mut(layer) = std::move(v);
  for (auto& [f, v] : slice.surface) w.surface_mut(f) = std::move(v);
  w.orography_m_mut() = orography;
  WeatherMetadata meta = slice.meta;
  meta.source = file;
  meta.forecast_step_h = static_cast<double>(meta.valid_time.unix_s - meta.reference_time.unix_s) / 3600.0;
  w.metadata() = meta;
  spdlog::debug("{}: read {} level fields on {} at {}", file, slice.pending.size(), grid.describe(),
                meta.valid_time.iso());
  return w;
}

// One pass over a GRIB file, a field at a time (add()), then its grids (grids()). A file may
// hold several valid times (forecast steps or analysis hours concatenated): with `all`, one
// grid per time that has pressure-level fields, in time order; else the time `at`, or the first
// pressure-level field's, alone, the others counted and named once.
class FileScan {
 public:
  FileScan(const std::filesystem::path& path, bool all, std::optional<UtcTime> at)
      : file_(path.string()), all_(all), at_(at), first_(at) {}

  // One field: a pressure-level field into its time's slice, cloud cover, orography or a surface
  // field beside it; anything else is noted as held.
  void add(codes_handle* h) {
    const std::string sn = get_string(h, "shortName");
    const std::string lt = get_string(h, "typeOfLevel");
    const auto field = field_for(sn);
    if (field && (lt == "isobaricInhPa" || lt == "isobaricInPa")) return add_level(h, sn, lt, *field);
    held_.insert(sn + "/" + lt);
    if (sn == "tcc") {
      if (auto layer = cloud_layer_for(lt))
        slices_[valid_time(h, sn, lt)].cloud[*layer] = values(h, sn, "tcc@" + lt, "tcc", cloud_cover_range);
    } else if (const auto layer = ecmwf_cloud_layer(sn, lt)) {  // already a fraction
      slices_[valid_time(h, sn, lt)].cloud[*layer] = values(h, sn, sn, sn, cloud_cover_range);
    } else if (orography_field(sn, lt) && orography_.empty()) {
      orography_ = values(h, sn, sn, sn, orography_range);  // ECMWF's surface geopotential z [m2 s-2] scaled to m
    } else if (const auto sf = surface_field_for(sn, lt)) {
      const SurfaceFieldInfo& si = info(*sf);
      slices_[valid_time(h, sn, lt)].surface[*sf] =
          values(h, sn, sn + "@" + lt, sn, {si.valid_min, si.valid_max, si.units}, si.scale);
    }
  }

  // After the last field: the file must have pressure-level fields (at `at`, if given); the
  // fields of times not read are reported once; then the grids.
  std::vector<WeatherGrid> grids() {
    if (!any_pressure_) {
      std::string list = fmt::format("{}", fmt::join(held_, ", "));
      if (list.size() > 200) list = list.substr(0, 200) + "...";
      throw FormatError(
          fmt::format("no pressure-level fields (gh or z, t, r, w, u, v on isobaric levels); it holds only {}", list),
          {.file = file_});
    }
    if (at_ && (slices_.count(*at_) == 0 || slices_[*at_].pending.empty())) {
      std::vector<std::string> times;  // those with pressure-level fields
      for (const auto& [t, count] : skipped_) times.push_back(t.iso());
      throw FormatError(fmt::format("no pressure-level fields valid at {}; the file's valid times: {}", at_->iso(),
                                    fmt::join(times, ", ")),
                        {.file = file_});
    }
    report_skipped();
    std::vector<WeatherGrid> out;
    for (auto& [t, slice] : slices_)
      if (!slice.pending.empty()) out.push_back(build(file_, *grid_, slice, orography_));
    return out;
  }

 private:
  // A pressure-level field: into its time's slice (without `all`, only the time read).
  void add_level(codes_handle* h, const std::string& sn, const std::string& lt, Field field) {
    const UtcTime vt = valid_time(h, sn, lt);
    any_pressure_ = true;
    if (!first_) first_ = vt;
    if (!all_ && vt != *first_) {
      ++skipped_[vt];
      return;
    }
    TimeSlice& slice = slices_[vt];
    if (slice.pending.empty()) {
      slice.meta.reference_time =
          time_from(get_long(h, "dataDate"), get_long(h, "dataTime"), file_, sn + "@" + lt, "the reference time");
      slice.meta.valid_time = vt;
      slice.meta.grib_edition = static_cast<int>(get_long(h, "editionNumber"));
      slice.meta.producer = get_string(h, "centre");
    }
    const long level = get_long(h, "level");
    const double p = lt == "isobaricInhPa" ? static_cast<double>(level) * 100.0 : static_cast<double>(level);
    const std::string name = fmt::format("{}@{:g}hPa", sn, p / 100);
    const std::string key = condensate_part(sn) ? sn : info(field).grib_short_name;
    if (!slice.seen.insert({key, std::llround(p * 1000)}).second) {
      spdlog::warn("{}: duplicate message for {} at {}; keeping the first", file_, name, vt.iso());
      return;
    }
    const FieldInfo& fi = info(field);
    slice.pending.push_back({field, p, values(h, sn, name, name, {fi.valid_min, fi.valid_max, fi.units})});
  }

  UtcTime valid_time(codes_handle* h, const std::string& sn, const std::string& lt) const {
    return validity_time(h, file_, sn + "@" + lt);
  }

  // The field's values on the file's one grid, in nephos's unit (scale_for, then `scale`),
  // checked against the range they can take.
  std::vector<float> values(codes_handle* h, const std::string& sn, const std::string& name,
                            const std::string& grid_field, const ValidRange& range, float scale = 1.0f) {
    Decoded d = decode_regular_ll(h, file_, name, geometry_cache_);
    check_grid(d.grid, grid_field);
    if (const float s = scale_for(sn) * scale; s != 1.0f)
      for (float& v : d.values) v *= s;
    check_range(d, range, file_, name);
    return std::move(d.values);
  }

  void check_grid(const LatLonGrid& g, const std::string& field) {
    if (!grid_) {
      grid_ = g;
    } else if (!(std::abs(grid_->lat0_deg - g.lat0_deg) < 1e-6 && std::abs(grid_->dlat_deg - g.dlat_deg) < 1e-6 &&
                 std::abs(grid_->lon0_deg - g.lon0_deg) < 1e-6 && std::abs(grid_->dlon_deg - g.dlon_deg) < 1e-6 &&
                 grid_->nlat == g.nlat && grid_->nlon == g.nlon)) {
      throw FormatError(fmt::format("grid {} differs from the first field's grid {}; all fields must share one grid",
                                    g.describe(), grid_->describe()),
                        {.file = file_, .field = field});
    }
  }

  // The fields of the times not read, once. Cloud cover at a time without pressure-level fields
  // (or, without `all`, at another time) has nothing to go with.
  void report_skipped() {
    for (auto& [t, slice] : slices_)
      if (slice.pending.empty() && t != *first_)
        skipped_[t] += static_cast<int>(slice.cloud.size() + slice.surface.size());
    if (skipped_.empty()) return;
    int n = 0;
    std::vector<std::string> times;
    for (const auto& [t, count] : skipped_) n += count, times.push_back(t.iso());
    if (all_)
      spdlog::warn("{}: {} single-level fields at {}, where the file has no pressure-level fields, are not read", file_,
                   n, fmt::join(times, ", "));
    else
      spdlog::log(at_ ? spdlog::level::info : spdlog::level::warn,
                  "{}: fields for {} valid times; reading those of {} ({}) and skipping {} at {} (the commands "
                  "that read weather take --weather-time to choose)",
                  file_, skipped_.size() + 1, first_->iso(), at_ ? "as asked" : "the first pressure-level field's", n,
                  fmt::join(times, ", "));
  }

  std::string file_;
  bool all_;
  std::optional<UtcTime> at_;
  std::optional<LatLonGrid> grid_;
  std::map<UtcTime, TimeSlice> slices_;
  std::optional<UtcTime> first_;    // the time read (without `all`): `at` or the first seen
  bool any_pressure_ = false;       // any pressure-level field at any time
  std::map<UtcTime, int> skipped_;  // without `all`: fields at other valid times
  std::vector<float> orography_;    // time-invariant: the first
  std::map<std::string, Geometry> geometry_cache_;
  std::set<std::string> held_;  // what the file has besides pressure-level fields
};

class GribReader final : public WeatherReader {
 public:
  std::string name() const override { return "grib"; }

  bool can_read(const std::filesystem::path& path) const override {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    char buf[4096];
    const size_t n = std::fread(buf, 1, sizeof buf, f);
    std::fclose(f);
    // A GRIB message starts "GRIB" and carries its edition (1 or 2) in octet 8.
    const std::string_view v(buf, n);
    for (size_t pos = v.find("GRIB"); pos != std::string_view::npos; pos = v.find("GRIB", pos + 1))
      if (pos + 7 < n && (buf[pos + 7] == 1 || buf[pos + 7] == 2)) return true;
    return false;
  }

  WeatherGrid read(const std::filesystem::path& path) const override { return read_times(path, false).front(); }

  WeatherGrid read_at(const std::filesystem::path& path, const UtcTime& valid_time) const override {
    return read_times(path, false, valid_time).front();
  }

  std::vector<WeatherGrid> read_all_times(const std::filesystem::path& path) const override {
    return read_times(path, true);
  }

 private:
  std::vector<WeatherGrid> read_times(const std::filesystem::path& path, bool all,
                                      std::optional<UtcTime> at = std::nullopt) const {
    FileScan scan(path, all, at);
    for_each_field(path, [&](codes_handle* h, int) { scan.add(h); });
    return scan.grids();
  }
};

}  // namespace

GribInventory inventory_grib(const std::filesystem::path& path) {
  GribInventory inv;
  std::map<std::string, int> skipped;
  std::set<std::string> grids;
  std::set<long> offsets;  // the fields of one message share its offset in the file
  for_each_field(path, [&](codes_handle* h, int) {
    ++inv.fields;
    offsets.insert(get_long(h, "offset"));
    inv.editions_mask |= 1 << get_long(h, "editionNumber");
    grids.insert(get_string(h, "gridType"));
    const std::string sn = get_string(h, "shortName"), lt = get_string(h, "typeOfLevel");
    const bool used = (field_for(sn) && (lt == "isobaricInhPa" || lt == "isobaricInPa")) ||
                      (sn == "tcc" && cloud_layer_for(lt)) || ecmwf_cloud_layer(sn, lt) || orography_field(sn, lt) ||
                      surface_field_for(sn, lt);
    if (!used) ++skipped[sn + "/" + lt], ++inv.unused_fields;
  });
  inv.messages = static_cast<int>(offsets.size());
  inv.grid_types.assign(grids.begin(), grids.end());
  for (const auto& [k, n] : skipped) inv.skipped_summary.push_back(fmt::format("{} x{}", k, n));
  return inv;
}

ReaderFactory grib_reader_factory() {
  return [] { return std::make_unique<GribReader>(); };
}

}  // namespace nephos::weather
