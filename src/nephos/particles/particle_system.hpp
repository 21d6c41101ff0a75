#pragma once
// The particle system of the WRF particle-cloud paper: particles placed by cloud-top height and optical thickness
// (eqs. 3-5), moved by the model winds (eq. 6), thinned with distance (eq. 13) and lit
// (eqs. 14-18). Structure of arrays; every random number is a counter-based hash of
// (seed, particle, attempt), so results do not depend on the thread count.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "nephos/particles/cloud_columns.hpp"

namespace nephos::particles {

struct Particles {
  std::vector<float> x, y, z;         ///< position [m] (planar grid coordinates, height above MSL)
  std::vector<float> radius_m;        ///< sprite radius
  std::vector<float> opacity;         ///< 1 - exp(-sigma * 2 radius), from the birth column's extinction
  std::vector<std::uint32_t> column;  ///< birth column index R (eqs. 3-4)
  std::size_t size() const { return x.size(); }
  void resize(std::size_t n);
};

struct GenerationParams {
  std::size_t count = 200000;
  double k = 1.0;  ///< eq. 5's K: a column is kept with probability min(1, K lambda / lambda_max)
  std::uint64_t seed = 0;
  /// Sprite radius = radius_scale * (cloud volume / count)^(1/3), so the sprites fill the cloud.
  double radius_scale = 0.8;
};

/// Eqs. (3)-(5): draws R uniformly over the columns, keeps it when lambda_R K / lambda_max - tau > 0
/// (tau uniform in [0, 1)), else draws again. The particle lies uniformly within the cell and
/// between cloud base and top. Throws ValueError if K <= 0 or no column is cloudy.
Particles generate(const PlanarGrid& grid, const CloudColumns& columns, const GenerationParams& p);

/// Probability with which eq. (5) keeps a draw of column c (its selection weight).
double selection_probability(const CloudColumns& columns, std::size_t c, double k);

/// Eq. (6) across the weather's frames, piecewise: at the start of each interval [t_n, t_n+1]
/// a particle's velocity V0 is the wind at its position at t_n and its acceleration
/// a = (wind_n+1 - wind_n) / (t_n+1 - t_n) at that position, and S = S0 + V0 T + a T^2 / 2 within
/// the interval. After the last frame the velocity stays constant. Positions at a time do not
/// depend on which earlier times were asked for.
class Motion {
 public:
  Motion(const ParticleWeather& weather, const Particles& initial);
  /// Moves `p` (whose positions are overwritten) to time t_s [s since the first frame], t_s >= 0.
  void positions_at(double t_s, Particles& p);

 private:
  void start_interval(std::size_t n);  // particles at t_n: sample V0 and a
  const ParticleWeather& w_;
  std::size_t interval_ = 0;  // current interval (n), or frames.size()-1 for the open end
  double t_start_ = 0;
  std::vector<float> x0_, y0_, z0_;                                // initial positions (for going back in time)
  std::vector<float> sx_, sy_, sz_, vx_, vy_, vz_, ax_, ay_, az_;  // S0, V0, a of the interval
};

/// Eq. (13) by distance bands: band 0 holds distances L <= L0, band m >= 1 holds
/// L0 r^(m-1) < L <= L0 r^m (r = band_ratio) and is represented by L_m = L0 r^(m - 1/2).
/// A band keeps N_m = max(1, round(n_m (L0 / L_m)^3)) of its n_m particles, those with the
/// smallest hash(seed, particle) (so survivors persist as the camera moves).
struct LodParams {
  double l0_m = 50000;
  double band_ratio = 1.189207115002721;  ///< 2^(1/4)
};
struct LodSelection {
  std::vector<std::uint32_t> kept;       ///< particle indices
  std::vector<float> size_factor;        ///< per kept particle: (n_m / N_m)^(1/3), keeps the cloud volume filled
  std::vector<std::size_t> band_counts;  ///< n_m: particles per band before thinning
  std::vector<std::size_t> band_kept;    ///< N_m
};
LodSelection select_lod(const Particles& p, const glm::dvec3& camera, const LodParams& lod, std::uint64_t seed);
/// Band index of distance L (0 for L <= L0).
int lod_band(double distance_m, const LodParams& lod);
/// Representative distance of band m >= 1.
double lod_band_distance(int m, const LodParams& lod);

// ---- Illumination (eqs. 14-18) ----------------------------------------------------------------

/// Eq. (17) as it should read: the integral over t in [0, d] of I / |r_c + t r_d - s|^2 with unit
/// r_d is (I / v) [atan((b + d) / v) - atan(b / v)] with b = r_d . (r_c - s) and
/// v = sqrt(|r_c - s|^2 - b^2) (the seed prints the reciprocal of v and squares the bracket; see
/// docs/particles.md). Falls back to the collinear limit I [1/b - 1/(b + d)] when v -> 0.
double inverse_square_line_integral(const glm::dvec3& r_c, const glm::dvec3& r_d, const glm::dvec3& s, double d,
                                    double intensity);

/// Optical depth from `from` along the unit direction `dir` through the columns (each column's
/// extinction sigma = tau / (top - base) between its base and top, 0 elsewhere), exact for this
/// piecewise-constant field: the ray is walked cell by cell and each cell's slab overlap summed.
/// Stops where the ray leaves the grid, leaves the height range of the clouds or has gone
/// `max_distance_m`.
double optical_depth_towards(const PlanarGrid& g, const CloudColumns& c, const glm::dvec3& from, const glm::dvec3& dir,
                             double max_distance_m = 1e30);

enum class Transmission { beer, two_stream };
struct Light {
  bool directional = true;        ///< the sun; else a point source at `position`
  glm::dvec3 direction{0, 0, 1};  ///< towards the sun (unit), when directional
  glm::dvec3 position{0.0};       ///< point light [m]
  double intensity = 1;           ///< I: irradiance of the sun, or intensity of the point light [per m^2 at 1 m]
};
struct IlluminationParams {
  Transmission transmission = Transmission::two_stream;
  double asymmetry = 0.85;  ///< g of cloud droplets (visible), for the two-stream similarity scaling
  double ambient = 0.25;    ///< grey floor: skylight and multiply-scattered light from below
};
/// Per-particle grey value in [0, 1]: ambient + (1 - ambient) * E / E_ref, where E is the light
/// reaching the particle (eq. 14 for a point light, averaged over the particle's diameter towards
/// the light with eq. 17; constant for the sun) times the transmission of the optical depth
/// towards the light (Beer, or the conservative two-stream slab with tau (1 - g)), and E_ref the
/// same light without cloud at the nearest particle (1 for the sun).
std::vector<float> illuminate(const PlanarGrid& g, const CloudColumns& c, const Particles& p, const Light& light,
                              const IlluminationParams& params);

}  // namespace nephos::particles
