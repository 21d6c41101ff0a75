#pragma once
// Output of lattice fields: CF-style NetCDF (dimensions z, y, x; lattice units).
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "nephos/lbm/lattice.hpp"

namespace nephos::lbm {

struct LatticeField {
  std::string name, long_name, units;
  const std::vector<float>* data;
};

/// Writes the fields on the grid (x fastest) with integer cell-centre coordinates x, y, z.
void write_lattice_netcdf(const std::filesystem::path& path, const Grid3& g, const std::vector<LatticeField>& fields,
                          const std::vector<std::pair<std::string, std::string>>& attributes);

}  // namespace nephos::lbm
