#include "nephos/realtime/sprite_textures.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/glm.hpp>

#include "nephos/core/error.hpp"
#include "nephos/optics/optics.hpp"

namespace nephos::realtime {

const SlabSpec& slab_spec(int type) {
  // Optical depths within the ISCCP classes (Rossow & Schiffer 1999, visible optical depth):
  // altostratus 3.6-23 (8, near its geometric middle 9), cirrus below 3.6 (1.2), stratus above
  // 23 (30).
  // Thickness over the renderer's tile (3 km; cirrus 6 km): altostratus and cirrus about 1 km
  // and 1.5 km deep, fog 300 m. Asymmetry: water droplets 0.85, ice crystals 0.75 (visible).
  static const std::array<SlabSpec, slab_types> specs{{
      {1000.0 / 3000, 8.0, 0.42, 0.85, 1},  // altostratus: a deck with breaks
      {1500.0 / 6000, 1.2, 0.50, 0.75, 4},  // cirrus: thin fibres along the tile's x
      {300.0 / 3000, 30.0, 0.30, 0.85, 1},  // low stratus / fog: nearly uniform and opaque
  }};
  if (type < 0 || type >= slab_types) throw ValueError("no slab spec for flat-layer type " + std::to_string(type));
  return specs[static_cast<std::size_t>(type)];
}

double slab_source(double tau, double asymmetry, bool from_below) {
  const double g = std::clamp(asymmetry, 0.0, 1.0);
  if (tau < 1e-6) return from_below ? g : 1 - g;  // single scattering, forwards or backwards
  const optics::SlabResult rt = optics::two_stream_slab((1 - g) * tau, 1.0);
  const double opacity = -std::expm1(-tau);
  // Transmitted light less the direct beam (which the layer's opacity already lets through as
  // the background), or reflected light; neither exceeds the opacity, so the texel stays a
  // valid premultiplied colour.
  return (from_below ? rt.transmittance - std::exp(-tau) : rt.reflectance) / opacity;
}

namespace {
// The optical depths of every texel of `spec`'s slab, the same from either side: vertical, and
// the mean vertical depth its 45-degree path crosses.
struct SlabDepths {
  std::vector<double> vertical, slant;
};

SlabDepths slab_depths(const noise::Texture3D& fractal, const SlabSpec& spec, int size) {
  if (size < 1) throw ValueError("slab view size must be >= 1", {.key = "size"});
  constexpr int steps = 32;
  const double h = spec.thickness_tiles, dz = h / steps;
  // The 45-degree path crosses the slab over a horizontal run equal to its depth, centred on
  // the texel; azimuth between +x and +y (a fixed choice: the pattern is isotropic but for the
  // cirrus fibres, which it then crosses obliquely).
  const double run = 1 / std::sqrt(2.0);
  auto extinction = [&](double u, double v, double z) {
    const double n = fractal.sample(static_cast<float>(u), static_cast<float>(spec.stretch * v), static_cast<float>(z));
    return std::max(0.0, n - spec.density_threshold);
  };
  SlabDepths d{std::vector<double>(static_cast<std::size_t>(size) * size), {}};
  d.slant.resize(d.vertical.size());
  double sum = 0;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double u = (x + 0.5) / size, v = (y + 0.5) / size;
      double cv = 0, cs = 0;
      for (int k = 0; k < steps; ++k) {
        const double z = 0.25 + (k + 0.5) * dz, off = ((k + 0.5) * dz - 0.5 * h) * run;
        cv += extinction(u, v, z) * dz;
        cs += extinction(u + off, v + off, z) * dz;
      }
      const std::size_t i = static_cast<std::size_t>(y) * size + x;
      d.vertical[i] = cv, d.slant[i] = cs;
      sum += cv;
    }
  // Extinction per unit fractal excess, so that the vertical depth averages the spec's.
  const double kappa = sum > 0 ? spec.mean_optical_depth * static_cast<double>(d.vertical.size()) / sum : 0.0;
  for (std::size_t i = 0; i < d.vertical.size(); ++i) d.vertical[i] *= kappa, d.slant[i] *= kappa;
  return d;
}

std::vector<SlabTexel> slab_views(const SlabDepths& d, const SlabSpec& spec, bool from_below) {
  std::vector<SlabTexel> out(d.vertical.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double tau_v = d.vertical[i];
    const double tau_mean = d.slant[i];              // the mean vertical depth the slant path crosses
    const double tau_s = std::sqrt(2.0) * tau_mean;  // along the path: dz / sin 45
    const double a_v = -std::expm1(-tau_v), a_s = -std::expm1(-tau_s);
    out[i] = {static_cast<float>(a_v * slab_source(tau_v, spec.asymmetry, from_below)), static_cast<float>(a_v),
              static_cast<float>(a_s * slab_source(tau_mean, spec.asymmetry, from_below)), static_cast<float>(a_s)};
  }
  return out;
}
}  // namespace

std::vector<SlabTexel> bake_slab_views(const noise::Texture3D& fractal, const SlabSpec& spec, bool from_below,
                                       int size) {
  return slab_views(slab_depths(fractal, spec, size), spec, from_below);
}

std::vector<std::uint8_t> bake_sprite_textures(std::uint64_t seed) {
  constexpr int n = sprite_texture_size;
  const noise::Texture3D tex = noise::bake({noise::FractalKind::perlin, 4, 3, 0.5, false}, seed, 32);
  std::vector<std::uint8_t> out(static_cast<std::size_t>(texture_layer_count) * n * n * 4);
  auto texel = [&](int layer, int x, int y) {
    return out.data() + ((static_cast<std::size_t>(layer) * n + y) * n + x) * 4;
  };
  auto byte = [](double v) { return static_cast<std::uint8_t>(std::lround(255 * std::clamp(v, 0.0, 1.0))); };
  // Sprite puffs: an ellipsoid (round for cumulus, flattened for stratocumulus) modulated by the
  // fractal, its column density integrated along five view elevations (-60 .. 60 degrees);
  // opacity 1 - exp(-4 column), premultiplied white (the renderer shades it per vertex).
  for (int type = 0; type < 2; ++type)
    for (int l = 0; l < sprite_views_per_type; ++l) {
      const double el = (-60.0 + 30.0 * l) * M_PI / 180;
      const double flat = type == 0 ? 1.0 : 0.45;
      const glm::dvec3 view{0, std::cos(el), std::sin(el)}, right{1, 0, 0};
      const glm::dvec3 up = glm::cross(right, view);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const double u = (x + 0.5) / n * 2 - 1, v = 1 - (y + 0.5) / n * 2;
          double column = 0;
          for (int k = 0; k < 32; ++k) {
            const double t = (k + 0.5) / 32 * 2 - 1;
            const glm::dvec3 p = u * right + v * up + t * view;
            const double r2 = p.x * p.x + p.y * p.y + (p.z / flat) * (p.z / flat);
            if (r2 >= 1) continue;
            const double f = tex.sample(static_cast<float>(p.x * 0.5 + 7), static_cast<float>(p.y * 0.5 + 3),
                                        static_cast<float>(p.z * 0.5 + 5));
            column += std::max(0.0, (1 - r2) * (0.4 + f) - 0.35) * (2.0 / 32);
          }
          std::uint8_t* q = texel(type * sprite_views_per_type + l, x, y);
          q[0] = q[1] = q[2] = q[3] = byte(1 - std::exp(-4 * column));
        }
    }
  // Flat layers: per type the slab seen from below, then from above, two views in each texel.
  for (int type = 0; type < slab_types; ++type) {
    const SlabDepths depths = slab_depths(tex, slab_spec(type), n);  // both sides' (integrated once)
    for (const bool from_below : {true, false}) {
      const auto views = slab_views(depths, slab_spec(type), from_below);
      const int layer = first_slab_layer + 2 * type + (from_below ? 0 : 1);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const SlabTexel& s = views[static_cast<std::size_t>(y) * n + x];
          std::uint8_t* q = texel(layer, x, y);
          q[0] = byte(s.c_vertical), q[1] = byte(s.a_vertical), q[2] = byte(s.c_slant), q[3] = byte(s.a_slant);
        }
    }
  }
  // A soft round particle: opacity (1 - r^2)^2, smooth to zero at the rim.
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double u = (x + 0.5) / n * 2 - 1, v = (y + 0.5) / n * 2 - 1;
      const double r2 = std::min(1.0, u * u + v * v);
      std::uint8_t* q = texel(particle_layer, x, y);
      q[0] = q[1] = q[2] = q[3] = byte((1 - r2) * (1 - r2));
    }
  return out;
}

std::array<float, 4> layer_mean_texel(const std::vector<std::uint8_t>& pixels, int layer) {
  constexpr std::size_t texels = static_cast<std::size_t>(sprite_texture_size) * sprite_texture_size;
  if (layer < 0 || layer >= texture_layer_count || pixels.size() < texels * 4 * texture_layer_count)
    throw ValueError("no texture layer " + std::to_string(layer) + " in the sprite array", {.key = "layer"});
  const std::uint8_t* p = pixels.data() + static_cast<std::size_t>(layer) * texels * 4;
  std::array<double, 4> sum{};
  for (std::size_t k = 0; k < texels; ++k)
    for (std::size_t c = 0; c < 4; ++c) sum[c] += p[4 * k + c];
  std::array<float, 4> mean{};
  for (std::size_t c = 0; c < 4; ++c) mean[c] = static_cast<float>(sum[c] / (255.0 * static_cast<double>(texels)));
  return mean;
}

}  // namespace nephos::realtime
