// nephos command-line program. Only this file (and the Python layer) catches exceptions:
// nephos::Error -> one-line message naming file/field/key, exit code 2.
#include <fmt/format.h>
#include <hdf5.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <new>
#include <optional>
#include <set>
#include <sstream>

#include "fly_bench.hpp"
#include "lbm_bench.hpp"
#include "lbm_mpi.hpp"
#include "nephos/clouds/cloud_model.hpp"
#include "nephos/core/atomic_file.hpp"
#include "nephos/core/config.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/log.hpp"
#include "nephos/core/parallel.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/core/progress.hpp"
#include "nephos/core/time.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/earth/sun.hpp"
#include "nephos/io/png.hpp"
#include "nephos/io/vdb_writer.hpp"
#include "nephos/lbm/lbm_io.hpp"
#include "nephos/lbm/lighting.hpp"
#include "nephos/lbm/percolation.hpp"
#include "nephos/lbm/raycast.hpp"
#include "nephos/lbm/water_model.hpp"
#include "nephos/particles/particles_io.hpp"
#include "nephos/particles/scene.hpp"
#include "nephos/particles/wrf_reader.hpp"
#include "nephos/realtime/cloud_field.hpp"
#include "nephos/realtime/frame_logic.hpp"
#include "nephos/realtime/gl_renderer.hpp"
#include "nephos/realtime/weather_input.hpp"
#include "nephos/render/outputs.hpp"
#include "nephos/render/renderer.hpp"
#include "nephos/render/sensor.hpp"
#include "nephos/weather/info.hpp"
#include "nephos/weather/masks.hpp"
#include "nephos/weather/masks_io.hpp"
#include "nephos/weather/reader.hpp"
#include "nephos/weather/synthetic.hpp"
#include "particles_bench.hpp"
#include "render_bench.hpp"
#include "view.hpp"

namespace fs = std::filesystem;
using namespace nephos;

namespace {

constexpr int exit_input_error = 2;

/// "1 thread" / "N threads", for summary lines.
std::string threads_text() {
  const int n = thread_count();
  return fmt::format("{} thread{}", n, n == 1 ? "" : "s");
}

/// The embedded default weather (a trimmed real GFS file, see data/README.md).
fs::path default_weather() {
  if (const char* env = std::getenv("NEPHOS_DATA_DIR")) return fs::path(env) / "gfs_20110110_12z_f120_2p5deg.grib2";
  return fs::path(NEPHOS_DATA_DIR) / "gfs_20110110_12z_f120_2p5deg.grib2";
}

struct GlobalOptions {
  bool verbose = false, quiet = false;
  int threads = 0;
  std::uint64_t seed = 1;
};

struct MasksOptions {
  std::string weather;
  std::string weather_time;  // a valid time of a file that holds several (ISO 8601)
  std::string out = "out";
  std::string config;
  bool synthetic = false;
  int png_width = 1440;
};

struct RenderOptions {
  std::string weather;
  std::string weather_time;  // a valid time of a file that holds several (ISO 8601)
  bool synthetic = false;
  std::string sensor = "geo:-75.2";
  std::string size = "1000x1000";
  std::string types = "low_stratus,low_cumulus,altostratus,cirrus";
  std::string bands = "vis,nir,lwir";
  int steps = 25;
  int samples = 1;             // rays per pixel, k^2
  bool sample_grid = false;    // sub-pixel rays at the sub-pixels' centres instead of stratified
  int texture = 0;             // 0: the config's [textures] size (default 256)
  std::string displace_hours;  // empty: per-type defaults
  double advance_hours = 0;
  int frames = 1;
  std::string time;
  std::string config;
  std::string out = "out";
};

std::vector<std::string> split(const std::string& list, const std::string& key) {
  std::vector<std::string> out;
  std::string item;
  std::stringstream ss(list);
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  if (out.empty()) throw ValueError("empty list", {.key = key});
  return out;
}

/// split() of a list whose items must be distinct (bands, cloud types).
std::vector<std::string> split_distinct(const std::string& list, const std::string& key) {
  std::vector<std::string> items = split(list, key);
  for (std::size_t i = 0; i < items.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (items[i] == items[j]) throw ValueError("'" + items[i] + "' is listed twice", {.key = key});
  return items;
}

std::pair<int, int> parse_size(const std::string& s) {
  int w = 0, h = 0;
  char x = 0;
  std::stringstream ss(s);
  if (!(ss >> w >> x >> h) || x != 'x' || w < 1 || h < 1 || w > 20000 || h > 20000 || !ss.eof())
    throw ValueError("expected WIDTHxHEIGHT (1..20000), got '" + s + "'", {.key = "--size"});
  return {w, h};
}

// A UTC time option (ISO 8601); its errors name the option.
UtcTime parse_time(const std::string& text, const char* key) {
  try {
    return UtcTime::parse(text);
  } catch (const ValueError& e) {
    throw ValueError(e.message(), {.key = key});
  }
}

// The weather file (default: the embedded sample), at `valid_time` (ISO 8601) when the file
// holds several valid times and one is asked for.
weather::WeatherGrid open_weather_file(const std::string& path, const std::string& valid_time) {
  const fs::path file = path.empty() ? default_weather() : fs::path(path);
  spdlog::info("weather: {}", file.string());
  if (valid_time.empty()) return weather::open_weather(file);
  return weather::open_weather(file, parse_time(valid_time, "--weather-time"));
}

weather::WeatherGrid load_weather(const std::string& path, bool synthetic, std::uint64_t seed,
                                  const std::string& valid_time) {
  if (synthetic) {
    if (!valid_time.empty())
      throw ValueError("synthetic weather has no file to choose a time from", {.key = "--weather-time"});
    weather::SyntheticWeatherParams p;
    p.seed = seed;
    spdlog::info("weather: synthetic atmosphere, seed {}", seed);
    return weather::make_synthetic_weather(p);
  }
  return open_weather_file(path, valid_time);
}

int run_masks(const MasksOptions& o, const GlobalOptions& g) {
  const auto t0 = std::chrono::steady_clock::now();
  weather::MaskParams params;
  if (!o.config.empty()) {
    const ParamDict dict = ParamDict::from_file(o.config);
    params = weather::MaskParams::from(dict);
    dict.check_unused();
  }
  const weather::WeatherGrid w = load_weather(o.weather, o.synthetic, g.seed, o.weather_time);
  const auto& m = w.metadata();
  spdlog::info("valid {} (run {} + {:g} h), {}", m.valid_time.iso(), m.reference_time.iso(), m.forecast_step_h,
               w.grid().describe());
  const weather::WeatherMasks masks = weather::compute_masks(w, params);

  const fs::path out(o.out);
  ensure_directory(out);
  weather::write_masks_netcdf(out / "masks.nc", masks, w, params);
  for (int t = 0; t < weather::cloud_type_count; ++t) {
    const auto type = static_cast<weather::CloudType>(t);
    weather::write_mask_png(out / (std::string(weather::name(type)) + ".png"), masks.grid, masks[type], o.png_width);
  }
  std::cout << fmt::format("{:<12} {:>10}\n", "mask", "cover");
  for (int t = 0; t < weather::cloud_type_count; ++t) {
    const auto type = static_cast<weather::CloudType>(t);
    std::cout << fmt::format("{:<12} {:>10.3f}\n", weather::name(type), weather::area_mean(masks.grid, masks[type]));
  }
  const auto agreement = weather::compare_with_gfs_cloud_cover(masks, w);
  if (!agreement.empty()) {
    std::cout << "\nagreement with GFS cloud cover (area-weighted):\n";
    std::cout << fmt::format("{:<7} {:<30} {:>10} {:>10} {:>12}\n", "layer", "mask", "mask cover", "GFS cover",
                             "correlation");
    for (const auto& a : agreement)
      std::cout << fmt::format("{:<7} {:<30} {:>10.3f} {:>10.3f} {:>12.3f}\n", weather::name(a.layer), a.mask,
                               a.mask_cover, a.gfs_cover, a.correlation);
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  spdlog::info("wrote {}/masks.nc and 4 PNGs in {:.2f} s ({})", out.string(), secs, threads_text());
  return 0;
}

int run_render(const RenderOptions& o, const GlobalOptions& g) {
  const auto t_start = std::chrono::steady_clock::now();
  // Parse everything before any work, so that bad input fails fast and writes nothing.
  const auto [width, height] = parse_size(o.size);
  std::vector<weather::CloudType> types;
  for (const auto& t : split_distinct(o.types, "--types")) types.push_back(weather::cloud_type_from_name(t));
  render::RenderParams rp;
  rp.bands = split_distinct(o.bands, "--bands");
  for (const auto& b : rp.bands) optics::band(b);
  rp.set_steps(o.steps, "--steps");
  rp.set_rays_per_pixel(o.samples, "--samples");
  rp.stratified_samples = !o.sample_grid;
  rp.sample_seed = g.seed;
  if (o.frames < 1) throw ValueError("must be >= 1", {.key = "--frames"});
  require_range(o.advance_hours, -clouds::CloudModelParams::max_displace_hours,
                clouds::CloudModelParams::max_displace_hours, "--advance-hours", "the advance per frame [h]");
  std::optional<double> displace_hours;
  if (!o.displace_hours.empty()) displace_hours = parse_numbers(o.displace_hours, 1, "--displace-hours", "hours")[0];
  clouds::CloudModelParams cp;
  weather::MaskParams mp;
  if (!o.config.empty()) {
    const ParamDict dict = ParamDict::from_file(o.config);
    cp = clouds::CloudModelParams::from(dict);
    mp = weather::MaskParams::from(dict);
    dict.check_unused();
  }
  cp.set_texture_size(o.texture != 0 ? o.texture : cp.texture_size, "--texture");
  const int tex = cp.texture_size;
  if (displace_hours) cp.set_displace_hours(*displace_hours, "--displace-hours");
  const render::Sensor sensor = render::parse_sensor(o.sensor, width, height);
  // The image and, while the previews are written, one byte per pixel and channel more.
  require_memory(render::render_memory_bytes(width, height, rp) + 3.0 * width * height, "--size",
                 fmt::format("a {}x{} image with {} rays per pixel", width, height, o.samples));

  const weather::WeatherGrid w = load_weather(o.weather, o.synthetic, g.seed, o.weather_time);
  const UtcTime time = o.time.empty() ? w.metadata().valid_time : parse_time(o.time, "--time");
  const earth::SunPosition sun = earth::sun_position(time);
  spdlog::info("sensor: {}", sensor.description);
  spdlog::info("time {}: subsolar point {:.2f}, {:.2f}", time.iso(), sun.subsolar_lat_deg, sun.subsolar_lon_deg);
  const weather::WeatherMasks masks = weather::compute_masks(w, mp);
  clouds::CloudScene scene = clouds::build_scene(w, masks, cp, types, g.seed);
  if (o.advance_hours != 0) clouds::advance_scene(scene, o.advance_hours, cp);

  const fs::path out(o.out);
  ensure_directory(out);
  for (int frame = 0; frame < o.frames; ++frame) {
    if (frame > 0) clouds::advance_scene(scene, o.advance_hours, cp);
    const render::RenderImage img = render::render(scene, sensor, sun, rp, &w);
    const fs::path dir = o.frames == 1 ? out : out / fmt::format("frame_{:03d}", frame);
    ensure_directory(dir);
    render::FrameMetadata meta{w.metadata().source,
                               sensor.description,
                               time.iso(),
                               sun.subsolar_lat_deg,
                               sun.subsolar_lon_deg,
                               g.seed,
                               o.steps,
                               tex,
                               o.samples,
                               o.samples == 1  ? "centre"
                               : o.sample_grid ? "grid"
                                               : "stratified",
                               {}};
    for (auto t : types) meta.types.emplace_back(weather::name(t));
    render::write_render_netcdf(dir / "render.nc", img, meta);
    render::write_render_exr(dir / "render.exr", img);
    render::write_render_previews(dir, img);
    std::string summary;
    for (const auto& [name, secs] : img.seconds_per_type) summary += fmt::format(" {} {:.0f} ms,", name, secs * 1e3);
    if (!summary.empty()) summary.pop_back();
    std::cout << fmt::format("frame {}: {}x{} px, {} ray{} per pixel, {} steps, texture {}^3:{} ({})\n", frame, width,
                             height, o.samples, o.samples == 1 ? "" : "s", o.steps, tex, summary, threads_text());
  }
  spdlog::info("wrote {} in {:.1f} s", out.string(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count());
  return 0;
}

struct LbmOptions {
  std::string grid = "128x128x128";
  static constexpr int silos_unset = std::numeric_limits<int>::min();
  int silos = silos_unset;  // unset: the parameter file's (default 4)
  long iterations = 20;
  long checkpoint_every = 0;
  int percolation = 5;         // K; 0: skip the stage
  std::string sun = "135,45";  // azimuth, elevation [deg]
  std::string size = "640x480";
  std::string resume;
  std::string config;
  std::string storage;  // empty: the parameter file's (default fp32)
  std::string out = "out/lbm";
};

int run_lbm(const LbmOptions& o, const GlobalOptions& g) {
  const auto t_start = std::chrono::steady_clock::now();
  if (o.iterations < 0) throw ValueError("must be >= 0", {.key = "--iterations"});
  const auto image_size = parse_size(o.size);
  const auto sun = parse_numbers(o.sun, 2, "--sun", "AZIMUTH,ELEVATION in degrees");
  // The sunlight enters through the faces it illuminates from above: a sun on or below the
  // horizon lights nothing.
  if (!(sun[1] > 0 && sun[1] <= 90))
    throw ValueError(fmt::format("the sun's elevation must be in (0, 90] deg, got {:g}", sun[1]), {.key = "--sun"});
  if (o.checkpoint_every < 0) throw ValueError("must be >= 0 (0: never)", {.key = "--checkpoint-every"});
  lbm::LightingParams lp;
  lp.sun_azimuth_deg = sun[0];
  lp.sun_elevation_deg = sun[1];

  lbm::WaterModelParams params;
  if (!o.config.empty()) {
    const ParamDict dict = ParamDict::from_file(o.config);
    params = lbm::WaterModelParams::from(dict);
    dict.check_unused();
  }
  if (o.silos != LbmOptions::silos_unset) params.set_silos(o.silos, "--silos");
  if (!o.storage.empty()) params.storage = lbm::parse_storage(o.storage);
  if (!o.resume.empty() && !o.storage.empty())
    throw ValueError("a resumed run keeps the storage of its checkpoint", {.key = "--storage"});
  const bool mpi = app::mpi_launched();  // every stage on slabs across the ranks
  {
    // What the stages hold at once, per cell [B] (docs/lbm.md): the water model's populations
    // and fields (one process), the percolation's five bits per refined site, the lighting's
    // two copies of 19 directions plus coefficients, and the output fields. Under MPI the
    // ranks share the three stages (slabs), and rank 0 gathers the fields.
    const lbm::Grid3 lattice =
        o.resume.empty() ? lbm::Grid3::parse(o.grid) : lbm::WaterModel::checkpoint_grid(o.resume);
    const double share = mpi ? 1.0 / app::mpi_size() : 1.0;
    const double water = params.bytes_per_cell() * share;
    const double percolation = (5.0 * std::pow(o.percolation, 3) / 8 + 8) * share, lighting = (2 * 19 * 4 + 8) * share,
                 fields = 5 * 4;
    require_memory(static_cast<double>(lattice.cells()) * (std::max({water, percolation, lighting}) + fields), "--grid",
                   fmt::format("the {} lattice with percolation K = {}", lattice.describe(), o.percolation));
  }
  const fs::path out(o.out);
  std::vector<float> vapour, temperature;
  std::vector<float> local_vapour;  // under MPI: this rank's slab of the vapour
  lbm::Grid3 grid;
  long done = 0, steps_total = 0;
  double t_water = 0;
  if (mpi) {
    ensure_directory(out);  // on every rank: a failure must stop all of them, not leave them waiting
    if (app::mpi_rank() != 0) Progress::set_enabled(false);  // one progress line per stage, rank 0's
    auto r = app::run_water_mpi(o.resume.empty() ? lbm::Grid3::parse(o.grid) : lbm::Grid3{}, params, g.seed,
                                {o.iterations, o.checkpoint_every, o.resume, out});
    grid = r.grid;
    vapour = std::move(r.vapour);  // rank 0 only
    temperature = std::move(r.temperature);
    local_vapour = std::move(r.local_vapour);
    done = r.steps_done - r.first_step;
    steps_total = r.steps_done;
    t_water = r.seconds;
    if (app::mpi_rank() == 0)
      spdlog::info("water model on {} MPI processes{}", app::mpi_size(),
                   o.resume.empty() ? "" : fmt::format(", resumed at step {} from {}", r.first_step, o.resume));
  } else {
    lbm::WaterModel model =
        o.resume.empty() ? lbm::WaterModel(lbm::Grid3::parse(o.grid), params) : lbm::WaterModel::load(o.resume);
    if (o.resume.empty()) {
      model.initialise(lbm::make_silos(model.grid(), params, g.seed), g.seed);
      spdlog::info("water model {} with {} silos (seed {})", model.grid().describe(), params.silos, g.seed);
    } else {
      spdlog::info("resumed {} at step {} from {}", model.grid().describe(), model.steps_done(), o.resume);
    }
    ensure_directory(out);
    grid = model.grid();
    auto check = [&] {
      const auto bad = model.bad_density();
      if (!bad) return;
      const auto ck = out / "checkpoint_failed.bin";
      model.save(ck);
      throw NumericError(fmt::format("{}; state saved to {}", *bad, ck.string()));
    };
    const auto t0 = std::chrono::steady_clock::now();
    const long first = model.steps_done();
    {
      Progress progress("water model", static_cast<std::size_t>(std::max(0L, o.iterations - first)));
      while (model.steps_done() < o.iterations) {
        model.step();
        progress.advance();
        if (model.steps_done() % 10 == 0) check();
        if (o.checkpoint_every > 0 && model.steps_done() % o.checkpoint_every == 0) model.save(out / "checkpoint.bin");
      }
    }
    check();
    t_water = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    vapour = model.vapour();
    temperature = model.temperature();
    done = model.steps_done() - first;
    steps_total = model.steps_done();
  }
  // Percolation and lighting: under MPI each rank works on its slab (halo rows exchanged with
  // its neighbours, docs/lbm.md) and rank 0 gathers the fields; otherwise on the whole lattice.
  std::vector<float> percolated;
  double t_perc = 0;
  int perc_steps = 0;
  if (o.percolation > 0) {
    const auto tp = std::chrono::steady_clock::now();
    lbm::PercolationParams pp;
    pp.refinement = o.percolation;
    pp.rho10 = params.rho10;
    // Steps to the end of activity are not known in advance: the line counts them.
    Progress progress("percolation", Progress::OpenEnded{});
    auto on_step = [&](int, std::size_t active) {
      progress.set_detail(fmt::format("{} active sites", active));
      progress.advance();
    };
    if (mpi) {
      auto r = app::run_percolation_mpi(grid, local_vapour, pp, g.seed, on_step);
      perc_steps = r.steps;
      percolated = std::move(r.local_density);  // this rank's slab until gathered
    } else {
      lbm::Percolation perc(grid, vapour, pp, g.seed);
      perc_steps = perc.run({.after_step = on_step});
      percolated = perc.coarse_density();
    }
    t_perc = std::chrono::duration<double>(std::chrono::steady_clock::now() - tp).count();
  }
  // Lighting (lattice-Boltzmann photon transport) of the cloud density, then ray casting.
  std::vector<float> cloud = percolated;
  if (cloud.empty()) {  // without percolation: condensate where the vapour exceeds rho10
    const std::vector<float>& v = mpi ? local_vapour : vapour;
    cloud.resize(v.size());
    for (std::size_t c = 0; c < v.size(); ++c)
      cloud[c] = static_cast<float>(std::clamp((v[c] - params.rho10) / (0.1 * params.rho10), 0.0, 1.0));
  }
  const auto tl = std::chrono::steady_clock::now();
  std::vector<float> light;
  int light_steps = 0;
  double light_residual = 0;
  {
    // Steps to the steady state are not known in advance: the line counts them and shows the
    // photon-balance residual against its tolerance.
    Progress progress("lighting", Progress::OpenEnded{});
    auto on_step = [&](const lbm::LightingSolver& s) {
      progress.set_detail(fmt::format("residual {:.1e} (to {:.0e})", s.residual(), lp.tolerance));
      progress.advance();
    };
    if (mpi) {
      auto r = app::run_lighting_mpi(grid, cloud, lp, on_step);
      light_steps = r.steps;
      light_residual = r.residual;
      light = app::gather_slabs(grid, r.local_light);
      cloud = app::gather_slabs(grid, cloud);
      if (!percolated.empty()) percolated = app::gather_slabs(grid, percolated);
    } else {
      lbm::LightingSolver lighting(grid, cloud, lp);
      light_steps = lighting.solve(on_step);
      light_residual = lighting.residual();
      light = lighting.light();
    }
  }
  if (mpi && app::mpi_rank() != 0) return 0;  // rank 0 casts the rays and writes the outputs
  const double t_light = std::chrono::duration<double>(std::chrono::steady_clock::now() - tl).count();
  const auto tr = std::chrono::steady_clock::now();
  lbm::RaycastParams rp;
  std::tie(rp.width, rp.height) = image_size;
  rp.sun_azimuth_deg = lp.sun_azimuth_deg;
  rp.sun_elevation_deg = lp.sun_elevation_deg;
  const auto image = lbm::raycast(grid, cloud, light, rp);
  io::write_png(out / "render.png", rp.width, rp.height, 3, image);
  const double t_ray = std::chrono::duration<double>(std::chrono::steady_clock::now() - tr).count();

  std::vector<lbm::LatticeField> fields{
      {"vapour_density", "water vapour density (lattice units; condensation above rho10)", "1", &vapour},
      {"temperature", "temperature (lattice units)", "1", &temperature}};
  if (!percolated.empty())
    fields.push_back(
        {"percolated_density", "cloud fraction of each cell after Nagel-Raschke percolation", "1", &percolated});
  fields.push_back(
      {"light", "steady-state photon density (sum over lattice directions; sunlight injected at 1)", "1", &light});
  lbm::write_lattice_netcdf(out / "lbm.nc", grid, fields,
                            {{"title", "nephos lattice-Boltzmann convective cloud"},
                             {"steps", std::to_string(steps_total)},
                             {"seed", std::to_string(g.seed)}});
  // The volumes for Blender/Houdini: "density" is the cloud the renderers expect.
  const int nx = grid.nx, ny = grid.ny, nz = grid.nz;
  io::write_vdb(out / "clouds.vdb", {{"density", nx, ny, nz, &cloud, 1.0, true, 0.0f},
                                     {"vapour", nx, ny, nz, &vapour, 1.0, false, -1.0f},
                                     {"temperature", nx, ny, nz, &temperature, 1.0, false, -1.0f},
                                     {"light", nx, ny, nz, &light, 1.0, false, 0.0f}});
  std::cout << fmt::format("water model {}: {} steps in {:.2f} s ({:.3f} s/step, {})\n", grid.describe(), done, t_water,
                           done > 0 ? t_water / static_cast<double>(done) : 0.0, threads_text());
  if (o.percolation > 0)
    std::cout << fmt::format("percolation K={}: {} steps in {:.2f} s\n", o.percolation, perc_steps, t_perc);
  std::cout << fmt::format("lighting: {} steps to residual {:.1e} in {:.2f} s\n", light_steps, light_residual, t_light);
  std::cout << fmt::format("ray casting {}x{}: {:.2f} s\n", rp.width, rp.height, t_ray);
  spdlog::info("wrote {} in {:.1f} s", (out / "lbm.nc").string(),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count());
  return 0;
}

struct FlyOptions {
  std::string code, metar, foreca, weather;
  std::string position = "48.0,11.0";  // latitude, longitude [deg]
  int frames = 60;
  std::string size = "1280x720";
  double speed_kt = 250, altitude_ft = 8000;
  std::string time = "2024-06-21T10:00:00Z";
  bool no_sort_opt = false;
  bool no_impostors = false;
  double impostor_radius_km = 8;   // MSFS 2004's ring radius
  double lod_km = 20;              // single-sprite level of detail beyond this (0: off)
  std::string change;              // CODE@SECONDS: the weather changes to CODE at that time of the flight
  std::string gl = "gles3";        // OpenGL ES 3.0 or desktop OpenGL 3.3 core
  std::string background = "sky";  // or "transparent": RGBA frames to composite over a map
  std::string weather_time;        // with --weather: a valid time of a file that holds several
  std::string out = "out/fly";
};

// --background of nephos fly and nephos particles.
void add_background_option(CLI::App* c, std::string& value) {
  c->add_option("--background", value,
                "sky, or transparent: RGBA frames (alpha = cloud coverage) to composite over a map or terrain")
      ->capture_default_str();
}

/// --background: false for "sky", true for "transparent".
bool transparent_background(const std::string& value) {
  if (value != "sky" && value != "transparent")
    throw ValueError("expected sky or transparent, got '" + value + "'", {.key = "--background"});
  return value == "transparent";
}

/// The renderer's last frame as a PNG: RGB over the sky, or RGBA (straight alpha) without it.
void write_frame_png(const fs::path& path, const realtime::SpriteRenderer& renderer, bool transparent) {
  if (transparent)
    io::write_png(path, renderer.width(), renderer.height(), 4, realtime::straight_alpha(renderer.read_pixels()));
  else
    app::write_rgb_png(path.string(), renderer.width(), renderer.height(), renderer.read_pixels());
}

// The options nephos fly and nephos view share: weather source, place, time, aircraft, GL API.
void add_flight_options(CLI::App* c, FlyOptions& o) {
  c->add_option("--code", o.code, "Foreca weather symbol, e.g. d300 (default)");
  c->add_option("--metar", o.metar, "METAR report (its cloud groups)");
  c->add_option("--foreca", o.foreca, "Foreca hourly or daily JSON");
  c->add_option("--weather", o.weather, "GRIB weather file (masks and winds at --position)");
  c->add_option("--weather-time", o.weather_time,
                "With --weather: which valid time (ISO 8601 UTC) of a file that holds several (default: its first)");
  c->add_option("--position", o.position, "LAT,LON of the aircraft [deg]")->capture_default_str();
  c->add_option("--size", o.size, "Frame WIDTHxHEIGHT")->capture_default_str();
  c->add_option("--speed", o.speed_kt, "Ground speed [kt]")->capture_default_str();
  c->add_option("--altitude", o.altitude_ft, "Altitude [ft]")->capture_default_str();
  c->add_option("--time", o.time, "UTC time for the sun (ISO 8601)")->capture_default_str();
  c->add_flag("--no-impostors", o.no_impostors, "Draw every cloud as sprites (no impostor ring)");
  c->add_option("--impostor-radius-km", o.impostor_radius_km, "Radius of the impostor ring [km]")
      ->capture_default_str();
  c->add_option("--lod-km", o.lod_km,
                "Clouds drawn as sprites farther than this are drawn as one sprite (level of detail) [km]; 0: "
                "every sprite")
      ->capture_default_str();
  c->add_option("--gl", o.gl, "OpenGL API: gles3 (OpenGL ES 3.0) or gl33 (OpenGL 3.3 core)")->capture_default_str();
}

// The aircraft's place, checked with the other numbers nephos fly and nephos view share.
std::pair<double, double> checked_flight(const FlyOptions& o) {
  const auto pos = parse_numbers(o.position, 2, "--position", "LAT,LON in degrees");
  require_range(pos[0], -90, 90, "--position", "the latitude [deg]");
  // From the Dead Sea shore to beyond any aircraft's ceiling.
  require_range(o.altitude_ft, -1500, 100000, "--altitude", "the altitude [ft]");
  require_range(o.speed_kt, 0, 5000, "--speed", "the ground speed [kt]");
  require_range(o.lod_km, 0, 1e4, "--lod-km", "the level-of-detail distance [km] (0: off)");
  return {pos[0], pos[1]};
}

// The clouds around the aircraft from whichever weather source the options name.
realtime::CloudRecipe flight_recipe(const FlyOptions& o, const UtcTime& time, double lat, double lon) {
  const int sources = !o.code.empty() + !o.metar.empty() + !o.foreca.empty() + !o.weather.empty();
  if (sources > 1) throw ValueError("give one of --code, --metar, --foreca, --weather", {.key = "--code"});
  if (!o.metar.empty()) return realtime::recipe_from_metar(o.metar);
  if (!o.foreca.empty()) return realtime::recipe_from_code(realtime::code_from_foreca_json(o.foreca, time));
  if (!o.weather.empty()) {
    const weather::WeatherGrid w = open_weather_file(o.weather, o.weather_time);
    return realtime::recipe_from_weather(weather::compute_masks(w, weather::MaskParams{}), w, lat, lon);
  }
  return realtime::recipe_from_code(realtime::parse_weather_code(o.code.empty() ? "d300" : o.code));
}

int run_view_command(const FlyOptions& o, const std::string& screenshot, const GlobalOptions& g) {
  app::ViewOptions v;
  std::tie(v.width, v.height) = parse_size(o.size);
  std::tie(v.lat_deg, v.lon_deg) = checked_flight(o);
  const UtcTime time = parse_time(o.time, "--time");
  if (o.frames < 0) throw ValueError("must be >= 0 (0: until the window is closed)", {.key = "--frames"});
  v.time = time;
  v.api = realtime::gl_api_from_name(o.gl);
  v.recipe = flight_recipe(o, time, v.lat_deg, v.lon_deg);
  v.frames = o.frames;
  v.altitude_m = o.altitude_ft * 0.3048;
  v.speed_m_s = o.speed_kt * 0.514444;
  v.impostor_radius_m = o.impostor_radius_km * 1000;
  v.single_sprite_distance_m = o.lod_km * 1000;
  v.impostors = !o.no_impostors;
  v.screenshot = screenshot;
  v.seed = g.seed;
  return app::run_view(v);
}

int run_fly(const FlyOptions& o, const GlobalOptions& g) {
  const auto [width, height] = parse_size(o.size);
  const auto [lat, lon] = checked_flight(o);
  const UtcTime time = parse_time(o.time, "--time");
  if (o.frames < 1) throw ValueError("must be >= 1", {.key = "--frames"});
  std::optional<std::pair<realtime::CloudRecipe, double>> change;
  bool changed = false;
  if (!o.change.empty()) {
    const auto at = o.change.find('@');
    if (at == std::string::npos)
      throw ValueError("expected CODE@SECONDS, e.g. d400@1.5, got '" + o.change + "'", {.key = "--change"});
    const auto secs = parse_numbers(o.change.substr(at + 1), 1, "--change", "CODE@SECONDS");
    require_range(secs[0], 0, 1e7, "--change", "the time of the change [s of flight]");
    change.emplace(realtime::recipe_from_code(realtime::parse_weather_code(o.change.substr(0, at))), secs[0]);
  }
  const bool transparent = transparent_background(o.background);
  const realtime::CloudRecipe recipe = flight_recipe(o, time, lat, lon);
  spdlog::info("clouds from {}: {} sprite clouds", recipe.source, recipe.sprite_clouds());
  const double alt_m = o.altitude_ft * 0.3048, speed_m_s = o.speed_kt * 0.514444;
  realtime::Camera cam{{0, 0, alt_m}, {1, 0, -0.05}, {0, 0, 1}, 60};
  realtime::CloudField field(recipe, g.seed, cam.position);
  realtime::SpriteRenderer renderer(width, height, g.seed, realtime::gl_api_from_name(o.gl));
  spdlog::info("OpenGL: {} on {}", renderer.gl_version(), renderer.gl_renderer());
  renderer.set_impostor_radius(o.impostor_radius_km * 1000);
  renderer.set_single_sprite_distance(o.lod_km * 1000);
  if (transparent) renderer.set_background(realtime::SpriteRenderer::Background::transparent);
  const realtime::SunLight sun = realtime::sun_light(time, lat, lon);
  realtime::ResortPolicy policy;
  const fs::path out(o.out);
  ensure_directory(out);
  AtomicFile csv(out / "frames.csv");
  std::ofstream table(csv.temp_path());
  table << "frame,frame_ms,sprites,impostor_updates\n";
  Progress progress("fly", static_cast<std::size_t>(o.frames));
  double total_ms = 0;
  for (int f = 0; f < o.frames; ++f) {
    cam.position.x += speed_m_s / 30.0;  // 30 frames per second of flight
    const double t_s = f / 30.0;
    if (change && !changed && t_s >= change->second) {
      field.change_weather(change->first, t_s, cam.position);
      changed = true;
    }
    field.advance_time(t_s);
    field.follow_camera(cam.position, cam.forward);
    const bool sort = o.no_sort_opt || policy.due(cam.position, cam.forward);
    const realtime::FrameStats st = renderer.draw(field, cam, sun, sort, !o.no_impostors);
    total_ms += st.milliseconds;
    table << fmt::format("{},{:.3f},{},{}\n", f, st.milliseconds, st.sprites, st.impostor_updates);
    write_frame_png(out / fmt::format("frame_{:04d}.png", f), renderer, transparent);
    progress.advance();
  }
  csv.commit(table);
  std::cout << fmt::format(
      "fly: {} frames of {}x{}, {} sprite clouds, mean frame {:.1f} ms (CPU time around glFinish; {})\n", o.frames,
      width, height, field.clouds().size(), total_ms / o.frames, renderer.gl_renderer());
  return 0;
}

struct ParticlesOptions {
  std::vector<std::string> weather;
  std::string wrf;
  std::string region;  // default: the whole WRF domain; for GFS the North Atlantic and Europe
  std::size_t count = 200000;
  int frames = 4;
  double frame_minutes = 30;
  std::string camera;  // X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG; default: south of the region
  std::string size = "1280x720";
  double k = 1;
  double lod_l0_km = 0;
  bool no_lod = false;
  std::string transmission = "two-stream";
  int refine = 0;  // 0: GFS cells split to <= 30 km, WRF as it is
  bool no_ply = false;
  std::string background = "sky";  // or "transparent"
  std::string out = "out/particles";
};

int run_particles(const ParticlesOptions& o, const GlobalOptions& g) {
  const auto [width, height] = parse_size(o.size);
  if (o.frames < 1) throw ValueError("must be >= 1", {.key = "--frames"});
  if (o.count < 1) throw ValueError("must be >= 1", {.key = "--count"});
  const bool transparent = transparent_background(o.background);
  // Per particle: its state, motion, shading, sort keys and instance data, about 256 B.
  require_memory(256.0 * static_cast<double>(o.count), "--count", fmt::format("{} particles", o.count));
  require_range(o.frame_minutes, 1e-3, 1e6, "--frame-minutes", "the time between frames [min]");
  require_range(o.lod_l0_km, 0, 1e5, "--lod-l0-km", "eq. 13's L0 [km] (0: a quarter of the region)");
  std::vector<double> camera;  // X_KM, Y_KM, ALT_KM, HEADING_DEG, PITCH_DEG; empty: the scene's default
  if (!o.camera.empty()) {
    camera = parse_numbers(o.camera, 5, "--camera", "X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG");
    require_range(camera[2], 0, 1e5, "--camera", "the camera's altitude [km]");
    require_range(camera[4], -90, 90, "--camera", "the camera's pitch [deg]");
  }
  if (!o.wrf.empty() && !o.weather.empty()) throw ValueError("give --weather or --wrf, not both", {.key = "--wrf"});
  particles::ParticleWeather pw;
  if (!o.wrf.empty()) {
    std::optional<particles::LatLonRegion> region;
    if (!o.region.empty()) region = particles::LatLonRegion::parse(o.region, "--region");
    pw = particles::read_wrf(o.wrf, region);
  } else {
    std::vector<weather::WeatherGrid> grids;
    if (o.weather.empty()) grids.push_back(weather::open_weather(default_weather()));
    for (const auto& f : o.weather)  // every valid time of every file
      for (auto& w : weather::open_weather_times(f)) grids.push_back(std::move(w));
    pw = particles::from_weather_grids(
        grids, o.region.empty() ? particles::default_gfs_region : particles::LatLonRegion::parse(o.region, "--region"));
  }
  const int factor = o.refine > 0    ? o.refine
                     : o.wrf.empty() ? particles::refine_factor_for(pw.grid, particles::default_refined_cell_m)
                                     : 1;
  if (o.refine < 0) throw ValueError("must be >= 0", {.key = "--refine"});
  if (factor > 1) {
    // The refined frames: three column fields and four per wind level, 4 B each.
    const double columns = static_cast<double>(pw.grid.cols) * pw.grid.rows * factor * factor;
    require_memory(columns * static_cast<double>(pw.frames.size()) * (3 + 4 * pw.frames.front().wind.levels) * 4.0,
                   "--refine", fmt::format("the weather refined {} x {}", factor, factor));
    pw = particles::refine(pw, factor);
  }
  particles::SceneParams sp;
  sp.generation.count = o.count;
  sp.generation.k = o.k;
  sp.generation.seed = g.seed;
  sp.lod = !o.no_lod;
  sp.lod_params.l0_m = o.lod_l0_km * 1000;
  if (o.transmission == "beer")
    sp.illumination.transmission = particles::Transmission::beer;
  else if (o.transmission != "two-stream")
    throw ValueError("must be 'two-stream' or 'beer', got '" + o.transmission + "'", {.key = "--transmission"});
  spdlog::info("particle weather: {} columns x {} rows of {:.1f} x {:.1f} km, {} time(s), max optical thickness {:.1f}",
               pw.grid.cols, pw.grid.rows, pw.grid.dx_m / 1000, pw.grid.dy_m / 1000, pw.frames.size(),
               pw.frames.front().columns.max_tau());
  const auto t_gen = std::chrono::steady_clock::now();
  particles::ParticleScene scene(std::move(pw), sp);
  const double gen_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_gen).count();
  const auto& w = scene.weather();

  realtime::Camera cam = scene.default_camera();
  if (!camera.empty()) {
    const auto& c = camera;
    const double h = c[3] * earth::deg, p = c[4] * earth::deg;
    cam.position = {c[0] * 1000, c[1] * 1000, c[2] * 1000};
    cam.forward = {std::sin(h) * std::cos(p), std::cos(h) * std::cos(p), std::sin(p)};
  }
  const double t_last = w.frames.back().time_s;
  auto frame_time = [&](int f) {
    if (w.frames.size() > 1 && o.frames > 1) return t_last * f / (o.frames - 1);
    return f * o.frame_minutes * 60.0;
  };

  const fs::path out(o.out);
  realtime::SpriteRenderer renderer(width, height, g.seed);  // before any output: it checks --size
  ensure_directory(out);
  particles::write_columns_netcdf(out / "columns.nc", w, 0);
  if (transparent) renderer.set_background(realtime::SpriteRenderer::Background::transparent);
  AtomicFile csv(out / "frames.csv");
  std::ofstream table(csv.temp_path());
  table << "frame,time_utc,time_s,particles,drawn,motion_ms,lod_ms,light_ms,sort_ms,draw_ms\n";
  Progress progress("particles", static_cast<std::size_t>(o.frames));
  for (int f = 0; f < o.frames; ++f) {
    const double t = frame_time(f);
    const auto t0 = std::chrono::steady_clock::now();
    scene.move_to(t);
    const double motion_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    particles::FrameTimings tm;
    const realtime::PointSprites sprites = scene.sprites(t, cam.position, &tm);
    const realtime::FrameStats st = renderer.draw_points(sprites, cam);
    table << fmt::format("{},{},{:.0f},{},{},{:.2f},{:.2f},{:.2f},{:.2f},{:.2f}\n", f, scene.time_at(t).iso(), t,
                         scene.current().size(), tm.drawn, motion_ms, tm.lod_ms, tm.light_ms, tm.sort_ms,
                         st.milliseconds);
    write_frame_png(out / fmt::format("frame_{:04d}.png", f), renderer, transparent);
    if (!o.no_ply)
      particles::write_particles_ply(out / fmt::format("particles_{:04d}.ply", f), scene.current(), scene.shade_all(t),
                                     w, scene.time_at(t));
    progress.advance();
  }
  csv.commit(table);
  std::cout << fmt::format(
      "particles: {} particles from {} ({} x {} columns) generated in {:.2f} s; {} frames of {}x{} in {}\n",
      scene.initial().size(), w.source, w.grid.cols, w.grid.rows, gen_s, o.frames, width, height, out.string());
  return 0;
}
}  // namespace

// An empty value (`--weather ""`, often an unset shell variable) is never what a user meant: it
// would silently pick the option's default, or write into the working directory for --out. Every
// text option of every subcommand refuses it, except those named in `allowed`, where empty means
// something (bench fly --plot "": no plot).
void reject_empty_values(CLI::App& app, const std::set<std::string>& allowed) {
  const CLI::Validator non_empty(
      [](std::string& value) { return value.empty() ? std::string("an empty value is not allowed") : std::string(); },
      "", "non-empty");
  for (CLI::Option* option : app.get_options())
    if (option->get_type_name() == "TEXT" && !allowed.count(option->get_name())) option->check(non_empty);
  for (CLI::App* sub : app.get_subcommands({})) reject_empty_values(*sub, allowed);
}

int main(int argc, char** argv) {
  // NetCDF-4 writes through HDF5, whose exit-time clean-up closes what is still open. After a
  // file failed to close (a full disk), that clean-up crashed the process after its error
  // message (HDF5 1.10.8): so no clean-up at exit. Every file is closed explicitly before then.
  // Must precede any HDF5 call.
  H5dont_atexit();
  // Under mpirun (several ranks) MPI is initialised for `nephos lbm`; plain runs never touch MPI.
  struct MpiSession {
    bool on;
    MpiSession(int& c, char**& v) : on(app::mpi_launched()) {
      if (on) app::mpi_init(c, v);
    }
    ~MpiSession() {
      if (on) app::mpi_finalize();
    }
  } mpi_session(argc, argv);
  // One line per message, written at once: under mpirun every rank reports (a failure on one
  // rank stops all of them, each with the first failing rank's message), and the lines of
  // ranks other than 0 say which rank they come from.
  auto report = [&](const char* kind, const std::string& message) {
    const std::string who =
        mpi_session.on && app::mpi_rank() > 0 ? fmt::format(" (rank {} of {})", app::mpi_rank(), app::mpi_size()) : "";
    std::cerr << fmt::format("nephos{}: {}: {}\n", who, kind, message) << std::flush;
  };
  CLI::App app{"nephos: real weather data to three-dimensional clouds"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("nephos ") + NEPHOS_VERSION);
  GlobalOptions g;
  app.add_flag("-v,--verbose", g.verbose, "Log debug detail");
  app.add_flag("-q,--quiet", g.quiet, "Log only warnings and errors; no progress bars");
  // CLI11's NonNegativeNumber prints its range as 0 to 1.8e308 in full; and it alone would let
  // --seed -1 through as 2^64 - 1.
  const CLI::Validator non_negative(
      [](std::string& value) {
        return !value.empty() && value[0] == '-' ? std::string("must not be negative, got " + value) : std::string();
      },
      "", "non-negative");
  app.add_option("--threads", g.threads, "Worker threads (0 = all cores)")->check(non_negative);
  app.add_option("--seed", g.seed, "Seed for all randomness (counter-based; results do not depend on threads)")
      ->check(non_negative);

  std::string info_file;
  auto* info = app.add_subcommand("info", "Describe a weather file in nephos's terms, or an lbm checkpoint");
  info->add_option("file", info_file, "GRIB1/GRIB2 file, or a checkpoint of nephos lbm")->required();

  MasksOptions mo;
  auto* masks = app.add_subcommand("masks", "Cloud weather masks (Table 1) as PNGs and CF-NetCDF");
  masks->add_option("--weather", mo.weather, "GRIB file (default: the embedded GFS sample)");
  masks->add_option("--weather-time", mo.weather_time,
                    "Which valid time (ISO 8601 UTC) of a file that holds several (default: its first)");
  masks->add_flag("--synthetic", mo.synthetic, "Use a synthetic atmosphere from --seed instead of a file");
  masks->add_option("--out", mo.out, "Output directory")->capture_default_str();
  masks->add_option("--config", mo.config, "TOML file with [cloud_fraction] and [masks.*] parameters");
  masks->add_option("--png-width", mo.png_width, "Width of the PNG previews [pixels]")
      ->capture_default_str()
      ->check(CLI::Range(16, 16384));

  RenderOptions ro;
  auto* rend = app.add_subcommand("render", "Render 3D fractal clouds from a sensor (GEO, LEO or any camera)");
  rend->add_option("--weather", ro.weather, "GRIB file (default: the embedded GFS sample)");
  rend->add_option("--weather-time", ro.weather_time,
                   "Which valid time (ISO 8601 UTC) of a file that holds several (default: its first)");
  rend->add_flag("--synthetic", ro.synthetic, "Use a synthetic atmosphere from --seed instead of a file");
  rend->add_option("--sensor", ro.sensor, "geo:LON | leo:LAT,LON,ALT_KM,FOV_DEG | camera TOML file")
      ->capture_default_str();
  rend->add_option("--size", ro.size, "Focal-plane array WIDTHxHEIGHT [pixels]")->capture_default_str();
  rend->add_option("--types", ro.types, "Cloud types, comma-separated")->capture_default_str();
  rend->add_option("--bands", ro.bands, "Bands: vis, nir, lwir")->capture_default_str();
  rend->add_option("--steps", ro.steps, "Ray-marching steps per shell")->capture_default_str();
  rend->add_option("--samples", ro.samples,
                   "Rays per pixel, a square k^2 (1, 4, 9, ... 256): the mean of one ray per sub-pixel of a k x k "
                   "grid, each at a hashed point of its sub-pixel (stratified)")
      ->capture_default_str();
  rend->add_flag("--sample-grid", ro.sample_grid,
                 "With --samples: each ray at its sub-pixel's centre (a regular grid) instead of stratified");
  rend->add_option("--texture", ro.texture,
                   "Fractal texture size N (N^3 voxels, power of two 8..1024; default 256 or the config's [textures] "
                   "size)");
  rend->add_option("--displace-hours", ro.displace_hours, "Wind displacement of all fractals [h] (default: per type)");
  rend->add_option("--advance-hours", ro.advance_hours, "Propagate the displacement maps by H hours (per frame)");
  rend->add_option("--frames", ro.frames, "Number of frames (each advanced by --advance-hours)")->capture_default_str();
  rend->add_option("--time", ro.time, "UTC time for the Sun, ISO 8601 (default: the weather's valid time)");
  rend->add_option("--config", ro.config, "TOML with [clouds.*], [textures], [displacement], [masks.*] parameters");
  rend->add_option("--out", ro.out, "Output directory")->capture_default_str();

  LbmOptions lo;
  auto* lbmc = app.add_subcommand("lbm", "Lattice-Boltzmann convective cloud (water model stage)");
  lbmc->add_option("--grid", lo.grid, "Lattice NXxNYxNZ (z up)")->capture_default_str();
  lbmc->add_option("--silos", lo.silos, "Number of initial vapour silos (default 4)");
  lbmc->add_option("--iterations", lo.iterations, "Total water-model steps")->capture_default_str();
  lbmc->add_option("--checkpoint-every", lo.checkpoint_every, "Write out/checkpoint.bin every N steps (0: never)");
  lbmc->add_option("--percolation", lo.percolation, "Percolation refinement K (0: skip)")
      ->capture_default_str()
      ->check(CLI::Range(0, 16));
  lbmc->add_option("--sun", lo.sun, "Sun AZIMUTH,ELEVATION [deg] (azimuth from +x towards +y)")->capture_default_str();
  lbmc->add_option("--size", lo.size, "Rendered image WIDTHxHEIGHT")->capture_default_str();
  lbmc->add_option("--resume", lo.resume, "Continue from a checkpoint file");
  lbmc->add_option("--config", lo.config, "TOML with a [water] table");
  lbmc->add_option("--storage", lo.storage,
                   "Population storage of the water model: fp32 (default) or fp16 (half the memory; see docs/lbm.md)");
  lbmc->add_option("--out", lo.out, "Output directory")->capture_default_str();

  FlyOptions fo;
  auto* fly = app.add_subcommand("fly", "Real-time sprite clouds along a straight, level flight (headless, EGL)");
  add_flight_options(fly, fo);
  fly->add_option("--frames", fo.frames, "Frames (30 per second of flight)")->capture_default_str();
  fly->add_flag("--no-sort-opt", fo.no_sort_opt, "Re-sort every frame instead of only when the view changed");
  fly->add_option("--change", fo.change, "CODE@SECONDS: the weather changes then (clouds form and dissipate)");
  add_background_option(fly, fo.background);
  fly->add_option("--out", fo.out, "Output directory")->capture_default_str();

  FlyOptions vo;
  vo.frames = 0;
  std::string screenshot;
  auto* view = app.add_subcommand("view", "Sprite clouds in a window: fly with the keyboard and mouse (GLFW)");
  add_flight_options(view, vo);  // --no-impostors: start with the ring off (key I toggles it)
  view->add_option("--frames", vo.frames, "Close after N frames of 1/30 s each (0: when the window is closed)")
      ->capture_default_str();
  view->add_option("--screenshot", screenshot, "PNG of the window's last frame, overlay included");

  ParticlesOptions po;
  auto* part = app.add_subcommand("particles", "Particle-system clouds from WRF or GFS (cloud top, optical thickness)");
  part->add_option("--weather", po.weather, "GRIB weather file(s), one per time (default: the embedded GFS sample)");
  part->add_option("--wrf", po.wrf, "WRF output (wrfout NetCDF), all its times");
  part->add_option("--region", po.region, "LAT0,LON0,LAT1,LON1 [deg] (default: GFS 30,-50,65,10; WRF all)");
  part->add_option("--count", po.count, "Particles")->capture_default_str();
  part->add_option("--frames", po.frames, "Frames (spread over the weather's times)")->capture_default_str();
  part->add_option("--frame-minutes", po.frame_minutes, "Minutes between frames when the weather has one time")
      ->capture_default_str();
  part->add_option("--camera", po.camera, "X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG (default: south of the region)");
  part->add_option("--size", po.size, "Frame WIDTHxHEIGHT")->capture_default_str();
  part->add_option("--k", po.k, "Eq. 5's K: selection probability min(1, K tau / tau_max)")->capture_default_str();
  part->add_option("--lod-l0-km", po.lod_l0_km, "Eq. 13's L0 [km] (0: a quarter of the region)")->capture_default_str();
  part->add_flag("--no-lod", po.no_lod, "Draw every particle");
  part->add_option("--transmission", po.transmission, "two-stream or beer")->capture_default_str();
  part->add_option("--refine", po.refine, "Split each weather cell NxN (0: GFS to <= 30 km cells, WRF unchanged)")
      ->capture_default_str();
  part->add_flag("--no-ply", po.no_ply, "Do not write the particle set as PLY");
  add_background_option(part, po.background);
  part->add_option("--out", po.out, "Output directory")->capture_default_str();

  auto* bench = app.add_subcommand("bench", "Benchmarks that print measured figures beside their anchors");
  bench->require_subcommand(1);
  bench::RenderBenchOptions rbo;
  auto* bench_render = bench->add_subcommand("render", "Table 3 configurations of the fractal renderer");
  bench_render->add_option("--type", rbo.type, "Cloud type to render")->capture_default_str();
  bench_render->add_option("--repeat", rbo.repeat, "Timed repetitions per configuration (median reported)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  bench_render->add_flag("--quick", rbo.quick, "Smaller images (for CI smoke runs); figures not comparable");
  bench::FlyBenchOptions fbo;
  auto* bench_fly = bench->add_subcommand("fly", "Sprite-cloud frame times for the thesis's test matrix");
  bench_fly
      ->add_option("--frames", fbo.frames,
                   "Frames per case (600: the thesis's 20-second tests at 30 frames per second)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  bench_fly->add_option("--tests", fbo.tests, "Which of the thesis's tests A-E to run (letters, e.g. E)")
      ->capture_default_str();
  bench_fly->add_option("--plot", fbo.plot, "PNG bar plot of p95 frame times (empty: none)")->capture_default_str();
  bench_fly
      ->add_option("--paired-block", fbo.paired_block,
                   "Test E's paired measure: frames per block of each renderer in turn (1: frame by frame)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  bench::ParticlesBenchOptions pbo;
  auto* bench_part =
      bench->add_subcommand("particles", "Particle generation rate and frame times, with and without LOD");
  bench_part->add_option("--frames", pbo.frames, "Frames per case (median reported)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  bench_part
      ->add_option("--max-count", pbo.max_count,
                   "Largest particle count: 100000 or more (10^5 and 10^6 by default; 10^5 alone below 10^6)")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{100000}, std::size_t{1000000000}));
  bench::LbmBenchOptions lbo;
  auto* bench_lbm = bench->add_subcommand("lbm", "Lattice-Boltzmann kernels beside the memory roofline");
  bench_lbm->add_option("--size", lbo.size, "Lattice edge (N^3 cells, 8..1024)")
      ->capture_default_str()
      ->check(CLI::Range(8, 1024));
  bench_lbm->add_option("--repeat", lbo.repeat, "Timed repetitions (median reported)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  bench_lbm
      ->add_option(
          "--kernels", lbo.kernels,
          "Comma-separated subset of bgk, water, water16 (FP16 storage), percolation, lighting, raycast (the last "
          "three run together)")
      ->capture_default_str();

  reject_empty_values(app, {"--plot"});
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : exit_input_error;
  }

  try {
    init_logging(g.quiet ? Verbosity::quiet : g.verbose ? Verbosity::verbose : Verbosity::normal);
    Progress::set_enabled(!g.quiet);
    set_threads(g.threads);
    remove_temporaries_on_interrupt();  // Ctrl-C or kill leaves no NAME.tmpPID behind
    if (*info) {
      std::cout << (lbm::WaterModel::is_checkpoint(info_file) ? lbm::WaterModel::describe_checkpoint(info_file)
                                                              : weather::describe_weather_file(info_file));
      return 0;
    }
    if (*masks) return run_masks(mo, g);
    if (*rend) return run_render(ro, g);
    if (*bench_render) return bench::run_render_bench(rbo, g.seed);
    if (*lbmc) return run_lbm(lo, g);
    if (*fly) return run_fly(fo, g);
    if (*view) return run_view_command(vo, screenshot, g);
    if (*bench_lbm) return bench::run_lbm_bench(lbo, g.seed);
    if (*bench_fly) return bench::run_fly_bench(fbo, g.seed);
    if (*part) return run_particles(po, g);
    if (*bench_part) return bench::run_particles_bench(pbo, g.seed);
  } catch (const Error& e) {
    report("error", e.what());
    return exit_input_error;
  } catch (const std::bad_alloc&) {
    // The commands check their big allocations against the machine's memory first; this is
    // what is left when the memory other programs hold makes the difference.
    report("error",
           "out of memory (other programs may hold what this run needs; try a smaller --size, --grid, --texture or "
           "--count)");
    return 1;
  } catch (const std::exception& e) {
    report("internal error", e.what());
    return 1;
  }
  return 0;
}
