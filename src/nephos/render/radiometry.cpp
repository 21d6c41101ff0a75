#include "nephos/render/radiometry.hpp"

#include <algorithm>
#include <cmath>

#include "nephos/atmosphere/rayleigh.hpp"
#include "nephos/core/simd_math.hpp"
#include "nephos/earth/earth.hpp"
#include "nephos/optics/optics.hpp"

namespace nephos::render {

void cloud_layers(const double* tau, const double* omega, double g, double mu_view, std::size_t n, double* r, double* t,
                  double* e) {
  const double mu = std::clamp(mu_view, 0.05, 1.0);
  constexpr std::size_t chunk = 16;
  for (std::size_t c0 = 0; c0 < n; c0 += chunk) {
    const std::size_t m = std::min(chunk, n - c0);
    alignas(64) double tau_s[chunk], omega_s[chunk], slab_r[chunk], slab_t[chunk], direct[chunk], diffuse[chunk];
    for (std::size_t i = 0; i < m; ++i) {
      const optics::SlabOptics s = optics::similarity_scaled(tau[c0 + i], omega[c0 + i], g);
      tau_s[i] = s.tau, omega_s[i] = s.omega;
    }
    optics::two_stream_slabs(tau_s, omega_s, m, slab_r, slab_t);
    // Seen through the layer: the direct beam along the view and the diffusely transmitted part
    // (the two-stream transmittance less its own direct share at the diffusivity cosine 0.6).
    for (std::size_t i = 0; i < m; ++i) direct[i] = std::exp(-tau_s[i] / mu), diffuse[i] = std::exp(-tau_s[i] / 0.6);
    for (std::size_t i = 0; i < m; ++i) {
      const bool empty = !(tau[c0 + i] > 0);
      r[c0 + i] = empty ? 0.0 : slab_r[i];
      t[c0 + i] = empty ? 1.0 : std::min(1.0, direct[i] + std::max(0.0, slab_t[i] - diffuse[i]));
      e[c0 + i] = empty ? 0.0 : std::clamp(1.0 - slab_t[i], 0.0, 1.0);
    }
  }
}

LayerOptics cloud_layer(double tau, double omega, double g, double mu_view) {
  LayerOptics l;
  cloud_layers(&tau, &omega, g, mu_view, 1, &l.reflectance, &l.transmittance, &l.emissivity);
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
