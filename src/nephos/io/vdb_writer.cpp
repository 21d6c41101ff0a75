#include "nephos/io/vdb_writer.hpp"

#include <openvdb/openvdb.h>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"

namespace nephos::io {

void write_vdb(const std::filesystem::path& path, const std::vector<DenseField>& fields) {
  openvdb::initialize();
  openvdb::GridPtrVec grids;
  for (const auto& f : fields) {
    if (!f.data || f.data->size() != static_cast<std::size_t>(f.nx) * f.ny * f.nz)
      throw ValueError("field '" + f.name + "' does not match its dimensions", {.file = path.string()});
    auto grid = openvdb::FloatGrid::create(0.0f);
    auto acc = grid->getAccessor();
    for (int z = 0; z < f.nz; ++z)
      for (int y = 0; y < f.ny; ++y)
        for (int x = 0; x < f.nx; ++x) {
          const float v = (*f.data)[(static_cast<std::size_t>(z) * f.ny + y) * f.nx + x];
          if (v > f.inactive_below) acc.setValue(openvdb::Coord(x, y, z), v);
        }
    grid->setName(f.name);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(f.voxel_size));
    grid->setGridClass(f.fog_volume ? openvdb::GRID_FOG_VOLUME : openvdb::GRID_UNKNOWN);
    grids.push_back(grid);
  }
  AtomicFile out(path);
  try {
    openvdb::io::File file(out.temp_path().string());
    file.write(grids);
    file.close();
  } catch (const std::exception& e) {
    throw IoError(std::string("OpenVDB: ") + e.what(), {.file = path.string()});
  }
  out.commit();
}

std::vector<float> read_vdb_dense(const std::filesystem::path& path, const std::string& name, int nx, int ny, int nz,
                                  std::size_t* active_voxels) {
  openvdb::initialize();
  try {
    openvdb::io::File file(path.string());
    file.open();
    auto base = file.readGrid(name);
    file.close();
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid) throw FormatError("grid '" + name + "' is not a float grid", {.file = path.string()});
    if (active_voxels) *active_voxels = static_cast<std::size_t>(grid->activeVoxelCount());
    std::vector<float> out(static_cast<std::size_t>(nx) * ny * nz);
    auto acc = grid->getConstAccessor();
    for (int z = 0; z < nz; ++z)
      for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x)
          out[(static_cast<std::size_t>(z) * ny + y) * nx + x] = acc.getValue(openvdb::Coord(x, y, z));
    return out;
  } catch (const openvdb::Exception& e) {
    throw IoError(std::string("OpenVDB: ") + e.what(), {.file = path.string()});
  }
}

}  // namespace nephos::io
