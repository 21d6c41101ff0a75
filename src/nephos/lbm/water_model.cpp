#include "nephos/lbm/water_model.hpp"

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"

namespace nephos::lbm {

WaterModelParams WaterModelParams::from(const ParamDict& dict) {
  WaterModelParams p;
  const ParamDict m = dict.table("water");
  p.rho10 = m.get("rho10", p.rho10);
  p.rho20 = m.get("rho20", p.rho20);
  p.rest_fraction = m.get("rest_fraction", p.rest_fraction);
  p.xi_vapour = m.get("xi_vapour", p.xi_vapour);
  p.xi_temperature = m.get("xi_temperature", p.xi_temperature);
  p.g12 = m.get("g12", p.g12);
  p.g22 = m.get("g22", p.g22);
  p.buoyancy = m.get("buoyancy", p.buoyancy);
  p.buoyancy_reference = m.get("buoyancy_reference", p.buoyancy_reference);
  p.temperature_bottom = m.get("temperature_bottom", p.temperature_bottom);
  p.temperature_top = m.get("temperature_top", p.temperature_top);
  p.silos = m.get("silos", p.silos);
  p.silo_radius_min = m.get("silo_radius_min", p.silo_radius_min);
  p.silo_radius_max = m.get("silo_radius_max", p.silo_radius_max);
  p.silo_height_min = m.get("silo_height_min", p.silo_height_min);
  p.silo_height_max = m.get("silo_height_max", p.silo_height_max);
  p.vapour_background = m.get("vapour_background", p.vapour_background);
  if (!(p.xi_vapour > 0.5) || !(p.xi_temperature > 0.5))
    throw ConfigError("relaxation times must exceed 1/2", {.file = dict.source(), .key = "water.xi_*"});
  if (p.rest_fraction < 0 || p.rest_fraction > 1)
    throw ConfigError("must be in [0, 1]", {.file = dict.source(), .key = "water.rest_fraction"});
  return p;
}

std::vector<Silo> make_silos(const Grid3& g, const WaterModelParams& p, std::uint64_t seed) {
  std::vector<Silo> s;
  const double size = std::min(g.nx, g.ny);
  for (int k = 0; k < p.silos; ++k) {
    const auto u = [&](std::uint64_t c) { return uniform01(seed, 0x5110, static_cast<std::uint64_t>(k), c); };
    s.push_back({u(0) * g.nx, u(1) * g.ny, (p.silo_radius_min + u(2) * (p.silo_radius_max - p.silo_radius_min)) * size,
                 (p.silo_height_min + u(3) * (p.silo_height_max - p.silo_height_min)) * g.nz});
  }
  return s;
}

namespace {
// Reference densities of the shifted populations: vapour rho10, temperature 0.5.
double reference(const WaterModelParams& p, int c) { return c == 0 ? p.rho10 : 0.5; }
}  // namespace

WaterModel::WaterModel(Grid3 grid, WaterModelParams params) : g_(grid), p_(params) {
  const std::size_t n = g_.cells();
  for (int c = 0; c < 2; ++c) {
    f_[c].assign(d3q19::q * n, 0.0f);
    tmp_[c].assign(d3q19::q * n, 0.0f);
    rho_[c].assign(n, 0.0f);
  }
  psi1_.assign(n, 0.0f);
}

void WaterModel::initialise(const std::vector<Silo>& silos, std::uint64_t seed) {
  const std::size_t n = g_.cells();
  const float d = static_cast<float>(p_.rest_fraction);
#pragma omp parallel for schedule(static)
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < g_.ny; ++y)
      for (int x = 0; x < g_.nx; ++x) {
        const std::size_t cell = g_.index(x, y, z);
        double vapour = p_.vapour_background * p_.rho10;
        for (const Silo& s : silos) {
          // Minimum-image horizontal distance on the torus.
          double dx = std::abs(x + 0.5 - s.x), dy = std::abs(y + 0.5 - s.y);
          dx = std::min(dx, g_.nx - dx);
          dy = std::min(dy, g_.ny - dy);
          const double zc = z + 0.5;
          const double dist =
              zc <= s.height ? std::hypot(dx, dy) : std::sqrt(dx * dx + dy * dy + (zc - s.height) * (zc - s.height));
          double v;
          if (dist <= s.radius) {
            v = p_.rho10 * (0.99 + 0.02 * uniform01(seed, 0x7a90, cell));
          } else {
            const double t = std::min(1.0, (dist - s.radius) / s.radius);
            v = p_.rho10 + t * (p_.vapour_background * p_.rho10 - p_.rho10);
          }
          vapour = std::max(vapour, v);
        }
        const double temp = p_.temperature_bottom + (p_.temperature_top - p_.temperature_bottom) *
                                                        (g_.nz > 1 ? static_cast<double>(z) / (g_.nz - 1) : 0.0);
        float feq[d3q19::q];
        d3q19::equilibrium_shifted<float>(static_cast<float>(vapour - reference(p_, 0)), static_cast<float>(vapour), 0,
                                          0, 0, d, feq);
        for (int i = 0; i < d3q19::q; ++i) f_[0][static_cast<std::size_t>(i) * n + cell] = feq[i];
        d3q19::equilibrium_shifted<float>(static_cast<float>(temp - reference(p_, 1)), static_cast<float>(temp), 0, 0,
                                          0, d, feq);
        for (int i = 0; i < d3q19::q; ++i) f_[1][static_cast<std::size_t>(i) * n + cell] = feq[i];
      }
  step_ = 0;
}

void WaterModel::step() {
  const std::size_t n = g_.cells();
  const ZBoundary zb = p_.periodic_z ? ZBoundary::periodic : ZBoundary::walls;
  const float rho10 = static_cast<float>(p_.rho10);
  // Pass 1: stream both components; densities and Psi_1.
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < g_.ny; ++y)
      for (int c = 0; c < 2; ++c) {
        const RowSources src = row_sources(g_, f_[c].data(), y, z, zb);
        const std::size_t base = g_.index(0, y, z);
        float* out = tmp_[c].data() + base;
        float* rho = rho_[c].data() + base;  // here: rho - rho_ref
        for (int x = 0; x < g_.nx; ++x) rho[x] = 0;
        for (int i = 0; i < d3q19::q; ++i) {
          float* o = out + static_cast<std::size_t>(i) * n;
          for (int x = 0; x < g_.nx; ++x) {
            o[x] = *src.at(i, x);
            rho[x] += o[x];
          }
        }
        const float ref = static_cast<float>(reference(p_, c));
        for (int x = 0; x < g_.nx; ++x) rho[x] += ref;
        if (c == 0)
          for (int x = 0; x < g_.nx; ++x)
            psi1_[base + static_cast<std::size_t>(x)] = rho10 * (1.0f - std::exp(-rho[x] / rho10));
      }

  // Pass 2: forces, equilibrium velocities, collision.
  const double v2 = 1.0;  // (lambda / tau)^2
  const float xi[2] = {static_cast<float>(p_.xi_vapour), static_cast<float>(p_.xi_temperature)};
  const float d = static_cast<float>(p_.rest_fraction);
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < g_.nz; ++z)
    for (int y = 0; y < g_.ny; ++y)
      for (int x = 0; x < g_.nx; ++x) {
        const std::size_t cell = g_.index(x, y, z);
        // Isotropic gradients of Psi_1 and Psi_2 = rho_2 (walls: the neighbour beyond is the cell itself).
        double g1[3] = {0, 0, 0}, g2[3] = {0, 0, 0};
        for (int i = 1; i < d3q19::q; ++i) {
          const auto iu = static_cast<std::size_t>(i);
          const int sx = (x + d3q19::cx[iu] + g_.nx) % g_.nx, sy = (y + d3q19::cy[iu] + g_.ny) % g_.ny;
          int sz = z + d3q19::cz[iu];
          if (p_.periodic_z)
            sz = (sz + g_.nz) % g_.nz;
          else
            sz = std::clamp(sz, 0, g_.nz - 1);
          const std::size_t nb = g_.index(sx, sy, sz);
          const double w = d3q19::gradient_weight(i);
          const double c3[3] = {static_cast<double>(d3q19::cx[iu]), static_cast<double>(d3q19::cy[iu]),
                                static_cast<double>(d3q19::cz[iu])};
          for (int a = 0; a < 3; ++a) {
            g1[a] += w * psi1_[nb] * c3[a];
            g2[a] += w * rho_[1][nb] * c3[a];
          }
        }
        const double r1 = rho_[0][cell], r2 = rho_[1][cell], psi1 = psi1_[cell];
        const double g11 = -v2 * ((1 - p_.rest_fraction) / p_.rho10) * (1 + p_.rho20 - r2);  // eq. (31)
        double force[2][3];
        for (int a = 0; a < 3; ++a) {
          force[0][a] = -psi1 * (g11 * g1[a] + p_.g12 * g2[a]);
          force[1][a] = -r2 * (p_.g12 * g1[a] + p_.g22 * g2[a]);
        }
        force[0][2] += r1 * p_.buoyancy * (r2 - p_.buoyancy_reference);
        // Momenta and the common equilibrium velocity (eq. 9).
        double j[2][3] = {{0, 0, 0}, {0, 0, 0}};
        for (int c = 0; c < 2; ++c)
          for (int i = 0; i < d3q19::q; ++i) {
            const auto iu = static_cast<std::size_t>(i);
            const double f = tmp_[c][iu * n + cell];
            j[c][0] += f * d3q19::cx[iu];
            j[c][1] += f * d3q19::cy[iu];
            j[c][2] += f * d3q19::cz[iu];
          }
        const double rho[2] = {r1, r2};
        double ueq[3];
        const double denom = r1 / xi[0] + r2 / xi[1];
        for (int a = 0; a < 3; ++a) ueq[a] = (j[0][a] / xi[0] + j[1][a] / xi[1]) / denom;
        for (int c = 0; c < 2; ++c) {
          // Collision in double; the populations are rounded to FP32 once, on store.
          double feq[d3q19::q];
          const double s = xi[c] / rho[c];  // eq. (10), tau = 1
          // rho - rho_ref from the shifted populations themselves (no cancellation against rho_ref).
          double drho = 0;
          for (int i = 0; i < d3q19::q; ++i) drho += tmp_[c][static_cast<std::size_t>(i) * n + cell];
          d3q19::equilibrium_shifted<double>(drho, rho[c], ueq[0] + s * force[c][0], ueq[1] + s * force[c][1],
                                             ueq[2] + s * force[c][2], static_cast<double>(d), feq);
          const double omega = 1.0 / xi[c];
          for (int i = 0; i < d3q19::q; ++i) {
            const std::size_t k = static_cast<std::size_t>(i) * n + cell;
            f_[c][k] = static_cast<float>(tmp_[c][k] - omega * (tmp_[c][k] - feq[i]));
          }
        }
      }

  // Fixed-temperature, zero-velocity bottom and top layers.
  if (!p_.periodic_z) {
    for (int z : {0, g_.nz - 1}) {
      const float temp = static_cast<float>(z == 0 ? p_.temperature_bottom : p_.temperature_top);
#pragma omp parallel for schedule(static)
      for (int y = 0; y < g_.ny; ++y)
        for (int x = 0; x < g_.nx; ++x) {
          const std::size_t cell = g_.index(x, y, z);
          float feq[d3q19::q];
          d3q19::equilibrium_shifted<float>(rho_[0][cell] - static_cast<float>(reference(p_, 0)), rho_[0][cell], 0, 0,
                                            0, d, feq);
          for (int i = 0; i < d3q19::q; ++i) f_[0][static_cast<std::size_t>(i) * n + cell] = feq[i];
          d3q19::equilibrium_shifted<float>(temp - static_cast<float>(reference(p_, 1)), temp, 0, 0, 0, d, feq);
          for (int i = 0; i < d3q19::q; ++i) f_[1][static_cast<std::size_t>(i) * n + cell] = feq[i];
        }
    }
  }
  ++step_;
}

std::vector<float> WaterModel::density(int c) const {
  const std::size_t n = g_.cells();
  std::vector<float> out(n, 0.0f);
  const float ref = static_cast<float>(reference(p_, c));
#pragma omp parallel for schedule(static)
  for (std::size_t cell = 0; cell < n; ++cell) {
    float s = ref;
    for (int i = 0; i < d3q19::q; ++i) s += f_[c][static_cast<std::size_t>(i) * n + cell];
    out[cell] = s;
  }
  return out;
}

double WaterModel::total(int c) const {
  double s = reference(p_, c) * static_cast<double>(g_.cells());
  for (float v : f_[c]) s += v;
  return s;
}

bool WaterModel::check(std::string& what, std::size_t& cell) const {
  const auto v = vapour(), t = temperature();
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (!(v[k] >= 0 && v[k] <= 100 * p_.rho10)) {
      what = fmt::format("vapour density {}", v[k]);
      cell = k;
      return false;
    }
    if (!(t[k] >= 0 && t[k] <= 10)) {
      what = fmt::format("temperature {}", t[k]);
      cell = k;
      return false;
    }
  }
  return true;
}

namespace {
constexpr char magic[16] = "NEPHOS-LBM-CK1";
}

void WaterModel::save(const std::filesystem::path& path) const {
  AtomicFile out(path);
  {
    std::ofstream os(out.temp_path(), std::ios::binary);
    if (!os) throw IoError("cannot open checkpoint for writing", {.file = path.string()});
    os.write(magic, sizeof magic);
    const std::int64_t hdr[4] = {g_.nx, g_.ny, g_.nz, step_};
    os.write(reinterpret_cast<const char*>(hdr), sizeof hdr);
    os.write(reinterpret_cast<const char*>(&p_), sizeof p_);
    for (int c = 0; c < 2; ++c)
      os.write(reinterpret_cast<const char*>(f_[c].data()), static_cast<std::streamsize>(f_[c].size() * sizeof(float)));
    if (!os.flush()) throw IoError("checkpoint write failed (disk full?)", {.file = path.string()});
  }
  out.commit();
}

WaterModel WaterModel::load(const std::filesystem::path& path) {
  std::ifstream is(path, std::ios::binary);
  if (!is) throw IoError("cannot open checkpoint", {.file = path.string()});
  char m[16] = {};
  is.read(m, sizeof m);
  if (std::memcmp(m, magic, sizeof magic) != 0)
    throw FormatError("not a nephos lbm checkpoint", {.file = path.string()});
  std::int64_t hdr[4];
  is.read(reinterpret_cast<char*>(hdr), sizeof hdr);
  WaterModelParams p;
  is.read(reinterpret_cast<char*>(&p), sizeof p);
  if (!is || hdr[0] < 4 || hdr[1] < 4 || hdr[2] < 4 || hdr[0] > 4096 || hdr[1] > 4096 || hdr[2] > 4096)
    throw FormatError("corrupt checkpoint header", {.file = path.string()});
  WaterModel w(Grid3{static_cast<int>(hdr[0]), static_cast<int>(hdr[1]), static_cast<int>(hdr[2])}, p);
  w.step_ = hdr[3];
  for (int c = 0; c < 2; ++c)
    is.read(reinterpret_cast<char*>(w.f_[c].data()), static_cast<std::streamsize>(w.f_[c].size() * sizeof(float)));
  if (!is) throw FormatError("truncated checkpoint", {.file = path.string()});
  return w;
}

}  // namespace nephos::lbm
