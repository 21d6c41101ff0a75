#include "nephos/lbm/lattice.hpp"

#include <fmt/format.h>

#include <regex>

#include "nephos/core/error.hpp"

namespace nephos::lbm {

std::string Grid3::describe() const { return fmt::format("{}x{}x{}", nx, ny, nz); }

Grid3 Grid3::parse(const std::string& text) {
  static const std::regex re(R"((\d+)x(\d+)x(\d+))");
  std::smatch m;
  if (!std::regex_match(text, m, re)) throw ValueError("expected NXxNYxNZ, got '" + text + "'", {.key = "--grid"});
  Grid3 g{std::stoi(m[1]), std::stoi(m[2]), std::stoi(m[3])};
  for (int n : {g.nx, g.ny, g.nz})
    if (n < 4 || n > 4096)
      throw ValueError("each grid dimension must be 4..4096, got '" + text + "'", {.key = "--grid"});
  return g;
}

RowSources row_sources(const Grid3& g, const float* f, int y, int z, ZBoundary zb) {
  RowSources r;
  r.nx = g.nx;
  const std::size_t cells = g.cells();
  for (int i = 0; i < d3q19::q; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    int sy = y - d3q19::cy[iu], sz = z - d3q19::cz[iu];
    sy = (sy + g.ny) % g.ny;
    if (zb == ZBoundary::periodic) {
      sz = (sz + g.nz) % g.nz;
    } else if (sz < 0 || sz >= g.nz) {  // halfway bounce-back at the wall
      r.row[iu] = f + static_cast<std::size_t>(d3q19::opposite[iu]) * cells + g.index(0, y, z);
      r.shift[iu] = 0;
      continue;
    }
    r.row[iu] = f + iu * cells + g.index(0, sy, sz);
    r.shift[iu] = d3q19::cx[iu];
  }
  return r;
}

}  // namespace nephos::lbm
