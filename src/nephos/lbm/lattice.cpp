#include "nephos/lbm/lattice.hpp"

#include <fmt/format.h>

#include <regex>

#include "nephos/core/error.hpp"

namespace nephos::lbm {

std::string Grid3::describe() const { return fmt::format("{}x{}x{}", nx, ny, nz); }

Grid3 Grid3::parse(const std::string& text) {
  static const std::regex re(R"((\d{1,5})x(\d{1,5})x(\d{1,5}))");  // at most 5 digits: no int overflow
  std::smatch m;
  if (!std::regex_match(text, m, re))
    throw ValueError("expected NXxNYxNZ (each 4..4096), got '" + text + "'", {.key = "grid"});
  Grid3 g{std::stoi(m[1]), std::stoi(m[2]), std::stoi(m[3])};
  for (int n : {g.nx, g.ny, g.nz})
    if (n < 4 || n > 4096)
      throw ValueError("each grid dimension must be 4..4096, got '" + text + "'", {.key = "grid"});
  return g;
}

}  // namespace nephos::lbm
