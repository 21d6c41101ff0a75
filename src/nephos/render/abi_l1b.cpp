#include "nephos/render/abi_l1b.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <future>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <omp.h>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/io/netcdf_writer.hpp"

namespace nephos::render {

namespace {
constexpr double c1 = 1.191042e-5;  // 2 h c^2 [mW m^-2 sr^-1 cm^4] (CODATA)
constexpr double c2 = 1.4387752;    // h c / k [K cm]
constexpr std::int16_t rad_fill = -1;
constexpr double counts = 32766;  // Rad's packed range 0..32766
// Rad's and DQF's chunks [pixels], as NOAA's L1b files store them: a reader (satpy's dask
// arrays) decompresses 100 KB to read a pixel, not a band.
constexpr std::size_t abi_chunk = 226;

// Mode-6 scan time of a sector [s]: full disc 10 min, CONUS 5 min, mesoscale 1 min.
double scan_seconds(char abbreviation) { return abbreviation == 'F' ? 600 : abbreviation == 'C' ? 300 : 60; }

// "sYYYYJJJHHMMSSt" of ABI file names: year, day of year, time, tenths of a second.
std::string abi_time(const UtcTime& t) {
  const std::string iso = t.iso();  // YYYY-MM-DDTHH:MM:SSZ
  const int year = std::stoi(iso.substr(0, 4));
  const auto day = (t.unix_s - UtcTime::from_civil(year, 1, 1).unix_s) / 86400 + 1;
  return fmt::format("{:04d}{:03d}{}{}{}0", year, day, iso.substr(11, 2), iso.substr(14, 2), iso.substr(17, 2));
}

// ISO time as ABI's global attributes write it, with tenths: 2011-01-15T12:00:00.0Z.
std::string abi_iso(const UtcTime& t) {
  std::string iso = t.iso();
  return iso.substr(0, 19) + ".0Z";
}

// Scalar variables of a file, defined first and written after the definitions end.
struct Scalars {
  std::vector<std::pair<int, double>> f32, f64;
  void add(io::NetcdfWriter& nc, const std::string& name, double value, const std::string& units,
           const std::string& long_name, bool dbl = false) {
    const int v = nc.add_variable(name, dbl ? io::NcType::f64 : io::NcType::f32, {});
    if (!units.empty()) nc.put_attribute(v, "units", units);
    nc.put_attribute(v, "long_name", long_name);
    (dbl ? f64 : f32).emplace_back(v, value);
  }
  void write(io::NetcdfWriter& nc) const {
    for (const auto& [v, x] : f32) {
      const float f = static_cast<float>(x);
      nc.write(v, &f);
    }
    for (const auto& [v, x] : f64) nc.write(v, &x);
  }
};

// The fixed grid's coordinate: int16 pixel indices scaled to scan angles [rad].
int coordinate(io::NetcdfWriter& nc, const std::string& name, double first, double step, const std::string& axis) {
  const int v = nc.add_variable(name, io::NcType::i16, {name});
  nc.put_attribute(v, "scale_factor", step);
  nc.put_attribute(v, "add_offset", first);
  nc.put_attribute(v, "units", "rad");
  nc.put_attribute(v, "axis", axis);
  nc.put_attribute(v, "standard_name", name == "x" ? "projection_x_coordinate" : "projection_y_coordinate");
  nc.put_attribute(v, "long_name",
                   name == "x" ? "GOES fixed grid projection x-coordinate" : "GOES fixed grid projection y-coordinate");
  return v;
}

// Where a file's planck_fk1, fk2, bc1 and bc2 come from, for its readers (a global attribute).
std::string planck_source_text(const std::string& platform, const optics::Band& b) {
  switch (planck_source(platform, b)) {
    case PlanckSource::published:
      return fmt::format("published: {}'s L1b files", platform);
    case PlanckSource::central_wavenumber:
      return fmt::format("fk1, fk2 at {}'s measured central wavenumber of the band (CRTM); bc1, bc2 G16's", platform);
    case PlanckSource::nephos_band:
      break;
  }
  return "nephos's band, flat between its nominal edges";
}

// A band's Rad as ABI packs it, its quality flags, and what PUG Vol. 3's L1b files report of the
// valid pixels (DQF 0): their count, the saturated (above Rad's range) and undersaturated (below
// 0) among them, the Earth pixels with no value, and the minimum, maximum, mean and standard
// deviation (of the population) of Rad as stored, counts times scale_factor, so that a reader
// who recomputes them from the file agrees. Integer sums: the same for any thread count.
struct PackedBand {
  PlanckCoefficients pc;  // thermal bands' calibration
  double scale = 1;       // Rad's scale_factor [Rad's units per count]
  std::vector<std::int16_t> rad;
  std::vector<std::int8_t> dqf;
  std::int32_t valid = 0, missing = 0, saturated = 0, undersaturated = 0;
  double min = 0, max = 0, mean = 0, std_dev = 0;  // [Rad's units]; 0 with no valid pixel
};

PackedBand pack_band(const L1bBands& img, std::size_t bi, const std::string& platform,
                     const std::vector<std::uint8_t>& on_earth) {
  const optics::Band& band = optics::band(img.bands[bi]);
  const float* radiance = img.radiance[bi];
  const std::size_t n = on_earth.size();
  PackedBand p;
  // Rad: reflective bands nephos's radiance [W m^-2 sr^-1 um^-1] up to a reflectance factor of
  // 1.5; thermal bands [mW m^-2 sr^-1 (cm^-1)^-1] up to 350 K.
  const PlanckCoefficients pc = p.pc = abi_planck_coefficients(platform, band);
  const double scale = p.scale = (band.thermal ? pc.radiance(350) : 1.5 * band.solar_irradiance / M_PI) / counts;
  p.rad.resize(n), p.dqf.resize(n);
  const auto ni = static_cast<std::ptrdiff_t>(n);
  std::int64_t valid = 0, missing = 0, saturated = 0, undersaturated = 0, sum = 0;
  int lo = 32767, hi = -1;
  // A thermal band's brightness temperatures: the image's, or found a piece at a time from its
  // radiances where it holds none (an L1b job's render: brightness_temperatures()).
  const float* image_bt = img.brightness_temperature[bi];
  const bool find_bt = band.thermal && image_bt == nullptr;
  constexpr std::size_t piece = 4096;  // pixels
  const auto pieces = static_cast<std::ptrdiff_t>((n + piece - 1) / piece);
  // Dealt out as the threads free up: one of them may share its core with a file being written.
#pragma omp parallel for schedule(dynamic, 8) reduction(+ : valid, missing, saturated, undersaturated, sum) \
    reduction(min : lo) reduction(max : hi)
  for (std::ptrdiff_t pc0 = 0; pc0 < pieces; ++pc0) {  // each pixel on its own: the same bits for any thread count
    const std::size_t i0 = static_cast<std::size_t>(pc0) * piece, i1 = std::min(n, i0 + piece);
    std::array<float, piece> found;
    if (find_bt) brightness_temperatures(band, radiance + i0, i1 - i0, found.data());
    const float* bt = find_bt ? found.data() : band.thermal ? image_bt + i0 : nullptr;  // from i0
    for (std::size_t i = i0; i < i1; ++i) {
      const double l = !on_earth[i] ? NAN : band.thermal ? pc.radiance(bt[i - i0]) : radiance[i];
      const bool ok = std::isfinite(l);
      const double q = l / scale;
      const int c = ok ? static_cast<int>(std::clamp(std::round(q), 0.0, counts)) : rad_fill;
      p.rad[i] = static_cast<std::int16_t>(c);
      p.dqf[i] = ok ? 0 : -1;
      missing += on_earth[i] && !ok;
      if (!ok) continue;
      valid += 1, saturated += q > counts, undersaturated += q < 0;
      sum += c;
      lo = std::min(lo, c), hi = std::max(hi, c);
    }
  }
  p.valid = static_cast<std::int32_t>(valid), p.missing = static_cast<std::int32_t>(missing);
  p.saturated = static_cast<std::int32_t>(saturated), p.undersaturated = static_cast<std::int32_t>(undersaturated);
  if (valid > 0) {
    // The deviations' squares from the integer nearest the mean, summed exactly; then the
    // variance about the mean itself (no cancellation: the two means differ by at most 0.5).
    const double mean_counts = static_cast<double>(sum) / static_cast<double>(valid);
    const auto centre = static_cast<std::int64_t>(std::llround(mean_counts));
    std::uint64_t dev2 = 0;  // at most 32766^2 per pixel: 2^64 holds 1.7e10 pixels
#pragma omp parallel for schedule(dynamic, 65536) reduction(+ : dev2)
    for (std::ptrdiff_t k = 0; k < ni; ++k) {
      const auto i = static_cast<std::size_t>(k);
      const std::int64_t d = p.dqf[i] == 0 ? p.rad[i] - centre : 0;
      dev2 += static_cast<std::uint64_t>(d * d);
    }
    const double offset = mean_counts - static_cast<double>(centre);
    const double variance = std::max(0.0, static_cast<double>(dev2) / static_cast<double>(valid) - offset * offset);
    p.min = lo * scale, p.max = hi * scale, p.mean = mean_counts * scale, p.std_dev = std::sqrt(variance) * scale;
  }
  return p;
}

// PUG Vol. 3's counts and statistics of the valid pixels, the image's centre and bounds in scan
// angle, and its geodetic extent, as variables of the file; returns the counts' variables and
// values (int32) and the bounds' (float32 pairs), written after the definitions end.
struct SummaryVariables {
  std::vector<std::pair<int, std::int32_t>> counts;
  std::vector<std::pair<int, std::array<float, 2>>> bounds;
};

SummaryVariables add_summary(io::NetcdfWriter& nc, Scalars& sc, const PackedBand& p, const SectorCover& cover,
                             const FixedGridView& view, const std::string& units) {
  SummaryVariables out;
  auto count = [&](const std::string& name, std::int32_t value, const std::string& long_name) {
    const int v = nc.add_variable(name, io::NcType::i32, {});
    nc.put_attribute(v, "long_name", long_name);
    nc.put_attribute(v, "units", "count");
    out.counts.emplace_back(v, value);
  };
  count("valid_pixel_count", p.valid, "number of good and conditionally usable pixels");
  count("missing_pixel_count", p.missing, "number of missing pixels");
  count("saturated_pixel_count", p.saturated, "number of saturated pixels");
  count("undersaturated_pixel_count", p.undersaturated, "number of undersaturated pixels");
  sc.add(nc, "min_radiance_value_of_valid_pixels", p.min, units, "minimum radiance value of pixels");
  sc.add(nc, "max_radiance_value_of_valid_pixels", p.max, units, "maximum radiance value of pixels");
  sc.add(nc, "mean_radiance_value_of_valid_pixels", p.mean, units, "mean radiance value of pixels");
  sc.add(nc, "std_dev_radiance_value_of_valid_pixels", p.std_dev, units,
         "standard deviation of radiance values of pixels");
  sc.add(nc, "percent_uncorrectable_L0_errors", 0.0, "percent", "percent data lost due to uncorrectable L0 errors");
  const FixedGridSector& sec = view.sector;
  const double x1 = sec.x(sec.nx - 1), y1 = sec.y(sec.ny - 1);
  const double xc = 0.5 * (sec.x0_rad + x1), yc = 0.5 * (sec.y0_rad + y1);  // the image's centre [rad]
  sc.add(nc, "x_image", xc, "rad", "GOES-R fixed grid projection x-coordinate center of image");
  sc.add(nc, "y_image", yc, "rad", "GOES-R fixed grid projection y-coordinate center of image");
  auto bounds = [&](const std::string& name, double a, double b, const std::string& long_name) {
    const int v = nc.add_variable(name, io::NcType::f32, {"number_of_image_bounds"});
    nc.put_attribute(v, "long_name", long_name);
    nc.put_attribute(v, "units", "rad");
    out.bounds.emplace_back(v, std::array<float, 2>{static_cast<float>(a), static_cast<float>(b)});
  };
  bounds("x_image_bounds", sec.x0_rad - 0.5 * sec.dx_rad, x1 + 0.5 * sec.dx_rad,
         "GOES-R fixed grid projection x-coordinate west/east extent of image");
  bounds("y_image_bounds", sec.y0_rad - 0.5 * sec.dy_rad, y1 + 0.5 * sec.dy_rad,
         "GOES-R fixed grid projection y-coordinate north/south extent of image");
  // The extent's values are its attributes (the variable itself holds the fill value).
  const int e = nc.add_variable("geospatial_lat_lon_extent", io::NcType::f32, {});
  nc.put_attribute(e, "long_name", "geospatial latitude and longitude references");
  nc.put_attribute_f32(e, "geospatial_westbound_longitude", {static_cast<float>(cover.west)});
  nc.put_attribute_f32(e, "geospatial_northbound_latitude", {static_cast<float>(cover.north)});
  nc.put_attribute_f32(e, "geospatial_eastbound_longitude", {static_cast<float>(cover.east)});
  nc.put_attribute_f32(e, "geospatial_southbound_latitude", {static_cast<float>(cover.south)});
  double lat_c = 0, lon_c = 0;  // the image's centre, where it lies on the Earth
  const bool centre_on_earth = view.projection.to_geodetic(xc, yc, lat_c, lon_c);
  nc.put_attribute_f32(e, "geospatial_lat_center", {static_cast<float>(centre_on_earth ? lat_c : NAN)});
  nc.put_attribute_f32(e, "geospatial_lon_center", {static_cast<float>(centre_on_earth ? lon_c : NAN)});
  nc.put_attribute_f32(e, "geospatial_lat_nadir", {0.0f});
  nc.put_attribute_f32(e, "geospatial_lon_nadir", {static_cast<float>(view.projection.lon0_deg)});
  nc.put_attribute(e, "geospatial_lat_units", "degrees_north");
  nc.put_attribute(e, "geospatial_lon_units", "degrees_east");
  return out;
}

// Rad (16-bit counts scaled to radiance, in NOAA's chunks) and DQF; returns their ids.
std::pair<int, int> define_radiances(io::NetcdfWriter& nc, const PackedBand& packed, const std::string& rad_units) {
  const int rad = nc.add_variable("Rad", io::NcType::i16, {"y", "x"}, {abi_chunk, abi_chunk});
  nc.put_attribute_i16(rad, "_FillValue", {rad_fill});
  nc.put_attribute(rad, "scale_factor", packed.scale);
  nc.put_attribute(rad, "add_offset", 0.0);
  nc.put_attribute(rad, "units", rad_units);
  nc.put_attribute(rad, "long_name", "ABI L1b Radiances (simulated by nephos)");
  nc.put_attribute(rad, "standard_name", "toa_outgoing_radiance_per_unit_wavenumber");
  nc.put_attribute_i16(rad, "valid_range", {0, static_cast<std::int16_t>(counts)});
  nc.put_attribute(rad, "grid_mapping", "goes_imager_projection");
  nc.put_attribute(rad, "coordinates", "band_id band_wavelength t y x");
  nc.put_attribute(rad, "ancillary_variables", "DQF");
  const int dqf = nc.add_variable("DQF", io::NcType::i8, {"y", "x"}, {abi_chunk, abi_chunk});
  nc.put_attribute_i8(dqf, "_FillValue", {-1});
  nc.put_attribute(dqf, "long_name", "ABI L1b Radiances data quality flags");
  nc.put_attribute_i8(dqf, "flag_values", {0});
  nc.put_attribute(dqf, "flag_meanings", "good_pixel_qf");
  return {rad, dqf};
}

// goes_imager_projection: the fixed grid as a CF grid mapping (GRS80, PUG Vol. 3 5.1.2.8).
int define_projection(io::NetcdfWriter& nc, const FixedGridView& view) {
  const int proj = nc.add_variable("goes_imager_projection", io::NcType::i32, {});
  nc.put_attribute(proj, "long_name", "GOES-R ABI fixed grid projection");
  nc.put_attribute(proj, "grid_mapping_name", "geostationary");
  nc.put_attribute(proj, "perspective_point_height", FixedGridProjection::perspective_height_m);
  nc.put_attribute(proj, "semi_major_axis", FixedGridProjection::semi_major_m);
  nc.put_attribute(proj, "semi_minor_axis", FixedGridProjection::semi_minor_m);
  nc.put_attribute(proj, "inverse_flattening", 298.2572221);
  nc.put_attribute(proj, "latitude_of_projection_origin", 0.0);
  nc.put_attribute(proj, "longitude_of_projection_origin", view.projection.lon0_deg);
  nc.put_attribute(proj, "sweep_angle_axis", "x");
  return proj;
}

// The band's calibration and the platform's place: wavelength, Planck coefficients (thermal
// bands), esun and kappa0, the Sun's distance, the nominal sub-satellite point and height.
void add_band_scalars(io::NetcdfWriter& nc, Scalars& sc, const optics::Band& band, const PlanckCoefficients& pc,
                      const FixedGridView& view, double sun_distance_au) {
  sc.add(nc, "band_wavelength", band.centre_um, "um", "ABI band central wavelength");
  if (band.thermal) {
    sc.add(nc, "planck_fk1", pc.fk1, "W m-1", "wavenumber-dependent coefficient (2 h c^2 nu^3) of the band");
    sc.add(nc, "planck_fk2", pc.fk2, "K", "wavenumber-dependent coefficient (h c nu / k) of the band");
    sc.add(nc, "planck_bc1", pc.bc1, "K", "spectral bandpass correction offset for brightness temperature");
    sc.add(nc, "planck_bc2", pc.bc2, "1", "spectral bandpass correction scale factor for brightness temperature");
  }
  sc.add(nc, "esun", band.solar_irradiance, "W m-2 um-1", "bandpass-weighted solar irradiance at 1 AU");
  sc.add(nc, "kappa0", M_PI / band.solar_irradiance, "(W m-2 um-1 sr-1)-1",
         "inverse of the solar irradiance times pi at 1 AU");
  sc.add(nc, "earth_sun_distance_anomaly_in_AU", sun_distance_au, "ua", "earth sun distance anomaly in AU");
  sc.add(nc, "nominal_satellite_subpoint_lat", 0.0, "degrees_north", "nominal satellite subpoint latitude");
  sc.add(nc, "nominal_satellite_subpoint_lon", view.nominal_subpoint_lon_deg, "degrees_east",
         "nominal satellite subpoint longitude");
  sc.add(nc, "nominal_satellite_height", FixedGridProjection::perspective_height_m / 1e3, "km",
         "nominal satellite height above GRS 80 ellipsoid");
}

// The file's global attributes: what it is, whose, which scene and when.
void put_global_attributes(io::NetcdfWriter& nc, const std::filesystem::path& path, const optics::Band& band,
                           const FixedGridView& view, const UtcTime& start, const UtcTime& end) {
  const FixedGridSector& sec = view.sector;
  const int g = io::NetcdfWriter::global;
  nc.put_attribute(g, "title", "ABI L1b Radiances");
  nc.put_attribute(g, "summary",
                   "Simulated by nephos from a weather model's clouds, atmosphere and ground: not an observation");
  nc.put_attribute(g, "Conventions", "CF-1.7");
  nc.put_attribute(g, "dataset_name", path.filename().string());
  nc.put_attribute(g, "platform_ID", view.platform);
  nc.put_attribute(g, "instrument_type", "GOES R Series Advanced Baseline Imager (simulated)");
  nc.put_attribute(g, "instrument_ID", "nephos");
  nc.put_attribute(g, "production_site", "nephos");
  nc.put_attribute(g, "orbital_slot", view.platform == "G16" ? "GOES-East" : "GOES-West");
  if (band.thermal) nc.put_attribute(g, "planck_coefficients_source", planck_source_text(view.platform, band));
  nc.put_attribute(g, "scene_id",
                   sec.abbreviation == 'F'   ? "Full Disk"
                   : sec.abbreviation == 'C' ? "CONUS"
                                             : "Mesoscale");
  nc.put_attribute(g, "timeline_id", "ABI Mode 6");
  nc.put_attribute(g, "spatial_resolution", fmt::format("{:g}km at nadir", sec.resolution_km * sec.step));
  nc.put_attribute(g, "time_coverage_start", abi_iso(start));
  nc.put_attribute(g, "time_coverage_end", abi_iso(end));
}

void write_band(const std::filesystem::path& path, const optics::Band& band, const PackedBand& packed,
                const FixedGridView& view, const UtcTime& start, double sun_distance_au, const SectorCover& cover) {
  const FixedGridSector& sec = view.sector;
  io::NetcdfWriter nc(path);
  nc.add_dimension("y", static_cast<std::size_t>(sec.ny)), nc.add_dimension("x", static_cast<std::size_t>(sec.nx));
  nc.add_dimension("number_of_time_bounds", 2), nc.add_dimension("number_of_image_bounds", 2);
  const std::string rad_units = band.thermal ? "mW m-2 sr-1 (cm-1)-1" : "W m-2 sr-1 um-1";
  const auto [rad, dqf] = define_radiances(nc, packed, rad_units);
  const int xv = coordinate(nc, "x", sec.x0_rad, sec.dx_rad, "X"),
            yv = coordinate(nc, "y", sec.y0_rad, sec.dy_rad, "Y");
  const int proj = define_projection(nc, view);
  const int band_id = nc.add_variable("band_id", io::NcType::i8, {});
  nc.put_attribute(band_id, "long_name", "ABI band number");
  Scalars sc;
  add_band_scalars(nc, sc, band, packed.pc, view, sun_distance_au);
  const SummaryVariables summary = add_summary(nc, sc, packed, cover, view, rad_units);
  const int yaw = nc.add_variable("yaw_flip_flag", io::NcType::i8, {});
  nc.put_attribute(yaw, "long_name", "Flag indicating the spacecraft is operating in yaw flip configuration");
  // Time: seconds since 2000-01-01 12:00:00 (J2000), the scan's middle and its bounds.
  const double t0 = start.days_since_j2000() * 86400, scan = scan_seconds(sec.abbreviation);
  sc.add(nc, "t", t0 + 0.5 * scan, "seconds since 2000-01-01 12:00:00",
         "J2000 epoch mid-point between the start and end image scan in seconds", true);
  const int tb = nc.add_variable("time_bounds", io::NcType::f64, {"number_of_time_bounds"});
  nc.put_attribute(tb, "long_name", "Scan start and end times in seconds since epoch (2000-01-01 12:00:00)");
  put_global_attributes(nc, path, band, view, start, start.plus_seconds(scan));
  nc.end_definitions();
  // Data.
  nc.write(rad, packed.rad.data());
  nc.write(dqf, packed.dqf.data());
  for (const auto& [v, value] : summary.counts) nc.write(v, &value);
  for (const auto& [v, pair] : summary.bounds) nc.write(v, pair.data());
  std::vector<std::int16_t> index(static_cast<std::size_t>(std::max(sec.nx, sec.ny)));
  for (std::size_t i = 0; i < index.size(); ++i) index[i] = static_cast<std::int16_t>(i);
  nc.write(xv, index.data());
  nc.write(yv, index.data());
  const std::int32_t zero = 0;
  nc.write(proj, &zero);
  const std::int8_t id = static_cast<std::int8_t>(band.abi_band), no = 0;
  nc.write(band_id, &id);
  nc.write(yaw, &no);
  const double bounds[2] = {t0, t0 + scan};
  nc.write(tb, bounds);
  sc.write(nc);
  nc.close();
}
}  // namespace

double PlanckCoefficients::radiance(double bt) const { return fk1 / (std::exp(fk2 / (bc1 + bc2 * bt)) - 1); }

double PlanckCoefficients::brightness_temperature(double l) const { return (fk2 / std::log(fk1 / l + 1) - bc1) / bc2; }

PlanckCoefficients planck_coefficients(const optics::Band& b) {
  PlanckCoefficients p;
  const double nu = 1e4 / b.centre_um;  // [cm^-1]
  p.fk1 = c1 * nu * nu * nu, p.fk2 = c2 * nu;
  // The centre's brightness temperature of the band-mean radiance, against the band's own.
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (double t = 180; t <= 340; t += 2, ++n) {
    const double l_um = optics::band_planck(b, t);                      // [W m^-2 sr^-1 um^-1]
    const double l_cm = l_um * b.centre_um * b.centre_um * 1e-4 * 1e3;  // per cm^-1, mW
    const double tc = p.fk2 / std::log(p.fk1 / l_cm + 1);
    sx += t, sy += tc, sxx += t * t, sxy += t * tc;
  }
  p.bc2 = (n * sxy - sx * sy) / (n * sxx - sx * sx), p.bc1 = (sy - p.bc2 * sx) / n;
  return p;
}

namespace {
// The Planck coefficients NOAA's ABI L1b files carry (fk1 = c1 nu^3 [mW m^-2 sr^-1 (cm^-1)^-1],
// fk2 = c2 nu [K], bc1 [K], bc2), from ABI's measured spectral responses: GOES-16
// bands 7-16 (OR_ABI-L1b-Rad*-M6Cnn_G16 files) and GOES-18 band 13 (M6C13_G18). The CMI ATBD
// (Schmit & Gunshor 2021, v4) quotes band 13's.
struct PublishedPlanck {
  const char* platform;
  int abi_band;
  PlanckCoefficients c;
};
constexpr std::array<PublishedPlanck, 11> published_planck{{
    {"G16", 7, {202263.0, 3698.19, 0.43361, 0.99939}},
    {"G16", 8, {50687.1, 2331.58, 1.55228, 0.99667}},
    {"G16", 9, {35828.3, 2076.95, 0.34427, 0.99918}},
    {"G16", 10, {30174.0, 1961.38, 0.05651, 0.99986}},
    {"G16", 11, {19779.9, 1703.83, 0.18733, 0.99948}},
    {"G16", 12, {13432.1, 1497.61, 0.09102, 0.99971}},
    {"G16", 13, {10803.3, 1392.74, 0.07550, 0.99975}},
    {"G16", 14, {8510.22, 1286.27, 0.22516, 0.99920}},
    {"G16", 15, {6454.62, 1173.03, 0.21702, 0.99916}},
    {"G16", 16, {5101.27, 1084.53, 0.06266, 0.99974}},
    {"G18", 13, {10818.40, 1393.39, 0.07725, 0.99974}},
}};

// The central frequencies [GHz] of ABI's thermal bands, from the measured spectral responses, as
// CRTM's spectral coefficients (abi_g16, abi_g18) give them and NOAA/EMC's radiance monitoring
// lists them (github.com/NOAA-EMC/obs-monitor, parm/cntrl/rad_angle.abi_g{16,18}.ges.ctl). Their
// wavenumbers give every published fk1 and fk2 above (AbiL1b.CentralWavenumbersGiveThePublishedFk).
struct CentralFrequency {
  const char* platform;
  int abi_band;
  double ghz;
};
constexpr std::array<CentralFrequency, 20> central_frequencies{{
    {"G16", 7, 77057.86},  {"G16", 8, 48582.22},  {"G16", 9, 43276.65},  {"G16", 10, 40868.56}, {"G16", 11, 35502.03},
    {"G16", 12, 31205.12}, {"G16", 13, 29019.94}, {"G16", 14, 26801.46}, {"G16", 15, 24441.91}, {"G16", 16, 22598.05},
    {"G18", 7, 76825.84},  {"G18", 8, 48472.21},  {"G18", 9, 43211.49},  {"G18", 10, 40832.92}, {"G18", 11, 35393.68},
    {"G18", 12, 31261.31}, {"G18", 13, 29033.47}, {"G18", 14, 26720.42}, {"G18", 15, 24473.21}, {"G18", 16, 22598.18},
}};

const PlanckCoefficients* find_published(const std::string& platform, int abi_band) {
  for (const PublishedPlanck& p : published_planck)
    if (platform == p.platform && abi_band == p.abi_band) return &p.c;
  return nullptr;
}
}  // namespace

double abi_central_wavenumber_cm1(const std::string& platform, int abi_band) {
  for (const CentralFrequency& f : central_frequencies)
    if (platform == f.platform && abi_band == f.abi_band) return f.ghz * 1e9 / 2.99792458e10;
  return 0;
}

PlanckSource planck_source(const std::string& platform, const optics::Band& b) {
  if (find_published(platform, b.abi_band)) return PlanckSource::published;
  if (abi_central_wavenumber_cm1(platform, b.abi_band) > 0 && find_published("G16", b.abi_band))
    return PlanckSource::central_wavenumber;
  return PlanckSource::nephos_band;
}

PlanckCoefficients abi_planck_coefficients(const std::string& platform, const optics::Band& b) {
  switch (planck_source(platform, b)) {
    case PlanckSource::published:
      return *find_published(platform, b.abi_band);
    case PlanckSource::central_wavenumber: {
      // fk1 and fk2 at the band's measured central wavenumber; the bandpass correction of the
      // same band of GOES-16, whose ABI is the same design (on band 13, published for both,
      // the two differ by 0.0018 K in bc1 and 1e-5 in bc2: < 0.005 K at 300 K).
      PlanckCoefficients p = *find_published("G16", b.abi_band);
      const double nu = abi_central_wavenumber_cm1(platform, b.abi_band);
      p.fk1 = c1 * nu * nu * nu, p.fk2 = c2 * nu;
      return p;
    }
    case PlanckSource::nephos_band:
      break;
  }
  return planck_coefficients(b);
}

std::string abi_l1b_file_name(const FixedGridView& view, int abi_band, const UtcTime& start) {
  const UtcTime end = start.plus_seconds(scan_seconds(view.sector.abbreviation));
  return fmt::format("OR_ABI-L1b-Rad{}-M6C{:02d}_{}_s{}_e{}_c{}.nc", view.sector.abbreviation, abi_band, view.platform,
                     abi_time(start), abi_time(end), abi_time(end));
}

L1bBands l1b_bands(const RenderImage& image) {
  L1bBands b;
  b.width = image.width, b.height = image.height, b.bands = image.bands;
  for (std::size_t k = 0; k < image.bands.size(); ++k) {
    b.radiance.push_back(image.radiance[k].data());
    const std::vector<float>& bt = image.brightness_temperature[k];
    b.brightness_temperature.push_back(bt.empty() ? nullptr : bt.data());
  }
  return b;
}

std::vector<std::filesystem::path> write_abi_l1b(const std::filesystem::path& dir, const RenderImage& image,
                                                 const FixedGridView& view, const UtcTime& start,
                                                 double sun_distance_au) {
  return write_abi_l1b(dir, l1b_bands(image), view, start, sun_distance_au);
}

std::vector<std::filesystem::path> write_abi_l1b(const std::filesystem::path& dir, const L1bBands& image,
                                                 const FixedGridView& view, const UtcTime& start,
                                                 double sun_distance_au) {
  const FixedGridSector& sec = view.sector;
  const std::size_t nb = image.bands.size();
  if (image.radiance.size() != nb || image.brightness_temperature.size() != nb ||
      std::count(image.radiance.begin(), image.radiance.end(), nullptr) > 0)
    throw ValueError(
        fmt::format("{} bands need {} radiance arrays and {} of brightness temperatures (or null)", nb, nb, nb),
        {.key = "bands"});
  if (image.width != sec.nx || image.height != sec.ny)
    throw ValueError(fmt::format("a {}x{} image is not the {}x{} sector", image.width, image.height, sec.nx, sec.ny),
                     {.key = "size"});
  if (sec.nx > 32767 || sec.ny > 32767) throw ValueError("the sector exceeds int16 pixel indices", {.key = "abi_step"});
  if (nb == 0) return {};
  ensure_directory(dir);
  const SectorCover cover = sector_cover(view.projection, sec);  // which pixels lie on the Earth, and their extent
  std::vector<std::filesystem::path> paths;
  for (const std::string& name : image.bands)
    paths.push_back(dir / abi_l1b_file_name(view, optics::band(name).abi_band, start));
  // A band's file is written by this thread while another packs the next band with as many
  // threads as this one's; in turn with one thread. netCDF-C and HDF5 take one caller at a time,
  // and HDF5 keeps its error reporting per thread: netCDF-C silences it on the thread that first
  // calls it, the caller's (written elsewhere, a later read here would print HDF5's reports).
  const int threads = omp_get_max_threads();
  auto pack = [&](std::size_t b) {
    omp_set_num_threads(threads);  // a new thread starts from OpenMP's default count
    return pack_band(image, b, view.platform, cover.on_earth);
  };
  PackedBand packed = pack(0);
  for (std::size_t b = 0; b < nb; ++b) {
    std::future<PackedBand> next;
    if (threads > 1 && b + 1 < nb) next = std::async(std::launch::async, pack, b + 1);
    write_band(paths[b], optics::band(image.bands[b]), packed, view, start, sun_distance_au, cover);
    if (b + 1 < nb) packed = next.valid() ? next.get() : pack(b + 1);
  }
  return paths;
}

}  // namespace nephos::render
