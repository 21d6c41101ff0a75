#include "nephos/particles/wrf_reader.hpp"

#include <fmt/format.h>
#include <netcdf.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"

namespace nephos::particles {

namespace {

constexpr double wrf_r_over_cp = 287.0 / 1004.5;  // WRF module_model_constants: r_d / cp
constexpr double wrf_p0_pa = 100000.0;            // reference pressure of theta
constexpr double wrf_theta0_k = 300.0;            // T holds theta - 300 K
constexpr double wrf_g = 9.81;                    // WRF's g [m s-2]

struct VarSpec {
  const char* name;
  std::array<const char*, 4> dims;  // nullptr-terminated when fewer than 4
  const char* units;
};

// What WRF writes (Registry.EM_COMMON) and nephos reads.
const VarSpec specs[] = {
    {"XLAT", {"Time", "south_north", "west_east", nullptr}, "degree_north"},
    {"XLONG", {"Time", "south_north", "west_east", nullptr}, "degree_east"},
    {"PH", {"Time", "bottom_top_stag", "south_north", "west_east"}, "m2 s-2"},
    {"PHB", {"Time", "bottom_top_stag", "south_north", "west_east"}, "m2 s-2"},
    {"P", {"Time", "bottom_top", "south_north", "west_east"}, "Pa"},
    {"PB", {"Time", "bottom_top", "south_north", "west_east"}, "Pa"},
    {"T", {"Time", "bottom_top", "south_north", "west_east"}, "K"},
    {"QCLOUD", {"Time", "bottom_top", "south_north", "west_east"}, "kg kg-1"},
    {"QICE", {"Time", "bottom_top", "south_north", "west_east"}, "kg kg-1"},
    {"U", {"Time", "bottom_top", "south_north", "west_east_stag"}, "m s-1"},
    {"V", {"Time", "bottom_top", "south_north_stag", "west_east"}, "m s-1"},
    {"W", {"Time", "bottom_top_stag", "south_north", "west_east"}, "m s-1"},
};

// A magnitude no field the particle clouds read reaches (geopotential ~1e6 m2 s-2, winds,
// mixing ratios); NetCDF's default fill value, 9.97e36, lies above it.
constexpr float max_wrf_value = 1e30f;

class WrfFile {
 public:
  explicit WrfFile(const std::filesystem::path& path) : path_(path.string()) {
    require_input_file(path, "a WRF output file (wrfout NetCDF)");
    const int st = nc_open(path_.c_str(), NC_NOWRITE, &id_);
    if (st != NC_NOERR) throw IoError(std::string("cannot open as NetCDF: ") + nc_strerror(st), {.file = path_});
    if (const std::string why = truncation(); !why.empty()) {
      nc_close(id_);  // no destructor runs for a constructor that throws
      throw FormatError(why, {.file = path_});
    }
  }
  ~WrfFile() { nc_close(id_); }
  WrfFile(const WrfFile&) = delete;
  WrfFile& operator=(const WrfFile&) = delete;

  std::size_t dim(const char* name) const {
    int d = 0;
    if (nc_inq_dimid(id_, name, &d) != NC_NOERR)
      throw FormatError(std::string("not a wrfout file: dimension '") + name + "' is missing", {.file = path_});
    std::size_t n = 0;
    nc_inq_dimlen(id_, d, &n);
    return n;
  }

  bool has_var(const char* name) const {
    int v = 0;
    return nc_inq_varid(id_, name, &v) == NC_NOERR;
  }

  /// Checks a variable's dimensions (names, order) and units attribute against WRF's.
  void check(const VarSpec& s) const {
    int v = 0;
    if (nc_inq_varid(id_, s.name, &v) != NC_NOERR)
      throw FormatError("variable is missing (needed for the particle clouds)", {.file = path_, .field = s.name});
    int ndims = 0;
    std::array<int, NC_MAX_VAR_DIMS> ids{};
    nc_inq_var(id_, v, nullptr, nullptr, &ndims, ids.data(), nullptr);
    std::string expected, found;
    int want = 0;
    for (const char* d : s.dims)
      if (d) expected += (want++ ? "," : "") + std::string(d);
    for (int k = 0; k < ndims; ++k) {
      std::array<char, NC_MAX_NAME + 1> nm{};
      nc_inq_dimname(id_, ids[static_cast<std::size_t>(k)], nm.data());
      found += (k ? "," : "") + std::string(nm.data());
    }
    if (found != expected)
      throw FormatError("dimensions are (" + found + "), WRF writes (" + expected + ")",
                        {.file = path_, .field = s.name});
    std::size_t len = 0;
    if (nc_inq_attlen(id_, v, "units", &len) == NC_NOERR) {
      std::string u(len, '\0');
      nc_get_att_text(id_, v, "units", u.data());
      while (!u.empty() && (u.back() == '\0' || u.back() == ' ')) u.pop_back();
      if (u != s.units)
        throw FormatError("units are '" + u + "', WRF writes '" + s.units + "'", {.file = path_, .field = s.name});
    }
  }

  /// One time of a variable: all its other dimensions, as float.
  std::vector<float> read(const char* name, std::size_t time, const std::vector<std::size_t>& shape) const {
    int v = 0;
    nc_inq_varid(id_, name, &v);
    std::vector<std::size_t> start(shape.size() + 1, 0), count(shape.size() + 1, 1);
    start[0] = time;
    std::size_t n = 1;
    for (std::size_t k = 0; k < shape.size(); ++k) {
      count[k + 1] = shape[k];
      n *= shape[k];
    }
    std::vector<float> out(n);
    const int st = nc_get_vara_float(id_, v, start.data(), count.data(), out.data());
    if (st != NC_NOERR)
      throw FormatError(std::string("cannot read values: ") + nc_strerror(st), {.file = path_, .field = name});
    // Every value a number that WRF could have written: NaN, infinity and NetCDF's fill value
    // (9.97e36: never written) are damage or missing data, refused before they reach a particle.
    const auto bad = std::find_if(out.begin(), out.end(), [](float x) { return !(std::abs(x) < max_wrf_value); });
    if (bad != out.end()) {
      std::size_t rest = static_cast<std::size_t>(bad - out.begin());
      std::string at;
      for (std::size_t k = shape.size(); k-- > 0;) {
        at = fmt::format("{}{}", rest % shape[k], at.empty() ? "" : ", " + at);
        rest /= shape[k];
      }
      throw FormatError(fmt::format("value {} at time index {}, ({}) is not a number WRF writes (missing or damaged "
                                    "data)",
                                    *bad, time, at),
                        {.file = path_, .field = name});
    }
    return out;
  }

  double global_double(const char* name) const {
    double x = 0;
    if (nc_get_att_double(id_, NC_GLOBAL, name, &x) != NC_NOERR)
      throw FormatError("global attribute is missing (grid spacing in m)", {.file = path_, .key = name});
    return x;
  }

  std::vector<std::string> times(std::size_t nt, std::size_t len) const {
    int v = 0;
    if (nc_inq_varid(id_, "Times", &v) != NC_NOERR)
      throw FormatError("variable is missing", {.file = path_, .field = "Times"});
    std::string buf(nt * len, '\0');
    if (nc_get_var_text(id_, v, buf.data()) != NC_NOERR)
      throw FormatError("cannot read the time strings", {.file = path_, .field = "Times"});
    std::vector<std::string> out;
    for (std::size_t t = 0; t < nt; ++t) out.push_back(buf.substr(t * len, len));
    return out;
  }

  const std::string& path() const { return path_; }

 private:
  // A classic-format file (WRF's usual) cut short reads as zeros past its end, without an error
  // from the library: its variables' values, uncompressed, must fit in the file. Why it does
  // not, or empty.
  std::string truncation() const {
    int format = 0, nvars = 0;
    nc_inq_format(id_, &format);
    if (format != NC_FORMAT_CLASSIC && format != NC_FORMAT_64BIT_OFFSET && format != NC_FORMAT_CDF5) return {};
    nc_inq_nvars(id_, &nvars);
    std::uintmax_t need = 0;
    for (int v = 0; v < nvars; ++v) {
      nc_type type = 0;
      int ndims = 0;
      std::array<int, NC_MAX_VAR_DIMS> dims{};
      nc_inq_var(id_, v, nullptr, &type, &ndims, dims.data(), nullptr);
      std::size_t bytes = 0, len = 0;
      nc_inq_type(id_, type, nullptr, &bytes);
      for (int k = 0; k < ndims; ++k) {
        nc_inq_dimlen(id_, dims[static_cast<std::size_t>(k)], &len);
        bytes *= len;
      }
      need += bytes;
    }
    const std::uintmax_t size = std::filesystem::file_size(path_);
    if (size >= need) return {};
    return fmt::format("truncated: {} bytes, where its variables' values alone take {}", size, need);
  }

  std::string path_;
  int id_ = -1;
};

UtcTime parse_wrf_time(std::string s, const std::string& file) {
  // "2011-01-10_12:00:00" -> ISO 8601
  while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
  if (s.size() != 19 || s[10] != '_')
    throw FormatError("time '" + s + "' is not WRF's YYYY-MM-DD_hh:mm:ss", {.file = file, .field = "Times"});
  s[10] = 'T';
  try {
    return UtcTime::parse(s + "Z");
  } catch (const ValueError& e) {
    throw FormatError("time '" + s + "': " + e.message(), {.file = file, .field = "Times"});
  }
}

}  // namespace

ParticleWeather read_wrf(const std::filesystem::path& path, const std::optional<LatLonRegion>& region,
                         const ColumnParams& params) {
  const WrfFile f(path);
  const std::size_t nt = f.dim("Time"), nx = f.dim("west_east"), ny = f.dim("south_north"), nz = f.dim("bottom_top");
  const std::size_t nzs = f.dim("bottom_top_stag"), nxs = f.dim("west_east_stag"), nys = f.dim("south_north_stag");
  if (nzs != nz + 1 || nxs != nx + 1 || nys != ny + 1)
    throw FormatError("staggered dimensions must be one longer than their mass-point dimensions", {.file = f.path()});
  if (nt == 0) throw FormatError("the file holds no times", {.file = f.path(), .field = "Times"});
  const bool has_ice = f.has_var("QICE");
  if (!has_ice) spdlog::warn("{}: no QICE (a warm-rain microphysics scheme?); cloud ice taken as 0", f.path());
  for (const VarSpec& s : specs)
    if (has_ice || std::string(s.name) != "QICE") f.check(s);
  const double dx = f.global_double("DX"), dy = f.global_double("DY");
  if (!(dx > 0 && std::isfinite(dx)) || !(dy > 0 && std::isfinite(dy)))
    throw FormatError(
        "grid spacing must be positive and finite, got DX=" + std::to_string(dx) + " DY=" + std::to_string(dy),
        {.file = f.path(), .key = "DX"});
  const auto time_strings = f.times(nt, f.dim("DateStrLen"));

  // Region -> smallest index rectangle of the cells inside it (XLAT/XLONG of the first time).
  const auto lat = f.read("XLAT", 0, {ny, nx}), lon = f.read("XLONG", 0, {ny, nx});
  std::size_t i0 = 0, i1 = nx - 1, j0 = 0, j1 = ny - 1;
  if (region) {
    double span = std::fmod(region->lon1_deg - region->lon0_deg + 720.0, 360.0);
    if (span == 0 && region->lon1_deg != region->lon0_deg) span = 360;
    i0 = nx, j0 = ny, i1 = 0, j1 = 0;
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i) {
        const double la = lat[j * nx + i], lo = lon[j * nx + i];
        if (la < region->lat0_deg || la > region->lat1_deg) continue;
        if (std::fmod(lo - region->lon0_deg + 720.0, 360.0) > span) continue;
        i0 = std::min(i0, i), i1 = std::max(i1, i), j0 = std::min(j0, j), j1 = std::max(j1, j);
      }
    if (i0 >= nx || i1 < i0 + 1 || j1 < j0 + 1)
      throw ValueError("fewer than 2 x 2 WRF cells of " + f.path() + " lie in the region", {.key = "region"});
  }

  ParticleWeather pw;
  pw.source = f.path();
  PlanarGrid& g = pw.grid;
  g.cols = static_cast<int>(i1 - i0 + 1);
  g.rows = static_cast<int>(j1 - j0 + 1);
  g.dx_m = dx;
  g.dy_m = dy;
  g.x0_m = -0.5 * (g.cols - 1) * dx;
  g.y0_m = -0.5 * (g.rows - 1) * dy;
  const std::size_t cc = ((j0 + j1) / 2) * nx + (i0 + i1) / 2;
  g.centre_lat_deg = lat[cc];
  g.centre_lon_deg = lon[cc];

  const UtcTime t0 = parse_wrf_time(time_strings[0], f.path());
  const std::size_t plane = g.size();
  for (std::size_t t = 0; t < nt; ++t) {
    const auto ph = f.read("PH", t, {nzs, ny, nx}), phb = f.read("PHB", t, {nzs, ny, nx});
    const auto p = f.read("P", t, {nz, ny, nx}), pb = f.read("PB", t, {nz, ny, nx});
    const auto theta = f.read("T", t, {nz, ny, nx});
    const auto qc = f.read("QCLOUD", t, {nz, ny, nx});
    const auto qi = has_ice ? f.read("QICE", t, {nz, ny, nx}) : std::vector<float>(nz * ny * nx, 0.0f);
    const auto u = f.read("U", t, {nz, ny, nxs}), v = f.read("V", t, {nz, nys, nx}), w = f.read("W", t, {nzs, ny, nx});

    WeatherFrame fr;
    fr.valid_time = parse_wrf_time(time_strings[t], f.path());
    fr.time_s = static_cast<double>(fr.valid_time.unix_s - t0.unix_s);
    fr.allocate(plane, static_cast<int>(nz));
    LayerColumn col;
    col.resize(nz);
    for (std::size_t j = j0; j <= j1; ++j)
      for (std::size_t i = i0; i <= i1; ++i) {
        const std::size_t c = (j - j0) * static_cast<std::size_t>(g.cols) + (i - i0);
        for (std::size_t k = 0; k < nz; ++k) {
          const std::size_t m = (k * ny + j) * nx + i, s0 = m, s1 = ((k + 1) * ny + j) * nx + i;
          col.z_lower_m[k] = (ph[s0] + phb[s0]) / wrf_g;
          col.z_upper_m[k] = (ph[s1] + phb[s1]) / wrf_g;
          const double pressure = static_cast<double>(p[m]) + pb[m];
          const double temperature = (theta[m] + wrf_theta0_k) * std::pow(pressure / wrf_p0_pa, wrf_r_over_cp);
          col.air_density[k] = pressure / (r_dry_air * temperature);
          col.q_liquid[k] = qc[m];
          col.q_ice[k] = qi[m];
          const std::size_t a = k * plane + c;
          fr.wind.z_m[a] = static_cast<float>(0.5 * (col.z_lower_m[k] + col.z_upper_m[k]));
          // De-stagger to the mass point: the mean of the two faces.
          fr.wind.u[a] = 0.5f * (u[(k * ny + j) * nxs + i] + u[(k * ny + j) * nxs + i + 1]);
          fr.wind.v[a] = 0.5f * (v[(k * nys + j) * nx + i] + v[(k * nys + j + 1) * nx + i]);
          fr.wind.w[a] = 0.5f * (w[s0] + w[s1]);
        }
        store(fr.columns, c, column_cloud(col, params));
      }
    pw.frames.push_back(std::move(fr));
  }
  pw.validate();
  return pw;
}

}  // namespace nephos::particles
