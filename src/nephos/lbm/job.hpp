#pragma once
// `nephos lbm` as a typed request and its runner: the water model (fresh or resumed, with
// checkpoints), Nagel-Raschke percolation, lattice-Boltzmann lighting and ray casting, on one
// process or on slabs across MPI processes (a Decomposition), written as lbm.nc, clouds.vdb and
// render.png. The command line and the Python module fill in the request; errors name its
// fields ("grid", "sun", ...).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "nephos/lbm/decomposition.hpp"
#include "nephos/lbm/lattice.hpp"
#include "nephos/lbm/water_model.hpp"

namespace nephos::lbm {

struct LbmRequest {
  Grid3 grid{128, 128, 128};       ///< lattice NX x NY x NZ (z up); a resumed run takes its checkpoint's
  std::optional<int> silos;        ///< initial vapour silos; empty: the configuration's (4)
  long iterations = 20;            ///< total water-model steps (a resumed run continues to this count)
  long checkpoint_every = 0;       ///< out/checkpoint.bin every N steps (0: never)
  int percolation = 5;             ///< refinement K of the percolation (0: skip it)
  double sun_azimuth_deg = 135;    ///< from +x towards +y
  double sun_elevation_deg = 45;   ///< above the x-y plane, (0, 90]
  int width = 640, height = 480;   ///< ray-cast image [pixels]
  std::filesystem::path resume;    ///< a checkpoint to continue from
  std::filesystem::path config;    ///< TOML with a [water] table
  std::optional<Storage> storage;  ///< population storage; empty: the configuration's (fp32)
  std::filesystem::path out = "out/lbm";
  std::uint64_t seed = 1;
};

/// What a run did, on every process (the fields on process 0 only).
struct LbmResult {
  Grid3 grid;
  long first_step = 0, steps_done = 0;  ///< the step resumed from (0 for a fresh run), and reached
  double water_s = 0;
  int percolation_steps = 0;
  double percolation_s = 0;
  int lighting_steps = 0;
  double lighting_residual = 0, lighting_s = 0;
  double raycast_s = 0;
  std::vector<float> vapour, temperature, percolated, cloud, light;  ///< whole lattice, process 0
};

/// The [water] parameters of a run: the configuration file's (defaults if empty), then the
/// silo count and storage if given. Errors name "config" keys, "silos" or "storage".
WaterModelParams water_params(const std::filesystem::path& config, std::optional<int> silos,
                              std::optional<Storage> storage);

/// Cloud density in [0, 1] where the vapour condenses, without percolation: a linear ramp
/// from rho10 to 1.1 rho10.
std::vector<float> condensate_fraction(const std::vector<float>& vapour, double rho10);

/// Runs every stage of `request` over `decomposition` and, on process 0, casts the rays and
/// writes the outputs. Everything is checked before any work.
LbmResult run_lbm(const LbmRequest& request, Decomposition& decomposition);

}  // namespace nephos::lbm
