#pragma once
// OpenVDB output of dense 3D fields (loadable by Blender, Houdini and other VDB tools),
// written atomically. Values at or below `inactive_below` are left as background (sparse).
#include <filesystem>
#include <string>
#include <vector>

namespace nephos::io {

struct DenseField {
  std::string name;            ///< grid name ("density" is what renderers look for)
  int nx = 0, ny = 0, nz = 0;  ///< x fastest in `data`
  const std::vector<float>* data = nullptr;
  double voxel_size = 1.0;      ///< world units per voxel
  bool fog_volume = true;       ///< grid class: fog volume (densities) or unknown
  float inactive_below = 0.0f;  ///< values <= this stay inactive background (0)
};

void write_vdb(const std::filesystem::path& path, const std::vector<DenseField>& fields);

/// Reads one float grid back into a dense array of the given size (for tests and tools).
std::vector<float> read_vdb_dense(const std::filesystem::path& path, const std::string& name, int nx, int ny, int nz,
                                  std::size_t* active_voxels = nullptr);

}  // namespace nephos::io
