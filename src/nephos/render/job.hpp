#pragma once
// `nephos render` as a typed request and its runner: the weather, the clouds built from it
// once (RenderScene), views of them from any sensor, and the frames written to disk. The
// command line and the Python module fill in these requests; every default, limit and check
// lives here. Errors name the request's fields ("size", "samples", ...), which the command
// line shows as its options and Python as its keyword arguments.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "nephos/clouds/cloud_model.hpp"
#include "nephos/core/time.hpp"
#include "nephos/earth/sun.hpp"
#include "nephos/render/outputs.hpp"
#include "nephos/render/renderer.hpp"
#include "nephos/render/sensor.hpp"
#include "nephos/weather/source.hpp"

namespace nephos::render {

/// The clouds of a weather state, built once and rendered from any number of views.
struct SceneRequest {
  std::vector<weather::CloudType> types = all_cloud_types();
  int texture = 0;                       ///< fractal texture edge [voxels]; 0: the configuration's (256)
  std::optional<double> displace_hours;  ///< wind displacement of every fractal [h]; empty: per type
  std::filesystem::path config;          ///< TOML: [clouds.*], [textures], [displacement], [masks.*]
  std::uint64_t seed = 1;                ///< textures and sub-pixel rays

  static std::vector<weather::CloudType> all_cloud_types();
};

/// One view of a scene: sensor, image, bands and sampling.
struct ViewRequest {
  std::string sensor = "geo:-75.2";  ///< "geo:LON", "leo:LAT,LON,ALT_KM,FOV_DEG" or a camera TOML file
  int width = 1000, height = 1000;   ///< focal-plane array [pixels]
  std::vector<std::string> bands{"vis", "nir", "lwir"};
  int steps = 25;            ///< ray-marching steps per shell
  int samples = 1;           ///< rays per pixel, a square k^2 (1..256)
  bool sample_grid = false;  ///< sub-pixel rays at the sub-pixels' centres, not stratified
  bool atmosphere = true;    ///< gases, Rayleigh scattering and the air's emission (false: a vacuum)
  bool shadows = true;       ///< clouds shade the ground and lower clouds from direct sunlight
  bool filter = true;        ///< fractal detail finer than a pixel filtered (false: point samples, aliased)
  /// UTC of the view (the Sun's, and the L1b files'); empty: the scene's (RenderScene::time())
  std::optional<UtcTime> time;
  std::string scene = "full";    ///< abi sensors: "full", "conus" or "meso:LAT,LON" (width, height: the sector's)
  int abi_step = 1;              ///< abi sensors: the fixed grid coarsened by this factor
  double abi_resolution_km = 0;  ///< abi sensors: 0.5, 1 or 2; 0: the coarsest native one of the bands
  bool brightness_temperatures = true;  ///< the thermal bands' brightness temperatures too (false: radiances alone)
  bool cloud_fields = true;  ///< the cloud fields and geolocation too (false: radiances and temperatures alone)

  /// The fixed grid's resolution of an abi sensor's view [km]: abi_resolution_km, or the coarsest
  /// native resolution of the bands.
  double resolution_km() const;
};

/// A view rendered: the image and what it was rendered with.
struct RenderedView {
  RenderImage image;
  Sensor sensor;
  UtcTime time;
  earth::SunPosition sun;
};

class RenderScene {
 public:
  /// Masks, textures, winds and displacement maps of `weather` for `request`. Errors name
  /// "texture", "displace_hours" or the configuration's keys.
  RenderScene(weather::WeatherGrid weather, const SceneRequest& request);
  /// Moves the clouds with the wind by `hours` (|hours| <= 240; ValueError naming `key`), and
  /// the scene's time with them.
  void advance(double hours, const std::string& key = "hours");
  /// The time the scene shows: the weather's valid time plus the hours the wind has carried it.
  UtcTime time() const;
  /// Renders one view. The renderer's memory plus `extra_bytes_per_pixel` (what the caller
  /// keeps of the image besides) is checked against the machine's first (ResourceError naming
  /// "size").
  RenderedView render(const ViewRequest& view, double extra_bytes_per_pixel = 0) const;
  /// The metadata render.nc records for a view of this scene.
  FrameMetadata metadata(const ViewRequest& view, const RenderedView& rendered) const;

  const weather::WeatherGrid& weather() const { return weather_; }
  const std::vector<weather::CloudType>& types() const { return types_; }
  const clouds::CloudModelParams& params() const { return params_; }

 private:
  weather::WeatherGrid weather_;  // the scene's displacement and the renderer's surface temperatures
  clouds::CloudModelParams params_;
  clouds::CloudScene scene_;
  std::vector<weather::CloudType> types_;
  std::uint64_t seed_;
  double advanced_hours_ = 0;  // the sum of advance()'s hours
};

/// The renderer's parameters of a view: bands, steps, rays per pixel; ValueError naming the field.
RenderParams render_params(const ViewRequest& view, std::uint64_t seed);

/// `nephos render`: a scene from a weather source, `frames` frames each `advance_hours` of wind
/// displacement after the last, written as render.nc, render.exr and a PNG per band into
/// `out` (or out/frame_NNN with several frames). Each frame's time is the scene's, or, where
/// the view gives one, that time for the first frame and `advance_hours` more for each next.
struct RenderRequest {
  weather::WeatherSource weather;
  SceneRequest scene;
  ViewRequest view;
  double advance_hours = 0;  ///< wind displacement before the first frame and between frames [h]
  int frames = 1;
  std::filesystem::path out = "out";
  /// "netcdf": render.nc, render.exr and PNG previews; "abi-l1b": one ABI L1b file per band
  /// (abi sensors; each band on its native resolution's grid, coarsened by abi_step).
  std::string format = "netcdf";
};

/// Runs `request`; `on_frame` (optional) sees each frame after it is written, with its folder
/// and the scene.
/// Everything is checked before any work.
void run_render(const RenderRequest& request,
                const std::function<void(int frame, const std::filesystem::path& dir, const RenderScene&,
                                         const RenderedView&)>& on_frame = {});

}  // namespace nephos::render
