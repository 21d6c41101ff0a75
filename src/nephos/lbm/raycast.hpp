#pragma once
// Volume ray casting of a lit cloud density (seed section 4.4): front-to-back compositing along
// rays from a pinhole camera, over a sky gradient and a ground plane z = 0 that carries the
// cloud's shadow (an orthographic projection of the density towards the sun).
#include <array>
#include <cstdint>
#include <vector>

#include "nephos/lbm/lattice.hpp"

namespace nephos::lbm {

struct RaycastParams {
  int width = 640, height = 480;
  double fov_deg = 55;
  std::array<double, 3> eye{}, target{};  ///< lattice units; eye == target: a default side view
  double extinction_per_density = 0.4;    ///< per lattice unit at density 1
  double sun_azimuth_deg = 135, sun_elevation_deg = 45;
  double step = 0.5;  ///< marching step [lattice units]
};

/// RGB8 image, rows from the top. `light` is the lighting solver's photon density (any scale:
/// normalised by its 99th percentile).
std::vector<std::uint8_t> raycast(const Grid3& g, const std::vector<float>& density, const std::vector<float>& light,
                                  const RaycastParams& p);

}  // namespace nephos::lbm
