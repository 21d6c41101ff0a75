#pragma once
// The texture array of the sprite-cloud renderer, baked at start-up from nephos's own 3D fractal
// (several view angles per cloud type, no downloaded imagery;
// thesis section 3.1 photographs cumulus and stratocumulus from five angles, altostratus and
// cirrus from three: from below, at 45 degrees, from above).
//
// Layers (64 x 64 RGBA8 each, rows from the top, premultiplied):
//   0-4    cumulus puffs seen from elevations -60 .. 60 degrees (white: r = g = b = a)
//   5-9    stratocumulus puffs, likewise
//   10-15  flat layers, two per type (altostratus, cirrus, low stratus): the slab seen from
//          below, then from above; each texel holds two views of that side, (r, g) = radiance
//          and opacity looking along the vertical, (b, a) = the same at 45 degrees
//   16     a soft round particle (white)
#include <array>
#include <cstdint>
#include <vector>

#include "nephos/noise/fractal_texture.hpp"

namespace nephos::realtime {

inline constexpr int sprite_texture_size = 64;   ///< texels per side of every layer
inline constexpr int sprite_views_per_type = 5;  ///< cumulus and stratocumulus view angles
inline constexpr int first_slab_layer = 2 * sprite_views_per_type;
inline constexpr int slab_types = 3;  ///< altostratus, cirrus, low stratus
inline constexpr int particle_layer = first_slab_layer + 2 * slab_types;
inline constexpr int texture_layer_count = particle_layer + 1;

/// A flat cloud layer as a horizontal slab of the tileable 3D fractal: its extinction is
/// proportional to the fractal's excess over `density_threshold`, scaled so that the vertical
/// optical depth averages `mean_optical_depth` over the tile.
struct SlabSpec {
  double thickness_tiles;     ///< slab thickness / the texture's horizontal period (3 km altostratus)
  double mean_optical_depth;  ///< vertical extinction optical depth, tile average (visible)
  double density_threshold;   ///< fractal value (0..1) below which the air is clear
  double asymmetry;           ///< scattering asymmetry g (similarity scaling of the two-stream)
  int stretch;                ///< fibres along x: the fractal's y frequency times this (cirrus)
};
/// The specs the renderer bakes: altostratus, cirrus, low stratus (docs/realtime.md).
const SlabSpec& slab_spec(int type);

/// One side of a slab at one texel: premultiplied radiance (relative to the incident flux) and
/// opacity, looking along the vertical and at 45 degrees elevation.
struct SlabTexel {
  float c_vertical, a_vertical, c_slant, a_slant;
};

/// Radiance per unit opacity (the source function) of a slab of vertical optical depth `tau`
/// seen from below (diffusely transmitted light, T - exp(-tau)) or above (reflected light, R),
/// from the conservative two-stream relations (3a)/(3b) of the fractal-cloud paper with the similarity-scaled
/// depth (1 - g) tau; opacity 1 - exp(-tau). Limits for tau -> 0: g from below, 1 - g above
/// (single scattering forwards and backwards).
double slab_source(double tau, double asymmetry, bool from_below);

/// The two views of one side of `spec`'s slab at every texel of a size x size tile (rows from
/// the top). The vertical view integrates the extinction down a column; the slant view along a
/// 45-degree path (azimuth between +x and +y, sqrt 2 times as long per unit depth), whose
/// radiance is its opacity times the source function of the mean vertical depth it crosses.
std::vector<SlabTexel> bake_slab_views(const noise::Texture3D& fractal, const SlabSpec& spec, bool from_below,
                                       int size = sprite_texture_size);

/// Every layer of the array (texture_layer_count x 64 x 64 RGBA8), deterministic from `seed`.
std::vector<std::uint8_t> bake_sprite_textures(std::uint64_t seed);

/// The mean texel of layer `layer` of `pixels` (bake_sprite_textures()'s layout), each channel
/// in [0, 1]: the value a fully filtered lookup of that layer converges to.
std::array<float, 4> layer_mean_texel(const std::vector<std::uint8_t>& pixels, int layer);

}  // namespace nephos::realtime
