#include "nephos/lbm/lbm_io.hpp"

#include "nephos/io/netcdf_writer.hpp"

namespace nephos::lbm {

void write_lattice_netcdf(const std::filesystem::path& path, const Grid3& g, const std::vector<LatticeField>& fields,
                          const std::vector<std::pair<std::string, std::string>>& attributes) {
  io::NetcdfWriter nc(path);
  nc.add_dimension("z", static_cast<std::size_t>(g.nz));
  nc.add_dimension("y", static_cast<std::size_t>(g.ny));
  nc.add_dimension("x", static_cast<std::size_t>(g.nx));
  std::vector<int> coord;
  for (const char* axis : {"z", "y", "x"}) {
    const int v = nc.add_variable(axis, io::NcType::f64, {axis});
    nc.put_attribute(v, "units", "1");
    nc.put_attribute(v, "long_name", std::string("lattice cell centre, ") + axis + (axis[0] == 'z' ? " (up)" : ""));
    nc.put_attribute(v, "axis", std::string(1, static_cast<char>(axis[0] - 'a' + 'A')));
    coord.push_back(v);
  }
  std::vector<int> vars;
  for (const auto& f : fields) {
    const int v = nc.add_variable(f.name, io::NcType::f32, {"z", "y", "x"});
    nc.put_attribute(v, "long_name", f.long_name);
    nc.put_attribute(v, "units", f.units);
    vars.push_back(v);
  }
  nc.put_attribute(io::NetcdfWriter::global, "Conventions", "CF-1.8");
  for (const auto& [k, v] : attributes) nc.put_attribute(io::NetcdfWriter::global, k, v);
  nc.end_definitions();
  const int n[3] = {g.nz, g.ny, g.nx};
  for (int a = 0; a < 3; ++a) {
    std::vector<double> c(static_cast<std::size_t>(n[a]));
    for (int i = 0; i < n[a]; ++i) c[static_cast<std::size_t>(i)] = i + 0.5;
    nc.write(coord[static_cast<std::size_t>(a)], c.data());
  }
  for (std::size_t k = 0; k < fields.size(); ++k) nc.write(vars[k], fields[k].data->data());
  nc.close();
}

}  // namespace nephos::lbm
