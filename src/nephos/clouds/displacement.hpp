#pragma once
// Wind displacement maps (the fractal-cloud paper, section 2.2, Figures 4-5). A displacement map sends each
// point of the sphere at a chosen altitude to the point its air came from `hours` earlier in
// the GFS wind at that altitude ("upwind point"). Sampling a fractal at the upwind point
// stretches and shears its shapes along the flow, as satellite imagery shows.
//
// Integration: the trajectory dp/dt = -V(p) / (R + z) of a unit position vector p on the
// sphere, V the horizontal wind as an Earth-fixed vector, with classical RK4 on the sphere
// (each stage re-normalised onto it), so poles and the date line need no special case.
// Propagation (animation) composes maps: D_{H+A}(x) = D_H(back_A(x)), integrating only A hours.
#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <vector>

#include "nephos/clouds/cube_map.hpp"
#include "nephos/weather/weather_grid.hpp"

namespace nephos::clouds {

/// The horizontal wind at one altitude as Earth-fixed vectors [m/s] on a cube map.
struct WindField {
  double altitude_m = 0;
  CubeMap<glm::vec3> velocity_m_s;
  earth::Vec3 at(const earth::Vec3& unit_position) const;
};

/// Samples u, v of `weather` at `altitude_m` (bilinear + log-p, weather/sampler.hpp) onto an
/// n x n x 6 cube map. Missing winds count as calm.
WindField make_wind_field(const weather::WeatherGrid& weather, double altitude_m, int n = 128);

class DisplacementMap {
 public:
  /// The identity map (no displacement).
  DisplacementMap() = default;
  double hours() const { return hours_; }
  bool is_identity() const { return upwind_.size() == 0; }
  /// The unit upwind direction of the unit direction `d`.
  earth::Vec3 upwind(const earth::Vec3& d) const {
    earth::Vec3 u;
    upwind(&d.x, &d.y, &d.z, 1, &u.x, &u.y, &u.z);
    return u;
  }
  /// upwind() of n directions (x[i], y[i], z[i]) into (ux[i], uy[i], uz[i]); the arrays must
  /// not overlap. Vectorised loops around a scalar one for the texel loads; upwind(d) is this
  /// with n = 1, so the two agree bit for bit.
  void upwind(const double* x, const double* y, const double* z, std::size_t n, double* ux, double* uy,
              double* uz) const;
  const CubeMap<glm::vec3>& map() const { return upwind_; }

  /// Integrates every texel `hours` backwards in `wind` with time step `step_s` [s].
  static DisplacementMap build(const WindField& wind, double hours, int n = 128, double step_s = 1800.0);
  /// build() of each of `hours`, in that order: durations with the same step length share one
  /// integration (the shorter maps are recorded on the way), with the same results.
  static std::vector<DisplacementMap> build_all(const WindField& wind, const std::vector<double>& hours, int n = 128,
                                                double step_s = 1800.0);
  /// This map advanced by `hours` more (frame-to-frame propagation by composition).
  DisplacementMap advanced(const WindField& wind, double hours, double step_s = 1800.0, int n = 128) const;

 private:
  double hours_ = 0;
  CubeMap<glm::vec3> upwind_;
};

/// Moves unit position `p` backwards along the wind for `seconds` (RK4 steps of `step_s`).
earth::Vec3 trace_upwind(const WindField& wind, earth::Vec3 p, double seconds, double step_s);

}  // namespace nephos::clouds
