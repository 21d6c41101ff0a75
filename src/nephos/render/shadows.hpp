#pragma once
// Cloud shadows: how much cloud lies between points and the Sun. Rays from many points in one
// direction (the Sun's) through a cloud shell, sampled in lockstep like the view rays (the
// shell's batched classify()), each giving the length of its path inside cloud.
#include <cstddef>

#include "nephos/clouds/cloud_model.hpp"

namespace nephos::render {

/// The length [m] of cloud (the cloud function above its threshold) along the rays o[i] + t d,
/// t > 0, through `shell`, into out[i]: the midpoint rule over `steps` equal steps of the part of
/// each ray's path inside the shell that lies within its altitude window (on rays that climb;
/// elsewhere the whole path), where alone the cloud can be. Rays that start above the shell or
/// whose path the shell's empty-space skip finds clear cost one lookup. With footprint_m (per ray, its width [m]): the
/// expected length through the filtered cloud (CloudShell::classify_filtered), sum of ds coverage(u).
/// chance (optional, per ray): the chance that the ray meets cloud at all (0 or 1 unfiltered), so
/// that out / chance is the length through cloud where it meets some.
void cloud_length_towards(const clouds::CloudShell& shell, const earth::Vec3* o, const earth::Vec3& d, std::size_t n,
                          int steps, double* out, const double* footprint_m = nullptr, double* chance = nullptr);

}  // namespace nephos::render
