#pragma once
// Outputs of the particle system: the particle set as PLY and the column cloud fields as
// CF-NetCDF. Both are written atomically (temporary name, then rename).
#include <filesystem>
#include <vector>

#include "nephos/particles/cloud_columns.hpp"
#include "nephos/particles/particle_system.hpp"

namespace nephos::particles {

/// Particles as PLY points (x, y, z in metres of the planar grid; grey as RGB; opacity as alpha;
/// radius); the header's comments name the grid's centre, the time and the source.
void write_particles_ply(const std::filesystem::path& path, const Particles& p, const std::vector<float>& grey,
                         const ParticleWeather& w, const UtcTime& time);

/// Cloud base and top height [m] and optical thickness of one frame's columns, on x/y [m]
/// coordinates, CF-1.8 (standard name atmosphere_optical_thickness_due_to_cloud).
void write_columns_netcdf(const std::filesystem::path& path, const ParticleWeather& w, std::size_t frame);

}  // namespace nephos::particles
