#include "nephos/render/job.hpp"

#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/render/abi_l1b.hpp"
#include "nephos/weather/masks.hpp"

namespace nephos::render {

std::vector<weather::CloudType> SceneRequest::all_cloud_types() {
  std::vector<weather::CloudType> all;
  for (int t = 0; t < weather::cloud_type_count; ++t) all.push_back(static_cast<weather::CloudType>(t));
  return all;
}

namespace {
// A view's bands by their own names, "all" spelled out (RenderParams::set_bands: ValueError
// naming "bands" for an unknown or repeated one).
std::vector<std::string> band_names(const std::vector<std::string>& bands) {
  RenderParams rp;
  rp.set_bands(bands, "bands");
  return rp.bands;
}
}  // namespace

double ViewRequest::resolution_km() const {
  if (abi_resolution_km > 0) return abi_resolution_km;
  double r = 0.5;
  for (const auto& b : band_names(bands)) r = std::max(r, abi_native_resolution_km(optics::band(b).abi_band));
  return r;
}

RenderParams render_params(const ViewRequest& view, std::uint64_t seed) {
  RenderParams rp;
  rp.set_bands(view.bands, "bands");
  rp.set_steps(view.steps, "steps");
  rp.set_rays_per_pixel(view.samples, "samples");
  rp.stratified_samples = !view.sample_grid;
  rp.atmosphere = view.atmosphere;
  rp.shadows = view.shadows;
  rp.filter = view.filter;
  rp.brightness_temperatures = view.brightness_temperatures;
  rp.cloud_fields = view.cloud_fields;
  rp.sample_seed = seed;
  return rp;
}

namespace {

// The cloud model's parameters of a scene request: the configuration, then the request's
// texture size and displacement.
clouds::ModelConfig scene_config(const SceneRequest& request) {
  clouds::ModelConfig c = clouds::read_model_config(request.config);
  c.cloud.set_texture_size(request.texture != 0 ? request.texture : c.cloud.texture_size, "texture");
  if (request.displace_hours) c.cloud.set_displace_hours(*request.displace_hours, "displace_hours");
  return c;
}

// A view's sensor and renderer parameters, checked: image size, bands, steps, rays, sensor and
// memory (the renderer's plus extra_bytes_per_pixel).
std::pair<Sensor, RenderParams> checked_view(const ViewRequest& view, std::uint64_t seed,
                                             double extra_bytes_per_pixel) {
  const bool abi = view.sensor.rfind("abi:", 0) == 0;
  if (!abi) require_image_size(view.width, view.height, "size");
  RenderParams rp = render_params(view, seed);
  Sensor sensor = abi ? parse_sensor(view.sensor, 0, 0, view.scene, view.resolution_km(), view.abi_step)
                      : parse_sensor(view.sensor, view.width, view.height);
  if (!abi && view.scene != "full") throw ValueError("a sector is for abi sensors only", {.key = "scene"});
  if (!abi && view.abi_step != 1) throw ValueError("a fixed-grid step is for abi sensors only", {.key = "abi_step"});
  if (abi && std::max(sensor.width, sensor.height) > max_image_edge_px)
    throw ValueError(fmt::format("the {} sector at {:g} km is {}x{} pixels, more than {} a side: coarsen it",
                                 view.scene, view.resolution_km(), sensor.width, sensor.height, max_image_edge_px),
                     {.key = "abi_step"});
  const int w = sensor.width, h = sensor.height;
  require_memory(render_memory_bytes(w, h, rp) + extra_bytes_per_pixel * w * static_cast<double>(h), "size",
                 fmt::format("a {}x{} image with {} rays per pixel", w, h, view.samples));
  return {std::move(sensor), std::move(rp)};
}

// What the writers hold beside the image [B per pixel]: the previews' byte per pixel and channel
// (render.nc's format), or two bands' packed Rad (int16) and DQF (int8) and the Earth mask
// (abi-l1b: a file is written while the next band is packed).
double writer_bytes_per_pixel(const std::string& format) { return format == "abi-l1b" ? 2 * (2 + 1) + 1 : 3; }

// The views a frame of `request` renders: its view, or for ABI L1b output one per native
// resolution of its bands (finest first), each on that resolution's grid, of radiances alone
// (an L1b file's readers find brightness temperatures with its Planck coefficients).
std::vector<ViewRequest> frame_views(const RenderRequest& request) {
  if (request.format == "netcdf") return {request.view};
  if (request.format != "abi-l1b") throw ValueError("'" + request.format + "': netcdf or abi-l1b", {.key = "format"});
  if (request.view.sensor.rfind("abi:", 0) != 0)
    throw ValueError("abi-l1b needs an ABI sensor (abi:east, abi:west or abi:LON)", {.key = "format"});
  const std::vector<std::string> bands = band_names(request.view.bands);
  std::vector<ViewRequest> views;
  for (double res : {0.5, 1.0, 2.0}) {
    ViewRequest v = request.view;
    v.bands.clear();
    for (const auto& b : bands)
      if (abi_native_resolution_km(optics::band(b).abi_band) == res) v.bands.push_back(b);
    v.abi_resolution_km = res;
    v.brightness_temperatures = false, v.cloud_fields = false;  // what an L1b file holds: radiances
    if (!v.bands.empty()) views.push_back(std::move(v));
  }
  return views;
}

}  // namespace

RenderScene::RenderScene(weather::WeatherGrid weather, const SceneRequest& request)
    : weather_(std::move(weather)), types_(request.types), seed_(request.seed) {
  if (types_.empty()) throw ValueError("no cloud type: at least one", {.key = "types"});
  const clouds::ModelConfig c = scene_config(request);
  params_ = c.cloud;
  const weather::WeatherMasks masks = weather::compute_masks(weather_, c.masks);
  scene_ = clouds::build_scene(weather_, masks, params_, types_, seed_);
}

void RenderScene::advance(double hours, const std::string& key) {
  require_range(hours, -clouds::CloudModelParams::max_displace_hours, clouds::CloudModelParams::max_displace_hours, key,
                "the advance [h]");
  clouds::advance_scene(scene_, hours, params_);
  advanced_hours_ += hours;
}

UtcTime RenderScene::time() const {
  return weather_.metadata().valid_time.plus_seconds(std::round(advanced_hours_ * 3600.0));
}

RenderedView RenderScene::render(const ViewRequest& view, double extra_bytes_per_pixel) const {
  auto [sensor, rp] = checked_view(view, seed_, extra_bytes_per_pixel);
  const UtcTime time = view.time.value_or(this->time());
  const earth::SunPosition sun = earth::sun_position(time);
  spdlog::info("sensor: {}", sensor.description);
  spdlog::info("time {}: subsolar point {:.2f}, {:.2f}", time.iso(), sun.subsolar_lat_deg, sun.subsolar_lon_deg);
  RenderImage image = render::render(scene_, sensor, sun, rp, &weather_);
  return {std::move(image), std::move(sensor), time, sun};
}

FrameMetadata RenderScene::metadata(const ViewRequest& view, const RenderedView& rendered) const {
  FrameMetadata meta{weather_.metadata().source,
                     rendered.sensor.description,
                     rendered.time.iso(),
                     rendered.sun.subsolar_lat_deg,
                     rendered.sun.subsolar_lon_deg,
                     seed_,
                     view.steps,
                     params_.texture_size,
                     view.samples,
                     view.samples == 1  ? "centre"
                     : view.sample_grid ? "grid"
                                        : "stratified",
                     {}};
  for (auto t : types_) meta.types.emplace_back(weather::name(t));
  return meta;
}

void run_render(
    const RenderRequest& request,
    const std::function<void(int, const std::filesystem::path&, const RenderScene&, const RenderedView&)>& on_frame) {
  // Everything that needs no weather is checked first, so that bad input fails fast and
  // writes nothing: the view (with the previews' byte per pixel and channel), the frame
  // count and advance, the scene's parameters.
  const std::vector<ViewRequest> views = frame_views(request);
  const double writer_bytes = writer_bytes_per_pixel(request.format);
  for (const ViewRequest& v : views) checked_view(v, request.scene.seed, writer_bytes);
  if (request.frames < 1) throw ValueError("must be >= 1", {.key = "frames"});
  require_range(request.advance_hours, -clouds::CloudModelParams::max_displace_hours,
                clouds::CloudModelParams::max_displace_hours, "advance_hours", "the advance per frame [h]");
  scene_config(request.scene);
  if (request.scene.types.empty()) throw ValueError("no cloud type: at least one", {.key = "types"});

  RenderScene scene(weather::load_weather(request.weather, request.scene.seed), request.scene);
  if (request.advance_hours != 0) scene.advance(request.advance_hours, "advance_hours");
  ensure_directory(request.out);
  for (int frame = 0; frame < request.frames; ++frame) {
    if (frame > 0) scene.advance(request.advance_hours, "advance_hours");
    const std::filesystem::path dir =
        request.frames == 1 ? request.out : request.out / fmt::format("frame_{:03d}", frame);
    ensure_directory(dir);
    for (ViewRequest v : views) {
      if (v.time) v.time = v.time->plus_seconds(std::round(frame * request.advance_hours * 3600.0));
      const RenderedView view = scene.render(v, writer_bytes);
      if (request.format == "abi-l1b") {
        const auto t0 = std::chrono::steady_clock::now();
        const auto paths = write_abi_l1b(dir, view.image, *view.sensor.fixed_grid, view.time, view.sun.distance_au);
        for (const auto& path : paths) spdlog::info("wrote {}", path.string());
        spdlog::info("{} L1b files in {:.1f} s", paths.size(),
                     std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      } else {
        write_render_netcdf(dir / "render.nc", view.image, scene.metadata(v, view));
        write_render_exr(dir / "render.exr", view.image);
        write_render_previews(dir, view.image);
      }
      if (on_frame) on_frame(frame, dir, scene, view);
    }
  }
}

}  // namespace nephos::render
