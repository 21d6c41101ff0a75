#pragma once
// The weather's atmosphere and ground as one sensor sees them under one Sun: per weather-grid
// node, the column's clear-sky optics in each band for that node's view and Sun geometry
// (atmosphere::clear_sky_column), its temperature and condensate profiles and its ground
// (surface::State); sampled anywhere by bilinear interpolation between nodes, with each node's
// transmittance carried to the pixel's own air mass.
#include <array>
#include <utility>
#include <vector>

#include "nephos/atmosphere/clear_sky.hpp"
#include "nephos/earth/geometry.hpp"
#include "nephos/earth/sun.hpp"
#include "nephos/optics/optics.hpp"
#include "nephos/render/sensor.hpp"
#include "nephos/surface/surface.hpp"
#include "nephos/weather/weather_grid.hpp"

namespace nephos::render {

/// What the air does in each band to light leaving altitude z towards the sensor.
struct AirSample {
  std::array<float, optics::max_band_count> t_view{};  ///< gas transmittance to the sensor
  std::array<float, optics::max_band_count> path{};    ///< thermal emission of the air between [W m^-2 sr^-1 um^-1]
  std::array<float, optics::max_band_count> t_sun{};   ///< gas transmittance from the Sun down to z
  std::array<float, optics::max_band_count> tau_rayleigh{};  ///< vertical Rayleigh optical depth above z
};

class EarthView {
 public:
  /// @param weather  the weather (nullptr: the US standard atmosphere over a grey 288 K sea)
  /// @param atmosphere  false: a vacuum (no gases, no Rayleigh), for comparison
  /// @param ground_temperature_k  without weather, the temperature of the ground (open sea)
  /// @param condensate_layers  altitude ranges [m] whose condensate condensate_layer() reports
  EarthView(const weather::WeatherGrid* weather, const Sensor& sensor, const earth::SunPosition& sun,
            const std::vector<const optics::Band*>& bands, bool atmosphere, double ground_temperature_k = 288.15,
            const std::vector<std::array<double, 2>>& condensate_layers = {});

  /// Where a point lies among the weather's nodes: the four around it and their bilinear
  /// weights, found once for all the lookups below at that point.
  struct Place {
    std::array<std::size_t, 4> node{};
    std::array<double, 4> w{};
  };
  Place place(double lat_deg, double lon_deg) const;
  /// Per node of a place, a level index near an altitude (upper_bound's in its levels): a
  /// lookup's at about the same altitude, or 1 at the ground. A lookup given one walks from it
  /// instead of searching, to the same interval.
  using LevelHint = std::array<std::size_t, 4>;
  static constexpr LevelHint ground_levels{1, 1, 1, 1};

  /// The air between altitude z [m] at a place and the sensor, for a line of sight of cos
  /// zenith mu_view and the Sun at cos zenith mu_sun there; hint: where each node's levels are
  /// walked from (the same values as searched).
  void air(const Place& at, double z_m, double mu_view, double mu_sun, AirSample& out,
           const LevelHint* hint = nullptr) const;
  /// air() for a line of sight and a Sun path of given air masses (m_sun <= 0: the Sun is down);
  /// t_view is the vertical column's to the power m_view (exact for the grey nodes' scaling).
  void air_at_air_masses(const Place& at, double z_m, double m_view, double m_sun, AirSample& out,
                         const LevelHint* hint = nullptr) const;
  /// air_at_air_masses()'s transmittance to the sensor alone (t_view), at n altitudes
  /// z_m[0..n) of one place along one air mass, into t[i * optics::max_band_count + b], bit for
  /// bit: each node's levels searched once, then walked from the previous altitude's interval
  /// (a few levels down a limb path's shells, which descend).
  void view_transmittances(const Place& at, const double* z_m, std::size_t n, double m_view, float* t) const;
  double temperature_k(const Place& at, double z_m) const;
  /// temperature_k() at n altitudes z_m[0..n) into out, bit for bit, searched as
  /// view_transmittances().
  void temperature_k(const Place& at, const double* z_m, std::size_t n, double* out) const;
  /// temperature_k() at z_m, and condensate_g_m3() at n altitudes z_below[0..n) under it into
  /// condensate (a cloud's profile below its top), bit for bit: each node's levels searched
  /// once for both. levels: each node's level index at z_m, a hint for other lookups there.
  double temperature_k(const Place& at, double z_m, const double* z_below, std::size_t n, double* condensate,
                       LevelHint* levels = nullptr) const;
  /// Grid-mean cloud condensate [g m^-3] at z (0 where the weather has none).
  double condensate_g_m3(const Place& at, double z_m) const;
  /// The condensate of one altitude layer at a place: its grid-mean path [g m^-2], its mean
  /// where it is (sum q^2 dz / sum q dz) [g m^-3] and the temperature at its centroid [K].
  struct LayerCondensate {
    double path_g_m2 = 0, mean_g_m3 = 0, temperature_k = 0;
  };
  /// Layer l of the constructor's condensate_layers at a place: the nodes' paths bilinear, their
  /// means and temperatures weighted by their shares of it (each node integrates its profile in
  /// 64 steps; all 0 where the weather has no condensate).
  LayerCondensate condensate_layer(const Place& at, std::size_t l) const;
  /// The nodes' count and geodetic positions [deg] (condensate_layer()'s node values apart).
  std::size_t node_count() const { return nodes_.size(); }
  std::pair<double, double> node_lat_lon_deg(std::size_t k) const;
  LayerCondensate node_condensate_layer(std::size_t k, std::size_t l) const { return nodes_[k].layers[l]; }
  bool has_condensate() const { return has_condensate_; }
  /// The ground at a place; with sky_down, also the sky's downwelling thermal radiance there per
  /// band (atmosphere::ClearSkyColumn::sky_down; 0 without the atmosphere and in solar bands).
  surface::State ground(const Place& at, std::array<double, optics::max_band_count>* sky_down = nullptr) const;
  /// ground(at).share[1], the land's share, alone.
  double land_share(const Place& at) const;
  double ground_height_m(const Place& at) const;
  bool atmosphere() const { return atmosphere_; }
  double seconds_to_build() const { return seconds_; }

 private:
  struct Node {
    std::vector<float> z, t, condensate;  // levels: altitude [m], temperature [K], condensate [g m^-3]
    std::vector<LayerCondensate> layers;  // the condensate layers'
    float ground_height_m = 0;
    surface::State ground;
    // The column's clear-sky optics (atmosphere::clear_sky_column) at its levels optics_z, per
    // level and band: ln of the gas transmittance to the sensor, the air's path radiance over its
    // absorptance 1 - t (a mean Planck radiance of the air between), ln of
    // the Sun path's own transmittance, the Rayleigh optical depth above. Logarithms, so that a
    // pixel's air mass m scales them by m / m_node (exp, not pow) and they interpolate in z as
    // the exponentials they are.
    std::vector<float> optics_z, optics;
    std::array<float, optics::max_band_count> sky_down{};  // per band, at the ground
    float view_air_mass = 1, sun_air_mass = -1;
  };
  static constexpr std::size_t optics_per_band = 4;
  void build_node(std::size_t n, int j, int i);

  const weather::WeatherGrid* weather_;
  weather::LatLonGrid grid_;  // a 1 x 1 grid without weather
  std::vector<const optics::Band*> bands_;
  bool atmosphere_, has_condensate_ = false;
  double ground_temperature_k_;
  earth::Vec3 sensor_position_, sun_direction_;
  std::vector<std::array<double, 2>> condensate_layers_;
  std::vector<Node> nodes_;
  double seconds_ = 0;
};

}  // namespace nephos::render
