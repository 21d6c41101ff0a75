// nephos particles: particle-system clouds from WRF or GFS cloud top and optical thickness,
// moved, thinned with distance, lit and drawn (docs/particles.md).
#include <fmt/format.h>

#include <array>
#include <cstdint>
#include <iostream>
#include <memory>
#include <tuple>

#include "cli_support.hpp"
#include "command.hpp"
#include "nephos/core/parse.hpp"
#include "nephos/particles/job.hpp"
#include "nephos/realtime/gl/flight_job.hpp"

namespace nephos::app {

namespace {

// The command's options; their defaults are the request's (particles/job.hpp).
struct ParticlesOptions {
  inline static const particles::ParticlesRequest defaults{};
  std::vector<std::string> weather;
  std::string wrf;
  std::string region;  // default: the whole WRF domain; for GFS the North Atlantic and Europe
  std::uint64_t count = defaults.count;
  int frames = defaults.frames;
  double frame_minutes = defaults.frame_minutes;
  std::string camera;  // X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG; default: south of the region
  std::string size = fmt::format("{}x{}", defaults.width, defaults.height);
  double k = defaults.k;
  double lod_l0_km = defaults.lod_l0_km;
  bool no_lod = !defaults.lod;
  std::string transmission = "two-stream";
  int refine = defaults.refine;
  bool no_ply = !defaults.ply;
  std::string background = "sky";  // or "transparent"
  std::string out = defaults.out.string();
};

// The options as the runner's request (particles/job.hpp), which checks them.
particles::ParticlesRequest request_from(const ParticlesOptions& o, const GlobalOptions& g) {
  particles::ParticlesRequest r;
  r.weather.assign(o.weather.begin(), o.weather.end());
  r.wrf = o.wrf;
  if (!o.region.empty()) r.region = particles::LatLonRegion::parse(o.region, "region");
  r.count = o.count;
  r.frames = o.frames;
  r.frame_minutes = o.frame_minutes;
  if (!o.camera.empty()) {
    const std::vector<double> c = parse_numbers(o.camera, 5, "camera", "X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG");
    r.camera = std::array<double, 5>{c[0], c[1], c[2], c[3], c[4]};
  }
  std::tie(r.width, r.height) = parse_size(o.size, "size");
  r.k = o.k;
  r.lod_l0_km = o.lod_l0_km;
  r.lod = !o.no_lod;
  r.transmission = particles::transmission_named(o.transmission, "transmission");
  r.refine = o.refine;
  r.ply = !o.no_ply;
  r.transparent = realtime::transparent_background(o.background);
  r.out = o.out;
  r.seed = g.seed;
  return r;
}

int run_particles(const ParticlesOptions& o, const GlobalOptions& g) {
  const particles::ParticlesRequest r = request_from(o, g);
  const particles::ParticlesResult res = particles::run_particles(r);
  std::cout << fmt::format(
      "particles: {} particles from {} ({} x {} columns) generated in {:.2f} s; {} frames of {}x{} in {}\n",
      res.particles, res.source, res.cols, res.rows, res.generation_s, r.frames, r.width, r.height, r.out.string());
  return 0;
}
}  // namespace

Command add_particles_command(CLI::App& app, const GlobalOptions& g) {
  auto o = std::make_shared<ParticlesOptions>();
  auto* part = app.add_subcommand("particles", "Particle-system clouds from WRF or GFS (cloud top, optical thickness)");
  part->add_option("--weather", o->weather, "GRIB weather file(s), one per time (default: the embedded GFS sample)");
  part->add_option("--wrf", o->wrf, "WRF output (wrfout NetCDF), all its times");
  part->add_option("--region", o->region, "LAT0,LON0,LAT1,LON1 [deg] (default: GFS 30,-50,65,10; WRF all)");
  part->add_option("--count", o->count, "Particles")->capture_default_str();
  part->add_option("--frames", o->frames, "Frames (spread over the weather's times)")->capture_default_str();
  part->add_option("--frame-minutes", o->frame_minutes, "Minutes between frames when the weather has one time")
      ->capture_default_str();
  part->add_option("--camera", o->camera, "X_KM,Y_KM,ALT_KM,HEADING_DEG,PITCH_DEG (default: south of the region)");
  part->add_option("--size", o->size, "Frame WIDTHxHEIGHT")->capture_default_str();
  part->add_option("--k", o->k, "Eq. 5's K: selection probability min(1, K tau / tau_max)")->capture_default_str();
  part->add_option("--lod-l0-km", o->lod_l0_km,
                   "Eq. 13's L0 [km] (0: 60 % of the camera's distance to the region's centre)")
      ->capture_default_str();
  part->add_flag("--no-lod", o->no_lod, "Draw every particle");
  part->add_option("--transmission", o->transmission, "two-stream or beer")->capture_default_str();
  part->add_option("--refine", o->refine, "Split each weather cell NxN (0: GFS to <= 30 km cells, WRF unchanged)")
      ->capture_default_str();
  part->add_flag("--no-ply", o->no_ply, "Do not write the particle set as PLY");
  part->add_option("--background", o->background,
                   "sky, or transparent: RGBA frames (alpha = cloud coverage) to composite over a map or terrain")
      ->capture_default_str();
  part->add_option("--out", o->out, "Output directory")->capture_default_str();
  return {part, [o, &g] { return run_particles(*o, g); }};
}

}  // namespace nephos::app
