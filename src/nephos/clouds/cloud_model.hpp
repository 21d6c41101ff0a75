#pragma once
// The cloud function of equation (1) (the fractal-cloud paper, section 2.1) for one cloud type inside its
// shell over the Earth:
//
//   CF(x) = sum_i m_i FF_i(x_i / LS_i) + b + w * mask(x_m)
//           - A exp(-(alt - alt_bottom) / LS_bottom) - A exp((alt - alt_top) / LS_top)
//
// FF_i are the baked fractal textures (coarse Perlin, fine Perlin, inverted Worley), x_i and
// x_m the upwind points of x from the displacement maps (same altitude), mask the weather mask
// of the type. Cloud is where CF > threshold. The seed's single altitude length scale is split
// into a bottom and a top one (equal by default) so cumulus can have flat bases.
//
// Calibration (default on): the mask term b + w mask becomes phi(mask) = threshold -
// Q_F(1 - mask), Q_F the quantile function of the fractal sum F = sum_i m_i FF_i, so that a
// mask value m gives a fraction m of cloudy sky (away from the altitude barriers). This keeps
// the masks' meaning, a cloud fraction, whatever the fractal weights.
#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "nephos/clouds/cube_map.hpp"
#include "nephos/clouds/displacement.hpp"
#include "nephos/core/config.hpp"
#include "nephos/noise/fractal_texture.hpp"
#include "nephos/optics/optics.hpp"
#include "nephos/weather/masks.hpp"

namespace nephos::clouds {

using weather::CloudType;

/// The three baked textures every cloud type draws from, one set per seed, with their mip
/// pyramids (for footprints wider than a voxel: CloudShell::classify_filtered).
struct FractalTextures {
  noise::Texture3D coarse, fine, worley;
  std::array<noise::MipPyramid, 3> mips;
  /// The three textures (of one size, at least 8) and their pyramids.
  static FractalTextures from(noise::Texture3D coarse, noise::Texture3D fine, noise::Texture3D worley);
  /// Bakes the three fractals of `params` at params.texture_size. Octaves finer than half the
  /// texture resolution (which the voxels could not resolve) are dropped.
  static FractalTextures bake(const struct CloudModelParams& params, std::uint64_t seed);
  const noise::Texture3D& operator[](int i) const { return i == 0 ? coarse : i == 1 ? fine : worley; }
  /// Level `level` of texture i's pyramid: 0 the texture, 1.. its filtered copies; null at the
  /// mean level (MipPyramid::mean_level()) and past it.
  const noise::Texture3D* level(int i, int level) const {
    const auto& m = mips[static_cast<std::size_t>(i)];
    return level == 0 ? &(*this)[i] : level < m.mean_level() ? &m.levels[static_cast<std::size_t>(level - 1)] : nullptr;
  }
};

struct FractalTerm {
  double weight = 0;          ///< m_i
  double length_scale_m = 1;  ///< LS_i: metres per texture tile
  double displace_hours = 0;  ///< hours of upwind displacement for this fractal
};

struct CloudTypeParams {
  double shell_bottom_m = 0, shell_top_m = 0;  ///< Table 1 shell range [m above MSL]
  double wind_altitude_m = 0;                  ///< altitude of the displacing wind (Table 1 sampling altitude)
  std::array<FractalTerm, 3> fractals;         ///< coarse Perlin, fine Perlin, Worley
  double bias = 0;                             ///< b (ignored when calibrated)
  double mask_weight = 1;                      ///< w (ignored when calibrated)
  bool calibrate = true;
  double mask_displace_hours = 0;  ///< the mask is valid-time weather: 0 by default
  double threshold = 0.5;          ///< level-set value
  double altitude_scale = 1.0;     ///< A
  double altitude_length_bottom_m = 300, altitude_length_top_m = 300;
  double min_mask = 0.02;  ///< below this mask value the sky is clear (skipping)
  // Optics (section 2.3)
  optics::Phase phase = optics::Phase::water;
  double water_content_g_m3 = 0.3;
  double effective_radius_um = 10;
  /// Asymmetry parameter g of the slab's scattering (van de Hulst's similarity relations,
  /// optics::similarity_scaled): 0, the default, is the seed's slab, in which every scattered
  /// photon reverses; ~0.85 (cloud droplets) gives realistic albedos and thermal emissivities.
  double asymmetry = 0;
};

struct CloudModelParams {
  /// The texture sizes the model accepts (powers of two): three textures of about 2.37 N^3 bytes
  /// each (noise::Texture3D's bricks), 7.2 GiB at N = 1024.
  static constexpr int min_texture_size = 8, max_texture_size = 1024;
  /// The longest wind displacement or animation advance [h]: ten days, the length of a GFS
  /// forecast (the trajectory integration takes one step per displacement step).
  static constexpr double max_displace_hours = 240;
  int texture_size = 256;
  noise::FractalSpec coarse{noise::FractalKind::perlin, 4, 5, 0.5, false};
  noise::FractalSpec fine{noise::FractalKind::perlin, 8, 4, 0.55, false};
  noise::FractalSpec worley{noise::FractalKind::worley, 4, 3, 0.45, true};
  int displacement_cube_size = 128;
  double displacement_step_s = 1800;
  int mask_cube_size = 512;
  /// Shells lifted per location to the weather's own cloud tops (cloud_top_lifts(); config
  /// [masks_cube] follow_weather_tops). false: the types' fixed shell ranges (Table 1).
  bool follow_weather_tops = true;
  std::array<CloudTypeParams, weather::cloud_type_count> types;

  CloudModelParams();  ///< defaults: docs/render.md
  /// Reads [textures], [displacement] and [clouds.<type>] (unknown keys: error on check_unused()).
  static CloudModelParams from(const ParamDict& dict);
  /// Sets texture_size after checking it (a power of two, min..max_texture_size) and that the
  /// three textures fit in this machine's memory; ValueError / ResourceError naming `key`.
  void set_texture_size(int n, const std::string& key);
  /// Sets every fractal's wind displacement [h] (0..max_displace_hours); ValueError naming `key`.
  void set_displace_hours(double hours, const std::string& key);
  const CloudTypeParams& operator[](CloudType t) const { return types[static_cast<std::size_t>(t)]; }
  CloudTypeParams& operator[](CloudType t) { return types[static_cast<std::size_t>(t)]; }
};

/// How far each type's shell rises or sinks per location to meet the weather's own cloud tops,
/// on n x n cube maps (bicubic from the lat-lon grid), one per type in order: GFS's diagnosed
/// top pressure of the type's layer (low cloud for the low types, middle cloud for altostratus,
/// the higher of high and convective cloud for cirrus), as a height on the column's gh profile,
/// less the type's nominal top; at most half the shell's depth down and up to 18 km; 0 where the
/// weather has no such top (no cloud of that layer, or no field).
std::vector<CubeMap<float>> cloud_top_lifts(const weather::WeatherGrid& weather, const CloudModelParams& params,
                                            const std::vector<CloudType>& types, int n);

/// The weather masks of `types` resampled onto n x n cube maps (bicubic from the lat-lon grid,
/// weather::sample_bicubic), one per type in order.
std::vector<CubeMap<float>> mask_cubes(const weather::WeatherMasks& masks, const std::vector<CloudType>& types, int n);

/// One cloud type ready to evaluate: textures, displacement maps, mask, calibrated constants.
class CloudShell {
 public:
  /// @param lift  the per-location lift of set_lift(), or null: none.
  CloudShell(CloudType type, const CloudTypeParams& params, std::shared_ptr<const FractalTextures> textures,
             std::shared_ptr<const CubeMap<float>> mask, std::vector<DisplacementMap> maps,
             std::shared_ptr<const CubeMap<float>> lift = nullptr);

  CloudType type() const { return type_; }
  const CloudTypeParams& params() const { return p_; }
  double radius_bottom_m() const { return r_bottom_; }
  double radius_top_m() const { return r_top_; }
  double threshold() const { return p_.threshold; }

  /// CF at Earth-fixed position p [m], exact.
  double value(const earth::Vec3& p) const { return evaluate(p, false); }
  /// CF or, once the side of the threshold is certain, a bound on it with the same side: the
  /// fractal terms' bounds over their texture blocks (Texture3D::bounds, cached) decide most
  /// points without a texture fetch; otherwise terms are added in order (coarse, Worley, fine)
  /// until the bounds of the rest cannot change whether CF exceeds the threshold. What ray
  /// marching needs, at a fraction of the texture fetches.
  double classify(const earth::Vec3& p) const { return evaluate(p, true); }
  /// classify() of n points at once (out[i] for p[i]), bit-identical to n single calls but
  /// staged so that the texture fetches of many points overlap: at kilometre pixel spacing
  /// every fetch misses the caches, and batching hides most of that latency.
  void classify(const earth::Vec3* p, std::size_t n, double* out) const { evaluate(p, n, out, true); }
  /// value() of n points at once (see classify()).
  void value(const earth::Vec3* p, std::size_t n, double* out) const { evaluate(p, n, out, false); }
  /// The cloud function as a pixel sees it (anti-aliasing by ray cones): at p[i] the pixel's
  /// footprint is footprint_m[i] metres wide. Each fractal term is read from the level of its mip
  /// pyramid whose voxels are that wide (level log2(footprint / voxel), rounded up or down at
  /// random in proportion, a counter-based hash of the point: stochastic texture filtering,
  /// Pharr et al. 2024), and the variance the footprint averages away, sigma^2 = sum_i m_i^2
  /// (var_i(0) - var_i(level)), is that of the sub-pixel detail. out[i] = u, the distance to the
  /// level set in units of sigma, (CF_filtered - threshold) / sigma, within [u_min(), u_max()]
  /// (an end where the bounds decide it): coverage(u) is the share of the footprint that is cloud
  /// at p. Where the footprint is finer than every voxel, sigma = 0 and u is an end on CF's side
  /// of the threshold: classify() again.
  void classify_filtered(const earth::Vec3* p, const double* footprint_m, std::size_t n, double* out) const {
    evaluate_filtered(p, footprint_m, n, out);
  }
  /// The share of a footprint that is cloud at filtered distance u: the chance that the
  /// sub-pixel detail, sigma Z, lifts CF above the threshold, P(Z > -u), Z the fractal sum
  /// standardised (its distribution sampled as for the calibration, tabulated): the fractal sum's
  /// own bounded, skewed shape, not a normal one. 0 at u_min() and below, 1 at u_max() and above.
  double coverage(double u) const { return u_table(coverage_, u, 1.0); }
  /// log(1 - coverage(u)), tabulated likewise (-27.6, log 1e-12, where coverage is 1).
  double log_clear(double u) const { return u_table(log_clear_, u, log_clear_.back()); }
  /// Equal-probability nodes of Z (its quantiles at (k + 1/2) / 4): the expectation over the
  /// sub-pixel detail shared along a path (PathCoverage).
  static constexpr int z_node_count = 4;
  const std::array<double, z_node_count>& z_nodes() const { return z_nodes_; }
  /// sigma^2 of the sub-pixel detail of a footprint footprint_m wide (as classify_filtered()).
  double detail_variance(double footprint_m) const { return footprint_table(detail_variance_, footprint_m); }
  /// The length [m] over which the sub-pixel detail of a footprint footprint_m wide decorrelates
  /// along a path: each band of the mip pyramid it averages away (2^l to 2^(l+1) voxels) renews
  /// itself once per its scale (their geometric mean); the rates 1 / scale averaged with the
  /// bands' shares of sigma^2 (fine detail holds little variance but renews often). A path of
  /// length L through cloud of coverage c then misses it with chance (1 - c)^(L / length), as if
  /// in L / length independent tries. Infinite where no detail is averaged away.
  double detail_length_m(double footprint_m) const { return footprint_table(detail_length_, footprint_m); }
  /// The mean squared gradient [1/m^2] that a footprint footprint_m wide averages away: per
  /// term, its weight^2 times its textures' (noise::TextureStats::gradient) at level 0 less at
  /// the footprint's level (linear between levels), in tiles of length_scale_m. What a filtered
  /// normal, the footprint's mean gradient, leaves out of the surface's.
  double detail_gradient_variance(double footprint_m) const {
    return footprint_table(detail_gradient_variance_, footprint_m);
  }
  double u_min() const { return u_min_; }  ///< -max Z: below, no sub-pixel detail reaches the threshold
  double u_max() const { return u_max_; }  ///< -min Z: above, all of it does
  /// CF at n points and its gradient [1/m] there, for surface normals. The fractal terms'
  /// gradients are the trilinear interpolants' own (from the eight voxels the value reads),
  /// chained with the Jacobian of their upwind texture coordinates; that Jacobian and the mask
  /// term (smooth, cheap lookups) come from forward differences of step h [m], the altitude
  /// barriers' derivative is analytic. Three texture lookups per point instead of the twelve
  /// of forward differences of CF itself. `value` may be null.
  /// With footprint_m (null: none), those of the filtered cloud function (classify_filtered()).
  void value_and_gradient(const earth::Vec3* p, std::size_t n, double h, double* value, earth::Vec3* gradient,
                          const double* footprint_m = nullptr) const;
  /// The mask value seen at p (after the mask's displacement).
  double mask_at(const earth::Vec3& p) const;
  /// The unit direction whose weather the cloud at p carries: where the wind (advance_scene)
  /// brought the mask seen at p from; p's own direction while the shell is not carried.
  earth::Vec3 carried_from(const earth::Vec3& p) const { return maps_[0].upwind(p / glm::length(p)); }
  /// Whether the wind has carried the shell's clouds away from where the weather puts them.
  bool carried() const { return !maps_[0].is_identity(); }
  /// The weather's own cloud fraction (the mask, not carried) in unit direction u.
  double weather_mask(const earth::Vec3& u) const { return mask_->sample(u); }
  /// Lifts the shell per location: at a point whose displaced mask direction is u the cloud
  /// function's altitude barriers stand lift(u) metres higher (the weather's own cloud tops;
  /// cloud_top_lifts()), the bottom one no lower than the ground. A cube map of the mask's
  /// size; the shell's radii grow to hold it.
  void set_lift(std::shared_ptr<const CubeMap<float>> lift);
  /// The lift at p [m] (0 without one).
  double lift_at(const earth::Vec3& p) const;
  /// The finest feature size [m]: the fine fractal's voxel.
  double feature_size_m() const;
  /// Angular half-width [rad] of the neighbourhood altitude_window() covers.
  double skip_radius_rad() const { return skip_radius_rad_; }
  /// Conservative bounds for empty-space skipping: the altitudes [lo[i], hi[i]] [m] outside
  /// which no point within skip_radius_rad() of direction (x[i], y[i], z[i]) (any length > 0)
  /// can hold cloud: there classify_filtered() is u_min() whatever the footprint (and CF below
  /// the threshold), the mask below min_mask or the altitude barriers alone keeping CF below the
  /// sub-pixel detail's reach, for the masks and lifts of that neighbourhood. lo[i] > hi[i]: no
  /// cloud anywhere near. Looks up two coarse cube maps of the bounds. A march skips the rays
  /// whose window is empty and leaves out the filtered steps outside it: the same result from
  /// fewer points.
  void altitude_window(const double* x, const double* y, const double* z, std::size_t n, double* lo, double* hi) const;
  /// Replaces the displacement maps (animation).
  void set_maps(std::vector<DisplacementMap> maps) {
    maps_ = std::move(maps);
    build_skip_map();
  }
  const std::vector<DisplacementMap>& maps() const { return maps_; }

 private:
  CloudType type_;
  CloudTypeParams p_;
  std::shared_ptr<const FractalTextures> tex_;
  std::shared_ptr<const CubeMap<float>> mask_;
  std::shared_ptr<const CubeMap<float>> lift_;  ///< per-location rise of the barriers [m], or null
  std::vector<DisplacementMap> maps_;           ///< [0] mask, [1..3] fractals
  /// The fractal terms with a non-zero weight, in evaluation order, into terms; their count.
  std::size_t active_terms(std::array<int, 3>& terms) const;
  /// Whether terms[t] is displaced like terms[t - 1], so that its upwind points are those.
  bool shares_upwind(const std::array<int, 3>& terms, std::size_t t) const;
  double evaluate(const earth::Vec3& p, bool early_out) const;
  void evaluate(const earth::Vec3* p, std::size_t n, double* out, bool early_out) const;
  void evaluate_filtered(const earth::Vec3* p, const double* footprint_m, std::size_t n, double* out) const;
  // The stages of the batched evaluate() over one chunk of points (cloud_model.cpp); Filtered:
  // those of evaluate_filtered().
  struct EvalWork;
  template <bool Filtered>
  std::size_t mask_stage(const earth::Vec3* p, std::size_t c0, std::size_t m, double* out, EvalWork& w) const;
  template <bool Filtered>
  void footprint_stage(const std::array<int, 3>& terms, std::size_t nt, std::size_t nlive, bool early_out,
                       EvalWork& w) const;
  template <bool Filtered>
  std::size_t select_stage(std::size_t c0, std::size_t nt, std::size_t nlive, bool early_out, double* out,
                           EvalWork& w) const;
  template <bool Filtered>
  void sample_stage(const std::array<int, 3>& terms, std::size_t nt, std::size_t c0, std::size_t nsel, bool early_out,
                    double* out, EvalWork& w) const;
  std::size_t level_stage(const earth::Vec3* p, const double* footprint_m, std::size_t c0, std::size_t nlive,
                          double* out, EvalWork& w) const;
  /// Per fractal term, what filtering needs: log2 of voxels per metre, the mean, and per pyramid
  /// level (0 .. top_level, the mean level) the variance averaged away, m_i^2 (var(0) -
  /// var(level)), and the weighted upper bound of the level's values.
  struct TermMips {
    static constexpr std::size_t max_levels = 16;  ///< a 1024^3 texture has 10
    double log2_voxels_per_m = 0, mean = 0, mean_weighted = 0, top = 0;
    int top_level = 0;
    std::array<double, max_levels> lost_variance{}, hi{};
    std::array<double, max_levels> lost_gradient{};  ///< the squared gradient averaged away [1/m^2]
    /// Each level's texture addressing (level 0's at the mean level and past it, where no
    /// texture is read).
    std::array<noise::Texture3D::Addressing, max_levels> addressing{};
  };
  std::array<TermMips, 3> term_mips_;
  void build_term_mips();
  /// The pyramid level of fractal term i for a footprint of 2^log2_s metres, rounded at random
  /// with u in [0, 1); its sigma^2 contribution (continuous in the level) into lost_var.
  int term_level(int i, double log2_s, double u, double& lost_var) const {
    const TermMips& tm = term_mips_[static_cast<std::size_t>(i)];
    const double x = std::clamp(log2_s + tm.log2_voxels_per_m, 0.0, tm.top);
    const int l = std::min(static_cast<int>(x), tm.top_level - 1);
    const double f = x - l;
    const auto lu = static_cast<std::size_t>(l);
    lost_var = tm.lost_variance[lu] + f * (tm.lost_variance[lu + 1] - tm.lost_variance[lu]);
    return l + (u < f ? 1 : 0);
  }
  double sigma_max_ = 0;  ///< sigma of a footprint that averages every term away
  static constexpr int footprint_nodes_per_octave = 8;
  std::vector<double> detail_length_, detail_variance_;  ///< at footprints 2^(i / 8) m
  std::vector<double> detail_gradient_variance_;         ///< likewise
  std::vector<double> log_clear_;                        ///< log_clear() at coverage_'s nodes
  std::array<double, z_node_count> z_nodes_{};
  void build_detail_tables();
  static double footprint_table(const std::vector<double>& t, double footprint_m) {
    const double x = std::log2(std::max(footprint_m, 1.0)) * footprint_nodes_per_octave;
    if (!(x < static_cast<double>(t.size() - 1))) return t.back();
    const auto i = static_cast<std::size_t>(x);
    return t[i] + (x - static_cast<double>(i)) * (t[i + 1] - t[i]);
  }
  /// The skip maps of altitude_window(): per texel, the widest bounds of the points' windows
  /// around it. After calibration: a window reads the calibrated mask term.
  void build_skip_map();
  /// set_lift() but for the skip maps it moves.
  void apply_lift(std::shared_ptr<const CubeMap<float>> lift);
  /// The altitude window [bottom, top] [m] of one point where the displaced mask is `mask` and
  /// the lift `lift` [m] (altitude_window()).
  std::pair<double, double> point_window(double mask, double lift) const;
  /// The altitude barriers at altitude alt [m] with the top one raised by lift [m]: A (exp(-(alt -
  /// bottom) / L_bottom) + exp((alt - lift - top) / L_top)), from tables where alt is on them.
  double barrier(double alt, double lift = 0) const;
  double barrier_term(const std::vector<float>& table, double x, bool top) const;
  /// The bottom barrier moves with the lift but not below the ground (a shell on the ground
  /// lowered by the weather only thins from the top).
  double bottom_lift(double lift) const { return std::max(lift, -p_.shell_bottom_m); }
  /// How much a lift below -shell_bottom thins the shell [m]: its bottom stays on the ground.
  double squeeze_m(double lift) const { return bottom_lift(lift) - lift; }
  /// The mask's term of CF: w m, or with calibration phi(m, squeeze) (linear between 1025 nodes
  /// of m and between the squeeze classes).
  double mask_term(double m, double squeeze_m = 0) const {
    if (mask_terms_.empty()) return mask_weight_ * m;
    const double x = std::clamp(m, 0.0, 1.0) * mask_term_intervals;
    const int i = std::min(static_cast<int>(x), mask_term_intervals - 1);
    const auto iu = static_cast<std::size_t>(i);
    const double* row = mask_terms_.data();
    if (squeeze_classes_ == 1) return row[iu] + (x - i) * (row[iu + 1] - row[iu]);
    const double y = std::clamp(squeeze_m * inv_squeeze_step_m_, 0.0, static_cast<double>(squeeze_classes_ - 1));
    const int j = std::min(static_cast<int>(y), squeeze_classes_ - 2);
    const double fy = y - j;
    const double* r0 = row + static_cast<std::size_t>(j) * (mask_term_intervals + 1);
    const double* r1 = r0 + (mask_term_intervals + 1);
    const double v0 = r0[iu] + (x - i) * (r0[iu + 1] - r0[iu]), v1 = r1[iu] + (x - i) * (r1[iu + 1] - r1[iu]);
    return v0 + fy * (v1 - v0);
  }
  static constexpr int mask_term_intervals = 1024;
  static constexpr int coverage_intervals = 1024;
  /// Table t (coverage_'s nodes in u) at u, linear between nodes: 0 at u_min() and below,
  /// `beyond` at u_max() and above.
  double u_table(const std::vector<double>& t, double u, double beyond) const {
    const double x = (u - u_min_) * coverage_scale_;
    if (!(x > 0)) return 0;
    if (x >= coverage_intervals) return beyond;
    const auto i = static_cast<std::size_t>(x);
    return t[i] + (x - static_cast<double>(i)) * (t[i + 1] - t[i]);
  }
  std::vector<double> coverage_;  ///< coverage() at u_min + k (u_max - u_min) / 1024
  double u_min_ = -4, u_max_ = 4;
  double coverage_scale_ = coverage_intervals / 8.0;  ///< table nodes per unit of u
  /// The fractal sum F at 32768 counter-hashed points (each texture at its own independent
  /// position: the terms use unrelated length scales), sorted.
  std::vector<double> fractal_sample() const;
  /// Per squeeze class j and column of the shell, the largest F - barrier over its height,
  /// sorted within each class (the calibration): [j][column].
  std::vector<std::vector<double>> column_sample() const;
  static constexpr int column_count = 16384, column_levels = 48;
  void build_coverage(const std::vector<double>& sorted_f);
  void calibrate();
  /// phi at m = k / 1024 for squeeze class j at [j * 1025 + k] (calibrated), else empty.
  std::vector<double> mask_terms_;
  static constexpr int squeeze_class_count = 9;  ///< a shell's from no squeeze to half its depth
  int squeeze_classes_ = 1;  ///< 1, or squeeze_class_count for a shell the weather can lower onto the ground
  double inv_squeeze_step_m_ = 0;
  double r_bottom_, r_top_;
  double bias_, mask_weight_, fractal_max_, fractal_min_;  ///< extreme sums of the fractal terms
  std::array<int, 3> order_{0, 2, 1};                      ///< evaluation order of the fractal terms
  CubeMap<float> window_bottom_m_, window_top_m_;          ///< altitude_window()'s bounds per skip texel
  double skip_radius_rad_ = 0;
  // Altitude barriers tabulated at 1 m over the shell +- 1 km (linear interpolation; the
  // exponentials' relative change over 1 m is < 1/150, error < 1e-5).
  std::vector<float> barrier_bottom_, barrier_top_;  ///< each barrier at 1 m steps from barrier_z0_
  double barrier_z0_ = 0;
};

/// The chance that a ray's path through a filtered shell meets cloud (anti-aliasing: a pixel's
/// cloud fraction is the share of the rays through its footprint that meet cloud anywhere along
/// their paths, far above any one step's coverage). The sub-pixel detail splits at the path's
/// length L: scales above it are shared by the whole path (sigma_c^2 = sigma^2(w) -
/// sigma^2(L)), those below renew along it, one independent try per detail length l(L)
/// (CloudShell::detail_length_m). The path misses with chance E[prod_k (1 - c_k)^(ds / l)], c_k
/// the share of the renewing detail that reaches the threshold at step k given the shared part,
/// the expectation over the shared part by equal-probability nodes of Z; never less than the
/// likeliest step's coverage.
class PathCoverage {
 public:
  PathCoverage() = default;
  /// @param footprint_m  the footprint's width along the path [m]
  /// @param path_m       the path's length inside the shell [m]
  PathCoverage(double footprint_m, double path_m) : footprint_m_(footprint_m), path_m_(path_m) {}
  /// One step of length ds_m [m] at filtered distance u (CloudShell::classify_filtered); returns
  /// the step's coverage, coverage(u).
  double add(const CloudShell& s, double u, double ds_m) {
    const double c = s.coverage(u);
    c_max_ = std::max(c_max_, c);
    if (c > 0) {
      if (!split_) split(s);
      if (rate_ > 0) {
        const double w = ds_m * rate_, x = u * scale_;
        for (std::size_t n = 0; n < shift_.size(); ++n) log_clear_[n] += w * s.log_clear(x + shift_[n]);
      }
    }
    return c;
  }
  double chance() const;

 private:
  // The detail's split into shared and renewing parts, made at the first step with cloud (most
  // paths a skip leaves possible meet none, and need no tables).
  void split(const CloudShell& s);
  double footprint_m_ = 0, path_m_ = 0;
  bool split_ = false;
  double scale_ = 1, rate_ = 0, c_max_ = 0;  // sigma / sigma_renewing; 1 / l(L)
  std::array<double, CloudShell::z_node_count> shift_{}, log_clear_{};
};

/// The indices j < n of the filtered distances u[j] (CloudShell::classify_filtered) above
/// s.u_min(), the steps with any coverage, into idx in order, compacted without branches (which
/// they are is hard to predict); returns their count.
inline std::size_t steps_with_cover(const CloudShell& s, const double* u, std::size_t n, std::uint32_t* idx) {
  const double u_min = s.u_min();
  std::size_t count = 0;
  for (std::size_t j = 0; j < n; ++j) {
    idx[count] = static_cast<std::uint32_t>(j);
    count += u[j] > u_min;
  }
  return count;
}

/// An altitude window [z_lo, z_hi] [m] (CloudShell::altitude_window) as squared radii [m^2], for
/// tests of points without a square root; an empty window stays empty.
inline std::pair<double, double> window_squared_radii(double z_lo, double z_hi) {
  const double lo = std::max(earth::radius_m + z_lo, 0.0), hi = earth::radius_m + z_hi;
  return {lo * lo, hi >= 0 ? hi * hi : -1.0};
}

/// classify_filtered() of those of the n points p[i] (footprints footprint_m[i] [m]) that lie in
/// their altitude windows, r2_lo[i] <= |p[i]|^2 <= r2_hi[i] (window_squared_radii()); out[i] =
/// s.u_min() for the others, which is what classify_filtered() gives there: the same values
/// from fewer points (a march's steps above and below what its ray's columns can hold).
void classify_filtered_in_windows(const CloudShell& s, const earth::Vec3* p, const double* footprint_m,
                                  const double* r2_lo, const double* r2_hi, std::size_t n, double* out);

/// The tables of a configuration file the cloud model and the masks read: [clouds.*],
/// [textures], [displacement] and [masks.*] / [cloud_fraction].
struct ModelConfig {
  CloudModelParams cloud;
  weather::MaskParams masks;
};
/// Reads `path` (every key must be known: ConfigError naming it otherwise); the defaults when
/// `path` is empty.
ModelConfig read_model_config(const std::filesystem::path& path);

/// Everything needed to render clouds of several types from one weather state.
struct CloudScene {
  std::shared_ptr<const FractalTextures> textures;
  std::vector<CloudShell> shells;
  /// Per shell, the altitudes [m MSL] whose condensate its clouds carry
  /// (weather::condensate_layers_m()); shells of one layer share it.
  std::vector<std::array<double, 2>> condensate_layer_m;
  std::vector<WindField> winds;    ///< one per distinct wind altitude
  std::vector<int> wind_of_shell;  ///< index into winds for each shell
};

/// Builds textures, masks' cube maps, winds and displacement maps for the requested types.
/// `textures`, when given, are used instead of baking: they must be those of `params` and
/// `seed` (e.g. another scene's, for other types or another weather state of the same run);
/// a size other than params.texture_size is a ValueError.
CloudScene build_scene(const weather::WeatherGrid& weather, const weather::WeatherMasks& masks,
                       const CloudModelParams& params, const std::vector<CloudType>& types, std::uint64_t seed,
                       std::shared_ptr<const FractalTextures> textures = nullptr);
/// Advances every shell's displacement maps by `hours` (frame-to-frame propagation).
void advance_scene(CloudScene& scene, double hours, const CloudModelParams& params);

}  // namespace nephos::clouds
