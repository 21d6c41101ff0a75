#pragma once
// `nephos particles` as a typed request and its runner: particle-system clouds from GFS (GRIB)
// or WRF, generated, moved over the weather's times, thinned with distance, lit and drawn
// headless (OpenGL ES), written as frame PNGs, per-frame PLY particle sets, columns.nc and
// frames.csv. The command line and the Python module fill in the request; errors name its
// fields ("count", "region", "camera", ...).
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "nephos/particles/cloud_columns.hpp"
#include "nephos/particles/particle_system.hpp"

namespace nephos::particles {

struct ParticlesRequest {
  std::vector<std::filesystem::path>
      weather;                ///< GRIB files, every valid time of each; none (and no wrf): the embedded GFS sample
  std::filesystem::path wrf;  ///< WRF output (wrfout NetCDF), all its times; not with `weather`
  std::optional<LatLonRegion> region;  ///< empty: default_gfs_region for GFS, the whole domain for WRF
  std::uint64_t count = 200000;        ///< particles generated
  int frames = 4;                      ///< frames, spread over the weather's times
  double frame_minutes = 30;           ///< between frames when the weather has one time [min]
  std::optional<std::array<double, 5>>
      camera;                      ///< X [km], Y [km], altitude [km], heading, pitch [deg]; empty: south of the region
  int width = 1280, height = 720;  ///< frame [pixels]
  double k = 1;                    ///< eq. 5's K: selection probability min(1, K tau / tau_max)
  double lod_l0_km = 0;            ///< eq. 13's L0 [km] (0: 60 % of the camera's distance to the region's centre)
  bool lod = true;                 ///< thin the particles with distance (eq. 13)
  Transmission transmission = Transmission::two_stream;
  int refine = 0;            ///< each weather cell split N x N (0: GFS to <= 30 km cells, WRF unchanged)
  bool ply = true;           ///< the particle set of every frame as PLY
  bool transparent = false;  ///< RGBA frames (alpha: cloud coverage) instead of RGB over the sky
  std::filesystem::path out = "out/particles";
  std::uint64_t seed = 1;
};

/// One drawn frame.
struct ParticlesFrame {
  double time_s = 0;          ///< since the first weather time
  std::string time_utc;       ///< ISO 8601
  std::size_t particles = 0;  ///< alive
  std::size_t drawn = 0;      ///< after the level of detail
};

struct ParticlesResult {
  std::size_t particles = 0;  ///< generated
  std::string source;         ///< the weather file(s)
  int cols = 0, rows = 0;     ///< weather columns, after refinement
  double cell_dx_m = 0, cell_dy_m = 0;
  double generation_s = 0;
  std::vector<ParticlesFrame> frames;
};

/// "two-stream" or "beer"; ValueError naming `key` otherwise.
Transmission transmission_named(const std::string& name, const std::string& key);

/// Checks `request`, reads its weather, generates the particles and draws `frames` frames into
/// `out` (frame_NNNN.png, particles_NNNN.ply, columns.nc, frames.csv; each written atomically).
/// Everything the request says is checked before the weather is read.
ParticlesResult run_particles(const ParticlesRequest& request);

}  // namespace nephos::particles
