#include "nephos/render/radiometry.hpp"

#include <algorithm>
#include <cmath>

#include "nephos/atmosphere/rayleigh.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/optics/optics.hpp"

namespace nephos::render {

LayerOptics cloud_layer(double tau, double omega, double g, double mu_view) {
  LayerOptics l;
  if (!(tau > 0)) return l;
  const double mu = std::clamp(mu_view, 0.05, 1.0);
  const optics::SlabOptics s = optics::similarity_scaled(tau, omega, g);
  const optics::SlabResult slab = optics::two_stream_slab(s.tau, s.omega);
  l.reflectance = slab.reflectance;
  // Seen through the layer: the direct beam along the view and the diffusely transmitted part
  // (the two-stream transmittance less its own direct share at the diffusivity cosine 0.6).
  const double direct = std::exp(-s.tau / mu);
  l.transmittance = std::min(1.0, direct + std::max(0.0, slab.transmittance - std::exp(-s.tau / 0.6)));
  l.emissivity = std::clamp(1.0 - slab.transmittance, 0.0, 1.0);
  return l;
}

double rayleigh_down(double tau, double mu_sun) {
  if (mu_sun <= 0) return 0;
  const double direct = std::exp(-tau / mu_sun);
  return direct + 0.5 * (1 - direct);
}

double rayleigh_up(double tau, double mu) {
  const double direct = std::exp(-tau / std::max(mu, 0.02));
  return direct + 0.5 * (1 - direct);
}

double rayleigh_path(double e0, double tau, double mu_v, double mu_s, double cos_scatter) {
  if (mu_s <= 0 || tau <= 0) return 0;
  mu_v = std::max(mu_v, 0.02);
  return e0 * atmosphere::rayleigh_phase(cos_scatter) / (4 * M_PI) * mu_s / (mu_s + mu_v) *
         (1 - std::exp(-tau * (1 / mu_s + 1 / mu_v)));
}

double rayleigh_sky(double e0, double tau, double mu_v, double mu_s, double cos_scatter) {
  if (mu_s <= 0 || tau <= 0) return 0;
  mu_v = std::max(mu_v, 0.02);
  const double p = e0 * atmosphere::rayleigh_phase(cos_scatter) / (4 * M_PI);
  if (std::abs(mu_s - mu_v) < 1e-6) return p * tau / mu_s * std::exp(-tau / mu_s);
  return p * mu_s / (mu_s - mu_v) * (std::exp(-tau / mu_s) - std::exp(-tau / mu_v));
}

double grazing_air_mass(double h, double scale_height) {
  return std::sqrt(2 * M_PI * (earth::radius_m + std::max(0.0, h)) / scale_height);
}

}  // namespace nephos::render
