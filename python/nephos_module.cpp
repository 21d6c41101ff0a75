// The nephos Python module: weather, cloud masks, the global fractal cloud renderer and the
// lattice-Boltzmann cloud stages as numpy arrays, for scene simulation, machine-learning data
// and parameter studies (docs/python.md). A thin layer over the C++ library: the same code and
// the same results as the command line, bit for bit. nephos errors become Python exceptions
// here, the only place besides main() that catches them.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "nephos/clouds/cloud_model.hpp"
#include "nephos/core/config.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/log.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/time.hpp"
#include "nephos/earth/sun.hpp"
#include "nephos/lbm/job.hpp"
#include "nephos/lbm/lighting.hpp"
#include "nephos/lbm/percolation.hpp"
#include "nephos/lbm/raycast.hpp"
#include "nephos/lbm/water_model.hpp"
#include "nephos/optics/optics.hpp"
#include "nephos/particles/job.hpp"
#include "nephos/realtime/gl/flight_job.hpp"
#include "nephos/realtime/gl/sprite_renderer.hpp"
#include "nephos/realtime/weather_input.hpp"
#include "nephos/render/abi_l1b.hpp"
#include "nephos/render/job.hpp"
#include "nephos/render/renderer.hpp"
#include "nephos/render/sensor.hpp"
#include "nephos/weather/masks.hpp"
#include "nephos/weather/masks_job.hpp"
#include "nephos/weather/reader.hpp"
#include "nephos/weather/synthetic.hpp"

namespace py = pybind11;
using namespace nephos;

namespace {

// A copy of `values` as a numpy array of `shape` (row-major), owned by Python.
template <class T>
py::array_t<T> to_array(const std::vector<T>& values, std::vector<py::ssize_t> shape) {
  py::array_t<T> a(shape);
  std::copy(values.begin(), values.end(), a.mutable_data());
  return a;
}

// `values` moved into a numpy array of `shape` (row-major) without a copy: the array owns the
// vector and frees it with itself. An image's fields are handed over so, since a full disc's are
// gigabytes.
template <class T>
py::array_t<T> to_array(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto owned = std::make_unique<std::vector<T>>(std::move(values));
  T* data = owned->data();
  py::capsule owner(owned.get(), [](void* p) { delete static_cast<std::vector<T>*>(p); });
  owned.release();  // the capsule owns it now
  return py::array_t<T>(shape, data, owner);
}

// f() with the GIL released, for long work that touches no Python object; its result.
template <class F>
auto without_gil(F&& f) {
  py::gil_scoped_release release;
  return f();
}

// Names from a keyword argument: a list, or one string, comma-separated as on the command line
// ("vis,lwir", "all").
using NameList = std::variant<std::vector<std::string>, std::string>;
std::vector<std::string> names(const NameList& v, const std::string& key) {
  if (const auto* s = std::get_if<std::string>(&v)) return split_list(*s, key);
  return std::get<std::vector<std::string>>(v);
}

// The four masks as {type name: (nlat, nlon) array}.
py::dict masks_dict(const weather::WeatherMasks& m) {
  py::dict out;
  const auto shape = std::vector<py::ssize_t>{m.grid.nlat, m.grid.nlon};
  for (int t = 0; t < weather::cloud_type_count; ++t) {
    const auto type = static_cast<weather::CloudType>(t);
    out[py::str(std::string(weather::name(type)))] = to_array(m[type], shape);
  }
  return out;
}

class Weather {
 public:
  explicit Weather(weather::WeatherGrid w) : w_(std::move(w)) {}
  const weather::WeatherGrid& grid() const { return w_; }

  py::dict masks(const std::optional<std::string>& config) const {
    const weather::MaskParams params = clouds::read_model_config(config.value_or("")).masks;
    return masks_dict(without_gil([&] { return weather::compute_masks(w_, params); }));
  }
  py::array_t<double> latitudes() const {
    std::vector<double> v(static_cast<std::size_t>(w_.grid().nlat));
    for (int j = 0; j < w_.grid().nlat; ++j) v[static_cast<std::size_t>(j)] = w_.grid().lat(j);
    return to_array(v, {w_.grid().nlat});
  }
  py::array_t<double> longitudes() const {
    std::vector<double> v(static_cast<std::size_t>(w_.grid().nlon));
    for (int i = 0; i < w_.grid().nlon; ++i) v[static_cast<std::size_t>(i)] = w_.grid().lon(i);
    return to_array(v, {w_.grid().nlon});
  }
  // A single-level field by its GRIB shortName and typeOfLevel, in WeatherGrid's unit.
  py::array_t<float> field(const std::string& short_name, const std::string& level_type) const {
    for (const auto& si : weather::all_surface_fields())
      if (short_name == si.grib_short_name && level_type == si.grib_level_type) {
        if (!w_.has(si.field))
          throw ValueError(fmt::format("the weather has no {} at {}", short_name, level_type), {.key = "short_name"});
        return to_array(w_.surface(si.field), {w_.grid().nlat, w_.grid().nlon});
      }
    for (int l = 0; l < weather::cloud_layer_count; ++l) {
      const auto layer = static_cast<weather::CloudLayer>(l);
      if (short_name != "tcc" || level_type != weather::grib_level_type(layer)) continue;
      if (!w_.has_cloud_cover(layer))
        throw ValueError(fmt::format("the weather has no tcc at {}", level_type), {.key = "short_name"});
      return to_array(w_.cloud_cover(layer), {w_.grid().nlat, w_.grid().nlon});
    }
    std::vector<std::string> known;
    for (const auto& si : weather::all_surface_fields())
      known.push_back(fmt::format("{}@{}", si.grib_short_name, si.grib_level_type));
    for (int l = 0; l < weather::cloud_layer_count; ++l)
      known.push_back(fmt::format("tcc@{}", weather::grib_level_type(static_cast<weather::CloudLayer>(l))));
    throw ValueError(
        fmt::format("no single-level field {}@{} (known: {})", short_name, level_type, fmt::join(known, ", ")),
        {.key = "short_name"});
  }
  py::array_t<double> pressure_levels_pa() const {
    const auto& p = w_.pressure_levels_pa();
    return to_array(p, {static_cast<py::ssize_t>(p.size())});
  }
  // A field on the pressure levels (nlev, nlat, nlon), bottom level first; NaN at levels the file
  // lacks.
  py::array_t<float> level_field(const std::string& short_name) const {
    for (const auto& fi : weather::all_fields()) {
      if (short_name != fi.grib_short_name) continue;
      if (!w_.has(fi.field))
        throw ValueError(fmt::format("the weather has no {} on pressure levels", short_name), {.key = "short_name"});
      const std::size_t n = w_.grid().size();
      std::vector<float> v(n * static_cast<std::size_t>(w_.level_count()), std::numeric_limits<float>::quiet_NaN());
      for (int k : w_.levels_of(fi.field)) std::copy_n(w_.level_data(fi.field, k), n, v.begin() + k * n);
      return to_array(v, {w_.level_count(), w_.grid().nlat, w_.grid().nlon});
    }
    std::vector<std::string> known;
    for (const auto& fi : weather::all_fields()) known.emplace_back(fi.grib_short_name);
    throw ValueError(fmt::format("no pressure-level field {} (known: {})", short_name, fmt::join(known, ", ")),
                     {.key = "short_name"});
  }

 private:
  weather::WeatherGrid w_;
};

// nephos.Scene: a render::RenderScene from keyword arguments (the fields of SceneRequest and
// ViewRequest, so that errors name the keyword).
class Scene {
 public:
  Scene(const Weather& w, const std::optional<NameList>& types, int texture, std::uint64_t seed,
        const std::optional<std::string>& config, std::optional<double> displace_hours)
      : scene_(make(w, types, texture, seed, config, displace_hours)) {}

  void advance(double hours) {
    py::gil_scoped_release release;
    scene_->advance(hours, "hours");
  }

  py::object render(const std::string& sensor, std::pair<int, int> size, const NameList& bands, int steps,
                    const std::optional<std::string>& time, int samples, bool sample_grid, bool atmosphere,
                    bool shadows, bool filter, const std::string& scene, int abi_step, bool brightness_temperatures,
                    bool cloud_fields, bool as_dict) const {
    render::ViewRequest view;
    view.sensor = sensor;
    std::tie(view.width, view.height) = size;
    view.bands = names(bands, "bands");
    view.steps = steps;
    view.samples = samples;
    view.sample_grid = sample_grid;
    view.atmosphere = atmosphere;
    view.shadows = shadows;
    view.filter = filter;
    view.scene = scene;
    view.abi_step = abi_step;
    view.brightness_temperatures = brightness_temperatures;
    view.cloud_fields = cloud_fields;
    if (time) view.time = parse_time(*time, "time");
    require_image_size(view.width, view.height, "size");
    // The image's fields become the arrays handed to Python (no copy).
    render::RenderedView r = without_gil([&] { return scene_->render(view); });
    if (r.sensor.fixed_grid && !as_dict) return image_dataset(r, view);
    return image_dict(r);
  }

  std::vector<std::string> types() const {
    std::vector<std::string> names;
    for (auto t : scene_->types()) names.emplace_back(weather::name(t));
    return names;
  }
  std::string time() const { return scene_->time().iso(); }

 private:
  static std::unique_ptr<render::RenderScene> make(const Weather& w, const std::optional<NameList>& types, int texture,
                                                   std::uint64_t seed, const std::optional<std::string>& config,
                                                   std::optional<double> displace_hours) {
    render::SceneRequest r;
    if (types) {
      r.types.clear();
      for (const auto& t : names(*types, "types")) r.types.push_back(weather::cloud_type_from_name(t));
    }
    r.texture = texture;
    r.displace_hours = displace_hours;
    r.config = config.value_or("");
    r.seed = seed;
    py::gil_scoped_release release;
    return std::make_unique<render::RenderScene>(w.grid(), r);
  }
  // Each (height, width) field of an image with its name, units and description, for the dict
  // and the Dataset alike; the fields are moved out of img into the arrays.
  template <class Fn>
  static void for_each_field(render::RenderImage& img, Fn&& field) {
    const std::vector<py::ssize_t> shape{img.height, img.width};
    for (std::size_t b = 0; b < img.bands.size(); ++b) {
      const std::string what = optics::band(img.bands[b]).description;
      field("radiance_" + img.bands[b], to_array(std::move(img.radiance[b]), shape), "W m-2 sr-1 um-1",
            what + " radiance");
      if (!img.brightness_temperature[b].empty())
        field("brightness_temperature_" + img.bands[b], to_array(std::move(img.brightness_temperature[b]), shape), "K",
              what + " brightness temperature");
    }
    if (img.cloud_fraction.empty()) return;  // radiances alone (cloud_fields=False)
    field("cloud_top_altitude", to_array(std::move(img.cloud_top_altitude_m), shape), "m",
          "nearest cloud surface above MSL");
    field("cloud_optical_depth", to_array(std::move(img.cloud_optical_depth), shape), "1",
          "visible cloud optical depth");
    field("cloud_type", to_array(std::move(img.cloud_type), shape), "1",
          "-1 none, 0 low stratus, 1 low cumulus, 2 altostratus, 3 cirrus");
    field("cloud_fraction", to_array(std::move(img.cloud_fraction), shape), "1", "cloud area fraction of the pixel");
    field("latitude", to_array(std::move(img.latitude_deg), shape), "degrees_north",
          "latitude of the nearest cloud or Earth point");
    field("longitude", to_array(std::move(img.longitude_deg), shape), "degrees_east",
          "longitude of the nearest cloud or Earth point");
  }
  static py::dict image_dict(render::RenderedView& r) {
    render::RenderImage& img = r.image;
    py::dict out;
    for_each_field(img, [&](const std::string& name, py::object array, const std::string&, const std::string&) {
      out[py::str(name)] = array;
    });
    py::dict seconds;
    for (const auto& [name, secs] : img.seconds_per_type) seconds[py::str(name)] = secs;
    out["seconds_per_type"] = seconds;
    py::dict stages;  // the threads' time by stage of the rows' work, and around them
    for (const auto& [name, secs] : img.seconds_per_stage) stages[py::str(name)] = secs;
    stages["atmosphere"] = img.seconds_atmosphere, stages["outputs"] = img.seconds_outputs;
    out["seconds_per_stage"] = stages;
    out["sensor"] = r.sensor.description;
    out["time"] = r.time.iso();
    return out;
  }
  // An ABI view as an xarray.Dataset on the fixed grid: x, y scan angles [rad], every field with
  // its units and the CF grid mapping goes_imager_projection; the view's request in the attributes
  // (what write_abi_l1b needs).
  static py::object image_dataset(render::RenderedView& r, const render::ViewRequest& view) {
    render::RenderImage& img = r.image;
    const render::FixedGridView& fg = *r.sensor.fixed_grid;
    const render::FixedGridSector& sec = fg.sector;
    std::vector<double> xs(static_cast<std::size_t>(sec.nx)), ys(static_cast<std::size_t>(sec.ny));
    for (int i = 0; i < sec.nx; ++i) xs[static_cast<std::size_t>(i)] = sec.x(i);
    for (int j = 0; j < sec.ny; ++j) ys[static_cast<std::size_t>(j)] = sec.y(j);
    const py::tuple yx = py::make_tuple("y", "x");
    py::dict vars;
    for_each_field(
        img, [&](const std::string& name, py::object array, const std::string& units, const std::string& long_name) {
          py::dict a;
          a["units"] = units, a["long_name"] = long_name, a["grid_mapping"] = "goes_imager_projection";
          vars[py::str(name)] = py::make_tuple(yx, array, a);
        });
    py::dict proj;
    proj["grid_mapping_name"] = "geostationary",
    proj["perspective_point_height"] = render::FixedGridProjection::perspective_height_m;
    proj["semi_major_axis"] = render::FixedGridProjection::semi_major_m;
    proj["semi_minor_axis"] = render::FixedGridProjection::semi_minor_m;
    proj["latitude_of_projection_origin"] = 0.0, proj["longitude_of_projection_origin"] = fg.projection.lon0_deg;
    proj["sweep_angle_axis"] = "x";
    vars["goes_imager_projection"] = py::make_tuple(py::tuple(), 0, proj);
    py::dict coords, xa, ya;
    xa["units"] = "rad", xa["standard_name"] = "projection_x_coordinate", xa["axis"] = "X";
    ya["units"] = "rad", ya["standard_name"] = "projection_y_coordinate", ya["axis"] = "Y";
    coords["x"] = py::make_tuple(py::make_tuple("x"), to_array(xs, {sec.nx}), xa);
    coords["y"] = py::make_tuple(py::make_tuple("y"), to_array(ys, {sec.ny}), ya);
    py::dict attrs;
    attrs["sensor"] = view.sensor, attrs["scene"] = view.scene, attrs["abi_step"] = view.abi_step;
    attrs["resolution_km"] = view.resolution_km(), attrs["platform"] = fg.platform;
    attrs["time"] = r.time.iso(), attrs["sun_distance_au"] = r.sun.distance_au;
    attrs["description"] = r.sensor.description;
    return py::module_::import("xarray").attr("Dataset")(vars, coords, attrs);
  }
  std::unique_ptr<render::RenderScene> scene_;
};

// nephos.write_abi_l1b: an ABI view's Dataset (Scene.render) as L1b files in `dir`.
std::vector<std::string> write_abi_l1b(const py::object& dataset, const std::string& dir) {
  if (!py::hasattr(dataset, "attrs") || !py::hasattr(dataset, "data_vars"))
    throw ValueError("expected the xarray.Dataset of an ABI view (Scene.render)", {.key = "dataset"});
  const py::dict attrs = dataset.attr("attrs");
  for (const char* k : {"sensor", "scene", "abi_step", "resolution_km", "time", "sun_distance_au"})
    if (!attrs.contains(k))
      throw ValueError(std::string("not an ABI view of Scene.render: no attribute '") + k + "'", {.key = "dataset"});
  const render::FixedGridView view =
      render::abi_view(attrs["sensor"].cast<std::string>(), attrs["scene"].cast<std::string>(),
                       attrs["resolution_km"].cast<double>(), attrs["abi_step"].cast<int>());
  // The bands as the Dataset holds them: its own arrays, copied only where not float32 rows.
  render::L1bBands img;
  img.width = view.sector.nx, img.height = view.sector.ny;
  std::vector<py::array_t<float, py::array::c_style | py::array::forcecast>> held;  // alive until written
  const std::string prefix = "radiance_";
  for (const auto& name : dataset.attr("data_vars").attr("keys")()) {
    const std::string n = name.cast<std::string>();
    if (n.rfind(prefix, 0) != 0) continue;
    const std::string band = n.substr(prefix.size());
    auto values = [&](const std::string& var) {
      // In the image's row order whatever the variable's dimension order (a transposed view).
      const py::object da = dataset[py::str(var)];
      const auto dims = da.attr("dims").cast<std::vector<std::string>>();
      const std::vector<std::string> yx{"y", "x"};
      if (!std::is_permutation(dims.begin(), dims.end(), yx.begin(), yx.end()))
        throw ValueError(fmt::format("{} has dimensions ({}), expected (y, x)", var, fmt::join(dims, ", ")),
                         {.key = "dataset"});
      held.push_back(da.attr("transpose")("y", "x")
                         .attr("values")
                         .cast<py::array_t<float, py::array::c_style | py::array::forcecast>>());
      const auto& a = held.back();
      if (a.ndim() != 2 || a.shape(0) != img.height || a.shape(1) != img.width)
        throw ValueError(fmt::format("{} is not {}x{}", var, img.height, img.width), {.key = "dataset"});
      return a.data();
    };
    img.bands.push_back(band);
    img.radiance.push_back(values(n));
    // A thermal band's brightness temperatures where the dataset has them; else write_abi_l1b
    // finds them from the radiances, as a render without them gives (the same values).
    const std::string bt = "brightness_temperature_" + band;
    const bool has_bt = dataset.attr("data_vars").attr("__contains__")(bt).cast<bool>();
    img.brightness_temperature.push_back(optics::band(band).thermal && has_bt ? values(bt) : nullptr);
  }
  if (img.bands.empty()) throw ValueError("no radiance_<band> variable", {.key = "dataset"});
  const UtcTime start = UtcTime::parse(attrs["time"].cast<std::string>());
  const double sun_distance_au = attrs["sun_distance_au"].cast<double>();
  // The arrays are held above.
  const std::vector<std::filesystem::path> paths =
      without_gil([&] { return render::write_abi_l1b(dir, img, view, start, sun_distance_au); });
  std::vector<std::string> out;
  for (const auto& p : paths) out.push_back(p.string());
  return out;
}

// ---- Lattice-Boltzmann clouds: fields as (nz, ny, nx) float32 arrays, [z][y][x] as in lbm.nc.

lbm::Grid3 grid_of(const py::array_t<float, py::array::c_style | py::array::forcecast>& a, const char* what) {
  if (a.ndim() != 3)
    throw ValueError(fmt::format("expected a 3D array (nz, ny, nx), got {} dimensions", a.ndim()), {.key = what});
  for (int axis = 0; axis < 3; ++axis)
    if (a.shape(axis) < 1 || a.shape(axis) > 4096)
      throw ValueError(
          fmt::format("expected each dimension in 1..4096, got ({}, {}, {})", a.shape(0), a.shape(1), a.shape(2)),
          {.key = what});
  return {static_cast<int>(a.shape(2)), static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0))};
}
// A field from the caller: every value must be a number (a NaN would run through the solvers
// and come back as NaN light or a black image, far from its cause).
std::vector<float> values_of(const py::array_t<float, py::array::c_style | py::array::forcecast>& a, const char* what) {
  std::vector<float> v(a.data(), a.data() + a.size());
  const auto bad = std::find_if(v.begin(), v.end(), [](float x) { return !std::isfinite(x); });
  if (bad != v.end()) {
    const auto i = static_cast<std::size_t>(bad - v.begin());
    const auto nx = static_cast<std::size_t>(a.shape(2)), ny = static_cast<std::size_t>(a.shape(1));
    throw ValueError(fmt::format("{:g} at index ({}, {}, {}) (z, y, x); expected finite values", *bad, i / (nx * ny),
                                 i / nx % ny, i % nx),
                     {.key = what});
  }
  return v;
}
py::array_t<float> field_array(const std::vector<float>& v, const lbm::Grid3& g) {
  return to_array(v, {g.nz, g.ny, g.nx});
}
class WaterModel {
 public:
  WaterModel(std::tuple<int, int, int> grid, std::uint64_t seed, std::optional<int> silos,
             const std::optional<std::string>& config, const std::optional<std::string>& storage)
      : model_(make(grid, seed, silos, config, storage)) {}
  explicit WaterModel(lbm::WaterModel m) : model_(std::move(m)) {}

  // As `nephos lbm`: the densities checked every 10 steps and at the end; a NaN or a density
  // out of bounds stops with NumericError naming the step and the cell.
  void step(long n) {
    if (n < 0) throw ValueError("must be >= 0", {.key = "n"});
    py::gil_scoped_release release;
    for (long k = 0; k < n; ++k) {
      model_.step();
      if (model_.steps_done() % 10 == 0 || k == n - 1) check();
    }
  }
  long steps_done() const { return model_.steps_done(); }
  py::array_t<float> vapour() const { return field_array(model_.vapour(), model_.grid()); }
  py::array_t<float> temperature() const { return field_array(model_.temperature(), model_.grid()); }
  void save(const std::string& path) const {
    py::gil_scoped_release release;
    model_.save(path);
  }
  std::tuple<int, int, int> shape() const { return {model_.grid().nz, model_.grid().ny, model_.grid().nx}; }

 private:
  static lbm::WaterModel make(std::tuple<int, int, int> grid, std::uint64_t seed, std::optional<int> silos,
                              const std::optional<std::string>& config, const std::optional<std::string>& storage) {
    const auto [nx, ny, nz] = grid;
    const lbm::Grid3 g = lbm::Grid3::parse(fmt::format("{}x{}x{}", nx, ny, nz));  // its checks and messages
    const lbm::WaterModelParams p = lbm::water_params(
        config.value_or(""), silos, storage ? std::optional(lbm::parse_storage(*storage)) : std::nullopt);
    require_memory(static_cast<double>(g.cells()) * p.bytes_per_cell(), "grid",
                   fmt::format("the {} water model", g.describe()));
    lbm::WaterModel m(g, p);
    m.initialise(lbm::make_silos(g, p, seed), seed);
    return m;
  }
  void check() const {
    if (const auto bad = model_.bad_density()) throw NumericError(*bad);
  }
  lbm::WaterModel model_;
};

// nephos.Flight: a realtime::FlightSession from keyword arguments (the fields of
// FlightRequest), drawn frame by frame: what `nephos fly` writes as PNGs, as numpy arrays.
class Flight {
 public:
  Flight(const std::optional<std::string>& code, const std::optional<std::string>& metar,
         const std::optional<std::string>& foreca, const Weather* weather, std::pair<double, double> position,
         std::pair<int, int> size, double speed_kt, double altitude_ft, const std::string& time, std::uint64_t seed,
         bool impostors, double impostor_radius_km, double lod_km, bool sort_opt, const std::string& background,
         const std::string& gl) {
    realtime::FlightRequest r;
    r.clouds.code = code.value_or("");
    r.clouds.metar = metar.value_or("");
    r.clouds.foreca = foreca.value_or("");
    r.clouds.weather = weather ? &weather->grid() : nullptr;
    std::tie(r.lat_deg, r.lon_deg) = position;
    std::tie(r.width, r.height) = size;
    r.speed_kt = speed_kt;
    r.altitude_ft = altitude_ft;
    r.time = parse_time(time, "time");
    r.seed = seed;
    r.impostors = impostors;
    r.impostor_radius_km = impostor_radius_km;
    r.lod_km = lod_km;
    r.sort_opt = sort_opt;
    r.transparent = realtime::transparent_background(background);
    r.gl = realtime::gl_api_from_name(gl);
    session_ = std::make_unique<realtime::FlightSession>(r);
    session_->renderer().release_current();  // any Python thread may draw the first frame
  }

  void change_weather(const std::string& code, double at_s) {
    session_->change_weather(realtime::parse_weather_code(code), at_s);
  }

  py::array_t<std::uint8_t> frame() {
    std::vector<std::uint8_t> pixels;
    {
      py::gil_scoped_release release;
      // The context is current only while this thread draws (also when drawing throws):
      // flights may be drawn from any thread, several at once, each by one thread at a time.
      struct Current {
        realtime::SpriteRenderer& r;
        explicit Current(realtime::SpriteRenderer& renderer) : r(renderer) { r.make_current(); }
        ~Current() {
          try {
            r.release_current();
          } catch (const Error&) {  // nothing to do: the next make_current() reports EGL's state
          }
        }
      } current(session_->renderer());
      last_ = session_->next_frame();
      pixels = session_->pixels();
    }
    const auto& r = session_->renderer();
    return to_array(pixels, {r.height(), r.width(), session_->channels()});
  }

  py::dict stats() const {
    py::dict d;
    d["frame_ms"] = last_.milliseconds;
    d["sprites"] = last_.sprites;
    d["impostor_updates"] = last_.impostor_updates;
    d["impostor_sprites"] = last_.impostor_sprites;
    return d;
  }
  int frames_flown() const { return session_->flight().frames_flown(); }
  std::size_t clouds() const { return session_->flight().field().clouds().size(); }
  std::string gl_renderer() const { return session_->renderer().gl_renderer(); }

 private:
  std::unique_ptr<realtime::FlightSession> session_;
  realtime::FrameStats last_{};
};

// nephos.run_lbm: every stage of `nephos lbm` in this process, from keyword arguments (the
// fields of LbmRequest), writing its outputs; the fields as arrays.
py::dict run_lbm(std::tuple<int, int, int> grid, std::optional<int> silos, long iterations, long checkpoint_every,
                 int percolation, std::pair<double, double> sun, std::pair<int, int> size,
                 const std::optional<std::string>& resume, const std::optional<std::string>& config,
                 const std::optional<std::string>& storage, const std::string& out, std::uint64_t seed) {
  lbm::LbmRequest r;
  const auto [nx, ny, nz] = grid;
  r.grid = lbm::Grid3::parse(fmt::format("{}x{}x{}", nx, ny, nz));
  r.silos = silos;
  r.iterations = iterations;
  r.checkpoint_every = checkpoint_every;
  r.percolation = percolation;
  std::tie(r.sun_azimuth_deg, r.sun_elevation_deg) = sun;
  std::tie(r.width, r.height) = size;
  r.resume = resume.value_or("");
  r.config = config.value_or("");
  if (storage) r.storage = lbm::parse_storage(*storage);
  r.out = out;
  r.seed = seed;
  lbm::LbmResult res = without_gil([&] {
    lbm::SingleProcess one;
    return lbm::run_lbm(r, one);
  });
  py::dict d;
  d["vapour"] = field_array(res.vapour, res.grid);
  d["temperature"] = field_array(res.temperature, res.grid);
  if (!res.percolated.empty()) d["percolated_density"] = field_array(res.percolated, res.grid);
  d["cloud"] = field_array(res.cloud, res.grid);
  d["light"] = field_array(res.light, res.grid);
  d["steps"] = res.steps_done;
  d["percolation_steps"] = res.percolation_steps;
  d["lighting_steps"] = res.lighting_steps;
  d["lighting_residual"] = res.lighting_residual;
  return d;
}

// nephos.run_masks: `nephos masks` in this process, from keyword arguments (the fields of
// MasksRequest), writing masks.nc and the PNGs; the masks, their cover and the agreement.
py::dict run_masks(const std::optional<std::string>& weather, const std::optional<std::string>& weather_time,
                   bool synthetic, const std::optional<std::string>& config, int png_width, const std::string& out,
                   std::uint64_t seed) {
  weather::MasksRequest r;
  r.weather.file = weather.value_or("");
  if (weather_time) r.weather.valid_time = parse_time(*weather_time, "weather_time");
  r.weather.synthetic = synthetic;
  r.config = config.value_or("");
  r.png_width = png_width;
  r.out = out;
  r.seed = seed;
  weather::MasksResult res = without_gil([&] { return weather::run_masks(r); });
  py::dict cover;
  for (int t = 0; t < weather::cloud_type_count; ++t)
    cover[py::str(std::string(weather::name(static_cast<weather::CloudType>(t))))] =
        res.cover[static_cast<std::size_t>(t)];
  py::list agreement;
  for (const auto& a : res.agreement) {
    py::dict d;
    d["layer"] = std::string(weather::name(a.layer)), d["mask"] = a.mask, d["mask_cover"] = a.mask_cover;
    d["gfs_cover"] = a.gfs_cover, d["correlation"] = a.correlation;
    agreement.append(d);
  }
  py::dict d;
  d["masks"] = masks_dict(res.masks), d["cover"] = cover, d["agreement"] = agreement;
  d["valid_time"] = res.weather.valid_time.iso();
  return d;
}

// nephos.run_particles: `nephos particles` in this process, from keyword arguments (the fields
// of ParticlesRequest), writing its outputs; what it generated and drew as a dict.
py::dict run_particles(const std::vector<std::string>& weather, const std::optional<std::string>& wrf,
                       const std::optional<std::string>& region, std::uint64_t count, int frames, double frame_minutes,
                       const std::optional<std::array<double, 5>>& camera, std::pair<int, int> size, double k,
                       double lod_l0_km, bool lod, const std::string& transmission, int refine, bool ply,
                       const std::string& background, const std::string& out, std::uint64_t seed) {
  particles::ParticlesRequest r;
  r.weather.assign(weather.begin(), weather.end());
  r.wrf = wrf.value_or("");
  if (region) r.region = particles::LatLonRegion::parse(*region, "region");
  r.count = count;
  r.frames = frames;
  r.frame_minutes = frame_minutes;
  r.camera = camera;
  std::tie(r.width, r.height) = size;
  r.k = k;
  r.lod_l0_km = lod_l0_km;
  r.lod = lod;
  r.transmission = particles::transmission_named(transmission, "transmission");
  r.refine = refine;
  r.ply = ply;
  r.transparent = realtime::transparent_background(background);
  r.out = out;
  r.seed = seed;
  particles::ParticlesResult res = without_gil([&] { return particles::run_particles(r); });
  py::list drawn;
  for (const auto& f : res.frames) {
    py::dict d;
    d["time_s"] = f.time_s, d["time"] = f.time_utc, d["particles"] = f.particles, d["drawn"] = f.drawn;
    drawn.append(d);
  }
  py::dict d;
  d["particles"] = res.particles;
  d["source"] = res.source;
  d["columns"] = py::make_tuple(res.cols, res.rows);
  d["cell_m"] = py::make_tuple(res.cell_dx_m, res.cell_dy_m);
  d["generation_s"] = res.generation_s;
  d["frames"] = drawn;
  return d;
}

py::tuple percolate(const py::array_t<float, py::array::c_style | py::array::forcecast>& vapour, int refinement,
                    std::uint64_t seed, double rho10) {
  const lbm::Grid3 g = grid_of(vapour, "vapour");
  lbm::PercolationParams pp;
  pp.refinement = refinement;
  pp.rho10 = rho10;
  std::vector<float> v = values_of(vapour, "vapour"), density;
  int steps = 0;
  {
    py::gil_scoped_release release;
    lbm::Percolation perc(g, v, pp, seed);
    steps = perc.run();
    density = perc.coarse_density();
  }
  return py::make_tuple(field_array(density, g), steps);
}

py::tuple light(const py::array_t<float, py::array::c_style | py::array::forcecast>& density,
                std::pair<double, double> sun) {
  const lbm::Grid3 g = grid_of(density, "density");
  lbm::LightingParams lp;
  lp.set_sun(sun.first, sun.second, "sun");
  std::vector<float> d = values_of(density, "density"), field;
  int steps = 0;
  double residual = 0;
  {
    py::gil_scoped_release release;
    lbm::LightingSolver solver(g, std::move(d), lp);
    steps = solver.solve();
    residual = solver.residual();
    field = solver.light();
  }
  return py::make_tuple(field_array(field, g), steps, residual);
}

py::array_t<std::uint8_t> raycast(const py::array_t<float, py::array::c_style | py::array::forcecast>& density,
                                  const py::array_t<float, py::array::c_style | py::array::forcecast>& light,
                                  std::pair<int, int> size, std::pair<double, double> sun) {
  const lbm::Grid3 g = grid_of(density, "density");
  if (!(grid_of(light, "light") == g)) throw ValueError("light and density differ in shape", {.key = "light"});
  const auto [width, height] = size;
  require_image_size(width, height, "size");
  lbm::RaycastParams rp;
  rp.width = width, rp.height = height;
  lbm::LightingParams sun_check;
  sun_check.set_sun(sun.first, sun.second, "sun");
  std::tie(rp.sun_azimuth_deg, rp.sun_elevation_deg) = sun;
  const std::vector<float> d = values_of(density, "density"), l = values_of(light, "light");
  const std::vector<std::uint8_t> rgb = without_gil([&] { return lbm::raycast(g, d, l, rp); });
  return to_array(rgb, {height, width, 3});
}

}  // namespace

namespace {

// nephos.Weather and nephos.Scene.
void def_weather_and_scene(py::module_& m) {
  py::class_<Weather>(m, "Weather", "Pressure-level weather on a latitude-longitude grid (GRIB1/GRIB2).")
      .def(py::init([](const std::string& path, const std::optional<std::string>& valid_time) {
             py::gil_scoped_release release;
             return valid_time ? Weather(weather::open_weather(path, UtcTime::parse(*valid_time)))
                               : Weather(weather::open_weather(path));
           }),
           py::arg("path"), py::arg("valid_time") = py::none(),
           "Reads a GRIB file; of a file with several valid times the first, or `valid_time` (ISO 8601).")
      .def_static(
          "synthetic",
          [](std::uint64_t seed) {
            weather::SyntheticWeatherParams p;
            p.seed = seed;
            return Weather(weather::make_synthetic_weather(p));
          },
          py::arg("seed") = 1, "A synthetic, physically consistent atmosphere (deterministic from the seed).")
      .def_property_readonly("valid_time", [](const Weather& w) { return w.grid().metadata().valid_time.iso(); })
      .def_property_readonly("reference_time",
                             [](const Weather& w) { return w.grid().metadata().reference_time.iso(); })
      .def_property_readonly("source", [](const Weather& w) { return w.grid().metadata().source; })
      .def_property_readonly(
          "shape", [](const Weather& w) { return std::make_pair(w.grid().grid().nlat, w.grid().grid().nlon); })
      .def_property_readonly("latitudes", &Weather::latitudes, "Row latitudes [deg], south to north.")
      .def_property_readonly("longitudes", &Weather::longitudes, "Column longitudes [deg east].")
      .def("field", &Weather::field, py::arg("short_name"), py::arg("level_type") = "surface",
           "A single-level field (nlat, nlon): the surface, column, tropopause, GFS's cloud tops and top-of-"
           "atmosphere fluxes (e.g. field('ulwrf', 'nominalTop')) and GFS's layer cloud cover (field('tcc', "
           "'lowCloudLayer'), as fractions), in SI units (albedo as a fraction).")
      .def_property_readonly("pressure_levels_pa", &Weather::pressure_levels_pa,
                             "The pressure levels [Pa], bottom first.")
      .def("level_field", &Weather::level_field, py::arg("short_name"),
           "A field on the pressure levels (nlev, nlat, nlon), bottom first, in WeatherGrid's units (gh [gpm], t "
           "[K], r [fraction], w [Pa s-1], u, v [m s-1], clwmr, o3mr [kg kg-1]); NaN at levels the file lacks.")
      .def("masks", &Weather::masks, py::arg("config") = py::none(),
           "The four cloud masks (Table 1) as {type: array (nlat, nlon)} of values in [0, 1]; `config` a TOML file "
           "as for `nephos masks --config`.")
      .def("__repr__", [](const Weather& w) {
        return fmt::format("<nephos.Weather {} valid {}>", w.grid().grid().describe(),
                           w.grid().metadata().valid_time.iso());
      });

  py::class_<Scene>(m, "Scene",
                    "Clouds of one or more types over the whole Earth from a Weather: fractal textures, weather masks "
                    "and wind displacement, built once and rendered from any sensor.")
      .def(py::init<const Weather&, const std::optional<NameList>&, int, std::uint64_t,
                    const std::optional<std::string>&, std::optional<double>>(),
           py::arg("weather"), py::arg("types") = py::none(), py::arg("texture") = 0, py::arg("seed") = 1,
           py::arg("config") = py::none(), py::arg("displace_hours") = py::none(),
           "types: cloud type names, a list or one comma-separated string (default all four); texture: fractal "
           "texture edge in voxels (0: the configuration's, 256 by default); config: a TOML file as for `nephos "
           "render --config`; displace_hours: the wind displacement of every fractal [h].")
      .def_property_readonly("types", &Scene::types)
      .def_property_readonly("time", &Scene::time,
                             "The time the scene shows (ISO 8601 UTC): the weather's valid time plus the hours "
                             "advance() has carried it; a render without a time takes it.")
      .def("advance", &Scene::advance, py::arg("hours"),
           "Moves the clouds with the wind by `hours` (frame-to-frame propagation).")
      .def("render", &Scene::render, py::arg("sensor") = "geo:-75.2", py::arg("size") = std::make_pair(1000, 1000),
           py::arg("bands") = std::vector<std::string>{"vis", "nir", "lwir"}, py::arg("steps") = 25,
           py::arg("time") = py::none(), py::arg("samples") = 1, py::arg("sample_grid") = false,
           py::arg("atmosphere") = true, py::arg("shadows") = true, py::arg("filter") = true, py::arg("scene") = "full",
           py::arg("abi_step") = 1, py::arg("brightness_temperatures") = true, py::arg("cloud_fields") = true,
           py::arg("as_dict") = false,
           "Renders the scene as `nephos render` does (bands: any of the 16 ABI bands' names, nephos.bands(), or "
           "'all', as a list or one comma-separated string; atmosphere, shadows: False leaves them out; filter: False "
           "renders point samples, detail finer than a pixel unfiltered): a dict of (height, width) arrays "
           "radiance_<band> [W m-2 sr-1 um-1], brightness_temperature_<band> [K] for thermal bands (unless "
           "brightness_temperatures is False: radiances alone, as an L1b job renders), "
           "cloud_top_altitude [m], "
           "cloud_optical_depth, cloud_type (-1 none, 0..3), cloud_fraction, latitude and longitude [deg] (unless "
           "cloud_fields is False: radiances and brightness temperatures alone); plus "
           "seconds_per_type, seconds_per_stage (the threads' time in each stage of the rows' work: rays, march, "
           "hit_shadows, hit_shading, layers, ground_shadows, ground_and_sky, brightness_temperatures; and the "
           "wall-clock time of the atmosphere's tables and the outputs' arrays), sensor and time. sensor: 'geo:LON', "
           "'leo:LAT,LON,ALT_KM,FOV_DEG', 'abi:east', "
           "'abi:west', 'abi:LON' (the GOES-R fixed grid: sector `scene` 'full', 'conus' or 'meso:LAT,LON', coarsened "
           "by abi_step; size is the sector's; returned as an xarray.Dataset with x/y scan angles and the CF grid "
           "mapping goes_imager_projection, unless as_dict) or a camera TOML file; time: ISO 8601 UTC (default: the "
           "weather's valid time).");
}

// nephos.Flight.
void def_flight(py::module_& m) {
  py::class_<Flight>(m, "Flight",
                     "A straight, level flight eastwards through sprite clouds at 30 frames per second of flight, "
                     "drawn headless (EGL, OpenGL ES 3.0 or 3.3 core): the frames of `nephos fly` as numpy arrays.")
      .def(
          py::init([](const std::optional<std::string>& code, const std::optional<std::string>& metar,
                      const std::optional<std::string>& foreca, const Weather* weather,
                      std::pair<double, double> position, std::pair<int, int> size, double speed_kt, double altitude_ft,
                      const std::string& time, std::uint64_t seed, bool impostors, double impostor_radius_km,
                      double lod_km, bool sort_opt, const std::string& background, const std::string& gl) {
            return std::make_unique<Flight>(code, metar, foreca, weather, position, size, speed_kt, altitude_ft, time,
                                            seed, impostors, impostor_radius_km, lod_km, sort_opt, background, gl);
          }),
          py::kw_only(), py::arg("code") = py::none(), py::arg("metar") = py::none(), py::arg("foreca") = py::none(),
          py::arg("weather") = nullptr, py::arg("position") = std::make_pair(48.0, 11.0),
          py::arg("size") = std::make_pair(1280, 720), py::arg("speed_kt") = 250.0, py::arg("altitude_ft") = 8000.0,
          py::arg("time") = "2024-06-21T10:00:00Z", py::arg("seed") = 1, py::arg("impostors") = true,
          py::arg("impostor_radius_km") = 8.0, py::arg("lod_km") = 20.0, py::arg("sort_opt") = true,
          py::arg("background") = "sky", py::arg("gl") = "gles3",
          "The clouds of one weather source (a Foreca `code`, default d300; a `metar`; a `foreca` JSON file; or a "
          "`weather` at `position`) around an aircraft at `position` (lat, lon) [deg], as `nephos fly` takes them.")
      .def("frame", &Flight::frame,
           "Flies 1/30 s and draws: (height, width, 3) uint8 RGB, or (height, width, 4) straight-alpha RGBA with "
           "background='transparent'; the pixels of `nephos fly`'s frame_NNNN.png.")
      .def("change_weather", &Flight::change_weather, py::arg("code"), py::arg("at_s"),
           "From `at_s` seconds of flight on, the weather is `code`: clouds form and dissipate.")
      .def_property_readonly(
          "stats", &Flight::stats,
          "The last frame's {frame_ms (CPU time around glFinish), sprites, impostor_updates, impostor_sprites}.")
      .def_property_readonly("frames_flown", &Flight::frames_flown)
      .def_property_readonly("clouds", &Flight::clouds, "Sprite clouds in the field.")
      .def_property_readonly("gl_renderer", &Flight::gl_renderer);
}

// nephos.WaterModel and the lattice-Boltzmann stages.
void def_lbm(py::module_& m) {
  py::class_<WaterModel>(m, "WaterModel",
                         "The two-component lattice-Boltzmann water model (vapour and temperature) of `nephos lbm`.")
      .def(py::init<std::tuple<int, int, int>, std::uint64_t, std::optional<int>, const std::optional<std::string>&,
                    const std::optional<std::string>&>(),
           py::arg("grid") = std::make_tuple(128, 128, 128), py::arg("seed") = 1, py::arg("silos") = py::none(),
           py::arg("config") = py::none(), py::arg("storage") = py::none(),
           "grid: (nx, ny, nz) cells; seed: of the silos and the initial state; silos: vapour silos (default the "
           "configuration's, 4); config: a TOML file with a [water] table as for `nephos lbm --config`; storage: "
           "'fp32' or 'fp16'.")
      .def_static(
          "load", [](const std::string& path) { return WaterModel(lbm::WaterModel::load(path)); }, py::arg("path"),
          "A model from a checkpoint of `nephos lbm --checkpoint-every` or save().")
      .def("step", &WaterModel::step, py::arg("n") = 1,
           "Advances n steps (densities checked every 10 steps: RuntimeError on a NaN or a density out of bounds).")
      .def_property_readonly("steps_done", &WaterModel::steps_done)
      .def_property_readonly("shape", &WaterModel::shape, "(nz, ny, nx) of the fields")
      .def("vapour", &WaterModel::vapour, "Vapour density, (nz, ny, nx) float32 [lattice units].")
      .def("temperature", &WaterModel::temperature, "Temperature, (nz, ny, nx) float32 [lattice units].")
      .def("save", &WaterModel::save, py::arg("path"), "A checkpoint, as --checkpoint-every writes it.");
  m.def("run_lbm", &run_lbm, py::kw_only(), py::arg("grid") = std::make_tuple(128, 128, 128),
        py::arg("silos") = py::none(), py::arg("iterations") = 20, py::arg("checkpoint_every") = 0,
        py::arg("percolation") = 5, py::arg("sun") = std::make_pair(135.0, 45.0),
        py::arg("size") = std::make_pair(640, 480), py::arg("resume") = py::none(), py::arg("config") = py::none(),
        py::arg("storage") = py::none(), py::arg("out") = "out/lbm", py::arg("seed") = 1,
        "Every stage of `nephos lbm` in this process (water model, percolation with refinement `percolation` (0: "
        "skip), lighting, ray casting), writing lbm.nc, clouds.vdb and render.png into `out`: a dict of the fields "
        "as (nz, ny, nx) float32 arrays (vapour, temperature, percolated_density, cloud, light) and steps, "
        "percolation_steps, lighting_steps, lighting_residual. grid: (nx, ny, nz); sun: (azimuth, elevation) [deg]; "
        "size: (width, height) of render.png.");
  {
    const weather::MasksRequest d;  // the defaults, as the command line's
    m.def("run_masks", &run_masks, py::kw_only(), py::arg("weather") = py::none(), py::arg("weather_time") = py::none(),
          py::arg("synthetic") = false, py::arg("config") = py::none(), py::arg("png_width") = d.png_width,
          py::arg("out") = d.out.string(), py::arg("seed") = d.seed,
          "`nephos masks` in this process: the four cloud masks (Table 1) of a GRIB file (`weather`; none: the "
          "embedded GFS sample; `weather_time` ISO 8601 for a file with several) or of synthetic weather, written as "
          "masks.nc and a PNG per type (`png_width` wide) into `out`. `config`: a TOML file with [cloud_fraction] "
          "and [masks.*] tables. A dict: masks {type: (nlat, nlon) float32}, cover {type: area-weighted mean}, "
          "agreement (per layer with GFS's cloud cover: layer, mask, mask_cover, gfs_cover, correlation), "
          "valid_time.");
  }
  {
    const particles::ParticlesRequest d;  // the defaults, as the command line's
    m.def("run_particles", &run_particles, py::kw_only(), py::arg("weather") = std::vector<std::string>{},
          py::arg("wrf") = py::none(), py::arg("region") = py::none(), py::arg("count") = d.count,
          py::arg("frames") = d.frames, py::arg("frame_minutes") = d.frame_minutes, py::arg("camera") = py::none(),
          py::arg("size") = std::make_pair(d.width, d.height), py::arg("k") = d.k, py::arg("lod_l0_km") = d.lod_l0_km,
          py::arg("lod") = d.lod, py::arg("transmission") = "two-stream", py::arg("refine") = d.refine,
          py::arg("ply") = d.ply, py::arg("background") = "sky", py::arg("out") = d.out.string(),
          py::arg("seed") = d.seed,
          "`nephos particles` in this process: particle clouds from GRIB files (`weather`, every valid time of each; "
          "none: the embedded GFS sample) or WRF output (`wrf`), over `region` (\"LAT0,LON0,LAT1,LON1\" [deg]), "
          "drawn headless as `frames` frames of `size` (width, height) into `out` (frame_NNNN.png, "
          "particles_NNNN.ply unless ply=False, columns.nc, frames.csv). camera: (x [km], y [km], altitude [km], "
          "heading, pitch [deg]); transmission: two-stream or beer; background: sky or transparent. A dict: "
          "particles, source, columns (cols, rows), cell_m (dx, dy), generation_s and frames (per frame time_s, "
          "time, particles, drawn).");
  }
  m.def("percolate", &percolate, py::arg("vapour"), py::arg("refinement") = 5, py::arg("seed") = 1,
        py::arg("rho10") = 1.0,
        "Nagel-Raschke percolation of a vapour field on the grid refined K times: (cloud fraction (nz, ny, nx), "
        "steps).");
  m.def("light", &light, py::arg("density"), py::arg("sun") = std::make_pair(135.0, 45.0),
        "Lattice-Boltzmann lighting of a cloud density in [0, 1] to its steady state: (photon density (nz, ny, nx), "
        "steps, photon-balance residual). sun: (azimuth from +x towards +y, elevation) [deg].");
  m.def("raycast", &raycast, py::arg("density"), py::arg("light"), py::arg("size") = std::make_pair(640, 480),
        py::arg("sun") = std::make_pair(135.0, 45.0),
        "The lit density ray-cast from the default side view over a ground with its shadow: (height, width, 3) "
        "uint8 RGB.");
}

}  // namespace

PYBIND11_MODULE(nephos, m) {
  m.doc() = "nephos: real weather data to 3D clouds (weather, cloud masks, the global fractal cloud renderer)";
  init_logging(Verbosity::quiet);  // a library in a Python process: no log lines unless asked

  // nephos's typed exceptions as Python's: bad values and configuration as ValueError, files
  // as OSError, a request larger than the machine's memory as MemoryError, the rest as
  // RuntimeError; the message names the file, field or key.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const IoError& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    } catch (const ValueError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const ConfigError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const FormatError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const ResourceError& e) {
      PyErr_SetString(PyExc_MemoryError, e.what());
    } catch (const Error& e) {
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });

  m.def(
      "set_threads", [](int n) { set_threads(n); }, py::arg("threads"),
      "Threads for the parallel loops (0: all cores). Results do not depend on it.");
  m.def(
      "set_verbose", [](bool on) { init_logging(on ? Verbosity::normal : Verbosity::quiet); }, py::arg("on") = true,
      "Log lines (and warnings) on stderr, as the command line prints them.");
  m.def("cloud_fraction",
        py::vectorize([](double relative_humidity, double condensate_kg_kg, double temperature_k, double pressure_pa) {
          return weather::cloud_fraction(relative_humidity, condensate_kg_kg, temperature_k, pressure_pa,
                                         weather::CloudFractionParams{});
        }),
        py::arg("relative_humidity"), py::arg("condensate_kg_kg"), py::arg("temperature_k"), py::arg("pressure_pa"),
        "The cloud fraction the masks diagnose at each level (GFS radiation's Xu & Randall 1996, docs/weather.md), "
        "element-wise over numpy arrays: relative humidity [fraction], condensate [kg kg-1] (NaN: none in the file, "
        "the humidity ramp instead), temperature [K], pressure [Pa].");
  m.def("write_abi_l1b", &write_abi_l1b, py::arg("dataset"), py::arg("dir"),
        "Writes an ABI view of Scene.render (an xarray.Dataset) as ABI L1b files, one per band, into `dir` (as "
        "`nephos render --format abi-l1b`, on the view's grid); returns their paths.");
  m.def(
      "sun",
      [](const std::string& time) {
        const earth::SunPosition sp = earth::sun_position(parse_time(time, "time"));
        py::dict d;
        d["subsolar_latitude_deg"] = sp.subsolar_lat_deg;
        d["subsolar_longitude_deg"] = sp.subsolar_lon_deg;
        d["distance_au"] = sp.distance_au;
        return d;
      },
      py::arg("time"), "The Sun at an ISO 8601 UTC time: subsolar point [deg] and distance [AU].");
  m.def(
      "bands",
      [] {
        py::list out;
        for (const optics::Band& b : optics::bands()) {
          py::dict d;
          d["name"] = b.name;
          d["description"] = b.description;
          d["abi_band"] = b.abi_band;
          d["centre_um"] = b.centre_um;
          d["lo_um"] = b.lo_um;
          d["hi_um"] = b.hi_um;
          d["solar_irradiance_w_m2_um"] = b.solar_irradiance;
          d["thermal"] = b.thermal;
          out.append(d);
        }
        return out;
      },
      "The bands Scene.render takes: a list of dicts with name, description (its GOES-16 ABI band), centre_um, "
      "lo_um, hi_um [um], solar_irradiance_w_m2_um (top of the atmosphere at 1 AU [W m-2 um-1]) and thermal "
      "(brightness temperature reported).");

  def_weather_and_scene(m);
  def_flight(m);
  def_lbm(m);
}
