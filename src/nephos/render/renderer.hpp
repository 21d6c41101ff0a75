#pragma once
// The global fractal-cloud renderer (the fractal-cloud paper, section 2 and Figure 1): for every pixel, Earth
// occlusion, intersection with each cloud type's shell, a ray march with N steps, the first
// level-set crossing refined by bisection, the surface normal from the cloud-function
// gradient, and the cloud depth integrated along the rest of the shell; then the section 2.3
// radiometry per band and front-to-back compositing of the cloud types.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "nephos/clouds/cloud_model.hpp"
#include "nephos/core/time.hpp"
#include "nephos/earth/sun.hpp"
#include "nephos/optics/optics.hpp"
#include "nephos/render/sensor.hpp"
#include "nephos/weather/weather_grid.hpp"

namespace nephos::render {

struct RenderParams {
  int steps = 25;                         ///< ray-marching steps through a shell (--steps)
  int bisection_iterations = 7;           ///< at most this many halvings of the first crossing (step / 128)
  double indirect_fraction = 0.3;         ///< share of scattered sunlight re-emitted diffusely by all facets
  double surface_temperature_k = 288.15;  ///< the ground's temperature without weather (open sea)
  /// The atmosphere between the scene and the sensor: gases, Rayleigh scattering and the air's
  /// emission (atmosphere::clear_sky_column per weather node). false: a vacuum, for comparison.
  bool atmosphere = true;
  /// Direct sunlight attenuated through the cloud shells on its way to the ground and to lower
  /// clouds. false (--no-shadows): every point lit as if no cloud stood between it and the Sun.
  bool shadows = true;
  /// Anti-aliasing: each ray's cone (a pixel's, or with k > 1 a sub-pixel's, angle) filters the
  /// fractal detail finer than its footprint (march_shell, CloudShell::classify_filtered).
  /// false (--no-filter): point samples, the fractal model itself, aliased at coarse pixels.
  bool filter = true;
  /// k: each pixel is sampled on a k x k grid of sub-pixel rays (--samples k^2, 1..16 per
  /// axis) and its radiance is their mean, the detector's integral over its footprint.
  int samples_per_axis = 1;
  /// With k > 1: each sub-pixel's ray at a point hashed from sample_seed, the pixel and the
  /// sub-pixel, uniform within the sub-pixel (stratified sampling: the periodic fractal
  /// textures' moire becomes fine noise), instead of at the sub-pixel's centre (a regular grid:
  /// exactly the area average of the image rendered k times finer). --sample-grid sets false.
  bool stratified_samples = true;
  std::uint64_t sample_seed = 0;
  /// The thermal bands' brightness temperatures among the outputs (RenderImage); false: their
  /// radiances alone, as an L1b file holds them (its readers convert with its Planck
  /// coefficients), 4 B less per pixel and band.
  bool brightness_temperatures = true;
  /// The per-pixel cloud fields and geolocation among the outputs (RenderImage's cloud top,
  /// optical depth, type, fraction, latitude and longitude); false: radiances (and brightness
  /// temperatures) alone, as an L1b file holds them, 21 B less per pixel.
  bool cloud_fields = true;
  std::vector<std::string> bands{"vis", "nir", "lwir"};

  /// Set `steps` (1..10000) and, from a count of rays per pixel that must be a square k^2 of
  /// 1..256, `samples_per_axis`; ValueError naming `key` otherwise.
  void set_steps(int n, const std::string& key);
  /// Set `bands`: at least one, each a known band (optics::bands()) listed once; ValueError
  /// naming `key` otherwise.
  void set_bands(const std::vector<std::string>& names, const std::string& key);
  void set_rays_per_pixel(int rays, const std::string& key);
};

/// Per-pixel results, row-major from the top-left pixel. The brightness temperatures and the cloud
/// fields are empty where RenderParams leaves them out.
struct RenderImage {
  int width = 0, height = 0;
  std::vector<std::string> bands;
  std::vector<std::vector<float>> radiance;                ///< per band [W m^-2 sr^-1 um^-1]
  std::vector<std::vector<float>> brightness_temperature;  ///< per band [K]; empty for solar bands
  std::vector<float> cloud_top_altitude_m;                 ///< nearest cloud surface; NaN where none
  std::vector<float> cloud_optical_depth;                  ///< visible optical depth along the line of sight, all types
  std::vector<std::int8_t> cloud_type;                     ///< nearest type (0..3), -1 none
  std::vector<float> cloud_fraction;                       ///< share of the pixel's rays that meet cloud
  std::vector<float> latitude_deg, longitude_deg;          ///< nearest cloud or Earth point; NaN for space
  /// Per cloud type, the time spent tracing it [s]: its threads' time over their count.
  std::vector<std::pair<std::string, double>> seconds_per_type;
  /// Per shell, in the order of seconds_per_type: the rays marched, those whose path through
  /// the shell the empty-space skip left possible cloud on (all sub-pixel rays counted). A
  /// shell's time follows this count, not the field of view (bench render).
  std::vector<std::uint64_t> marched_rays_per_type;
  /// Per stage of the rows' work (render_stage_names(), in order), its threads' time over their
  /// count [s]: where a render's time goes, whatever the cloud type.
  std::vector<std::pair<std::string, double>> seconds_per_stage;
  double seconds_atmosphere = 0;  ///< building the atmosphere's and ground's tables for this sensor and Sun
  double seconds_outputs = 0;     ///< allocating the outputs' arrays and touching their pages first
};

/// The brightness temperatures [K] of n radiances [W m^-2 sr^-1 um^-1] of a thermal band: the
/// inverse of its band-mean Planck function (100-400 K), as RenderImage holds them.
void brightness_temperatures(const optics::Band& band, const float* radiance, std::size_t n, float* out);

/// The stages of a row's work that RenderImage::seconds_per_stage times: the rays ("rays"), each
/// type's march to its hits ("march"), the hits' shadow rays through the other types
/// ("hit_shadows") and their shading ("hit_shading"), each pixel's layers added up ("layers"), the
/// ground's shadow rays ("ground_shadows"), the ground's or sky's radiance behind the layers
/// ("ground_and_sky") and the brightness temperatures ("brightness_temperatures").
const std::vector<std::string>& render_stage_names();

/// What one ray finds in one shell.
struct ShellHit {
  bool hit = false;
  double t = 0;                  ///< distance to the first surface [m]
  earth::Vec3 position, normal;  ///< outward unit normal
  double depth_m = 0;            ///< cloud depth along the line of sight after the surface
  /// The share of the pixel's cone that meets the cloud (filtered marches; 1 otherwise).
  double coverage = 1;
  /// The share of the surface's mean squared gradient that `normal` holds: filtered,
  /// |g|^2 / (|g|^2 + the sub-pixel detail's, CloudShell::detail_gradient_variance) of the
  /// footprint's gradient g, 0 for a partial hit (cloud smaller than the footprint); 1 for a point
  /// sample.
  double coherence = 1;
  bool marched = false;  ///< the empty-space skip left possible cloud on the path (every hit was)
};

/// The mean of max(0, n.s) over the visible area of a surface whose normals n face every way
/// (sub-pixel cloud detail), seen along v with the Sun towards s, cos_phase = -v.s: a Lambertian
/// sphere's mean over its disc, (2/3)(sin a + (pi - a) cos a) / pi at phase angle a (Russell
/// 1916, Astrophys. J. 43, 173: the Lambert sphere's phase law; 2/3, its mean cosine at full
/// phase).
double facets_facing_every_way(double cos_phase);

/// Below this share of a pixel's cone in cloud, a filtered march's partial hit is kept at random
/// in proportion (march_shell).
constexpr double roulette_coverage = 0.3;

/// Marches one shell along o + t d up to t_max (the Earth's surface or infinity).
ShellHit march_shell(const clouds::CloudShell& shell, const earth::Vec3& o, const earth::Vec3& d, double t_max,
                     int steps, int bisection_iterations, double spread = 0);
/// Marches n rays o + t d[i] (t < t_max[i]) through one shell together, into hits[i]: the
/// same result as n single-ray calls, faster (the rays' texture fetches overlap).
/// spread > 0: the pixel's cone, spread t metres wide at distance t, filters the cloud
/// (CloudShell::classify_filtered): the first surface is where the filtered cloud function
/// crosses the threshold, or where it comes nearest (a partial hit; below roulette_coverage, kept
/// with probability coverage / roulette_coverage, at that coverage);
/// coverage is the chance that the path meets cloud (clouds::PathCoverage), depth the expected
/// length of cloud over it.
/// @param lit_by  where given, the surface normal (and coherence) is found only for the hits
///   this direction lights from above their horizon (the Sun's, for the sunlit facets: the only
///   reader of the normal); the others' are those of a partial hit (-d, 0). A zero vector: no
///   hit's.
void march_shell(const clouds::CloudShell& shell, const earth::Vec3& o, const earth::Vec3* d, const double* t_max,
                 std::size_t n, int steps, int bisection_iterations, ShellHit* hits, double spread = 0,
                 const std::optional<earth::Vec3>& lit_by = std::nullopt);

/// Where the ray of sub-pixel (i, j) of a k x k grid crosses pixel (x, y) [pixels from its
/// top-left corner, 0..1 each]: the sub-pixel's centre, or with `stratified` a point uniform in
/// the sub-pixel hashed from seed, pixel and sub-pixel (the centre sub-pixel of an odd k stays
/// at the pixel centre).
std::pair<double, double> sub_pixel_offset(int x, int y, int i, int j, int k, bool stratified, std::uint64_t seed);

/// Renders all shells of `scene` from `sensor`. `weather` (optional) gives the surface
/// temperature for the thermal background. With params.samples_per_axis = k > 1 every pixel
/// is the mean of k x k rays, one through each sub-pixel of a k x k grid (at its centre, the
/// area average of the image rendered k times finer, or stratified: see RenderParams;
/// bit-identical whatever the thread count either way): radiance and optical depth are their means
/// (brightness temperature is that of the mean radiance), cloud_fraction the share of them
/// that meet cloud, cloud_top_altitude the mean over those, cloud_type the most frequent type
/// among them (the lower type number on a tie), and latitude/longitude those of the sub-pixel
/// ray nearest the pixel centre (the centre itself for odd k).
RenderImage render(const clouds::CloudScene& scene, const Sensor& sensor, const earth::SunPosition& sun,
                   const RenderParams& params, const weather::WeatherGrid* weather = nullptr);

/// About the most memory render() holds for a width x height image [bytes]: its outputs (21 B
/// per pixel, 4 more per band and per thermal band), each thread's row of layers, and with
/// k x k rays per pixel the sums and one sub-pixel image (~47 B + 12 B per band more). Checked
/// against the machine's memory before any work.
double render_memory_bytes(int width, int height, const RenderParams& params);

}  // namespace nephos::render
