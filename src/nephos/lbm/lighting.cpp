#include "nephos/lbm/lighting.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "nephos/core/error.hpp"

namespace nephos::lbm {

void LightingParams::set_sun(double azimuth_deg, double elevation_deg, const std::string& key) {
  if (!(std::isfinite(azimuth_deg) && elevation_deg > 0 && elevation_deg <= 90))
    throw ValueError(fmt::format("expected (azimuth, elevation) with a finite azimuth and an elevation in (0, 90] "
                                 "deg, got ({:g}, {:g})",
                                 azimuth_deg, elevation_deg),
                     {.key = key});
  sun_azimuth_deg = azimuth_deg;
  sun_elevation_deg = elevation_deg;
}
namespace {

struct Dir {
  double c[3];
  double unit[3];
  double weight;  // D3Q19 lattice weight
};

std::array<Dir, light_dirs> dirs() {
  std::array<Dir, light_dirs> d{};
  for (int k = 0; k < light_dirs; ++k) {
    const auto i = static_cast<std::size_t>(k + 1);
    const double c[3] = {static_cast<double>(d3q19::cx[i]), static_cast<double>(d3q19::cy[i]),
                         static_cast<double>(d3q19::cz[i])};
    const double len = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    auto& e = d[static_cast<std::size_t>(k)];
    for (int a = 0; a < 3; ++a) e.c[a] = c[a], e.unit[a] = c[a] / len;
    e.weight = k < 6 ? 1.0 / 18.0 : 1.0 / 36.0;
  }
  return d;
}

double hg(double mu, double g) { return (1 - g * g) / std::pow(1 + g * g - 2 * g * mu, 1.5); }

// Column j of the phase matrix for Henyey-Greenstein parameter g'.
std::array<double, light_dirs> column(int j, double gp) {
  const auto d = dirs();
  std::array<double, light_dirs> col{};
  double sum = 0;
  for (int i = 0; i < light_dirs; ++i) {
    const auto& a = d[static_cast<std::size_t>(i)];
    const auto& b = d[static_cast<std::size_t>(j)];
    const double mu = a.unit[0] * b.unit[0] + a.unit[1] * b.unit[1] + a.unit[2] * b.unit[2];
    col[static_cast<std::size_t>(i)] = a.weight * hg(mu, gp);
    sum += col[static_cast<std::size_t>(i)];
  }
  for (double& v : col) v /= sum;
  return col;
}

double column_mean_cosine(const std::array<double, light_dirs>& col, int j) {
  const auto d = dirs();
  double m = 0;
  for (int i = 0; i < light_dirs; ++i) {
    const auto& a = d[static_cast<std::size_t>(i)];
    const auto& b = d[static_cast<std::size_t>(j)];
    m += col[static_cast<std::size_t>(i)] * (a.unit[0] * b.unit[0] + a.unit[1] * b.unit[1] + a.unit[2] * b.unit[2]);
  }
  return m;
}

}  // namespace

PhaseMatrix phase_matrix(double g) {
  if (!(g > -0.95 && g < 0.95))
    throw ValueError("phase-function asymmetry must be in (-0.95, 0.95)", {.key = "asymmetry"});
  PhaseMatrix p{};
  for (int j = 0; j < light_dirs; ++j) {
    // Solve for the discrete parameter g' whose column has mean cosine g (bisection; the mean
    // cosine increases monotonically with g').
    double lo = -0.999, hi = 0.999;
    for (int it = 0; it < 100; ++it) {
      const double mid = 0.5 * (lo + hi);
      (column_mean_cosine(column(j, mid), j) < g ? lo : hi) = mid;
    }
    const auto col = column(j, 0.5 * (lo + hi));
    for (int i = 0; i < light_dirs; ++i)
      p[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = col[static_cast<std::size_t>(i)];
  }
  return p;
}

double mean_cosine(const PhaseMatrix& p, int j) {
  std::array<double, light_dirs> col{};
  for (int i = 0; i < light_dirs; ++i)
    col[static_cast<std::size_t>(i)] = p[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
  return column_mean_cosine(col, j);
}

LightingSolver::LightingSolver(Grid3 grid, std::vector<float> density, LightingParams params)
    : LightingSolver(grid, std::move(density), params, 0, grid.ny, 0) {}

LightingSolver::LightingSolver(Grid3 grid, std::vector<float> density, LightingParams params, int y_begin, int y_end)
    : LightingSolver(grid, std::move(density), params, y_begin, y_end, 1) {}

LightingSolver::LightingSolver(Grid3 grid, std::vector<float> density, LightingParams params, int y_begin, int y_end,
                               int halo)
    : global_(grid),
      y_begin_(y_begin),
      halo_(halo),
      p_(params),
      phase_(phase_matrix(params.asymmetry)),
      isotropic_(params.asymmetry == 0) {
  if (!(y_begin >= 0 && y_begin < y_end && y_end <= grid.ny))
    throw ValueError(
        fmt::format("lighting slab rows {}..{} outside the grid's 0..{}", y_begin, y_end - 1, grid.ny - 1));
  const int own = y_end - y_begin;
  g_ = {grid.nx, own + 2 * halo, grid.nz};
  const std::size_t own_cells = static_cast<std::size_t>(grid.nx) * own * grid.nz;
  if (density.size() != own_cells) throw ValueError("density field does not match the lighting grid");
  const std::size_t n = g_.cells();
  sigma_s_.assign(n, 0.0f);  // halo rows: never collided
  sigma_a_.assign(n, 0.0f);
  for (int z = 0; z < grid.nz; ++z)
    for (int yo = 0; yo < own; ++yo)
      for (int x = 0; x < grid.nx; ++x) {
        const std::size_t c = g_.index(x, halo + yo, z);
        const double rho =
            std::clamp(static_cast<double>(density[(static_cast<std::size_t>(z) * own + yo) * grid.nx + x]), 0.0, 1.0);
        sigma_s_[c] = static_cast<float>(p_.sigma_s_per_density * rho);
        sigma_a_[c] = static_cast<float>(p_.sigma_a_per_density * rho);
        if (sigma_s_[c] + sigma_a_[c] > 1.0f) throw ValueError("sigma_s + sigma_a must not exceed 1 per lattice step");
      }
  i_.assign(g_.population_size(light_dirs), 0.0f);  // padding between directions stays zero
  next_.assign(i_.size(), 0.0f);
  if (!p_.periodic) {
    // Light travels along -(direction towards the sun); inject along the three lattice
    // directions closest to it, weighted by their cosine to it.
    const double ea = p_.sun_elevation_deg * M_PI / 180, az = p_.sun_azimuth_deg * M_PI / 180;
    const double travel[3] = {-std::cos(ea) * std::cos(az), -std::cos(ea) * std::sin(az), -std::sin(ea)};
    std::vector<std::pair<double, int>> cosines;
    const auto d = dirs();
    for (int k = 0; k < light_dirs; ++k) {
      const auto& u = d[static_cast<std::size_t>(k)].unit;
      cosines.emplace_back(u[0] * travel[0] + u[1] * travel[1] + u[2] * travel[2], k);
    }
    std::sort(cosines.rbegin(), cosines.rend());
    double sum = 0;
    for (int k = 0; k < 3; ++k) sum += std::max(0.0, cosines[static_cast<std::size_t>(k)].first);
    for (int k = 0; k < 3; ++k)
      if (cosines[static_cast<std::size_t>(k)].first > 0)
        sun_.emplace_back(cosines[static_cast<std::size_t>(k)].second,
                          cosines[static_cast<std::size_t>(k)].first / sum);
    // Start from the clear-sky solution, the sunlight unattenuated in every cell, instead of
    // an empty box: the iteration converges to the same steady state from any start, but
    // from this one only the cloud's shadow and scattered light have yet to settle.
    const std::size_t stride = g_.direction_stride();
    for (const auto& [k, w] : sun_)
      std::fill_n(i_.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(k) * stride),
                  static_cast<std::ptrdiff_t>(n), static_cast<float>(w));
  }
}

std::size_t LightingSolver::local_cell(std::size_t cell) const {
  const auto nx = static_cast<std::size_t>(global_.nx), ny = static_cast<std::size_t>(global_.ny);
  const int x = static_cast<int>(cell % nx), y = static_cast<int>(cell / nx % ny),
            z = static_cast<int>(cell / (nx * ny));
  const int yl = y - y_begin_ + halo_;
  if (yl < halo_ || yl >= g_.ny - halo_) throw ValueError(fmt::format("cell row {} is not in this lighting slab", y));
  return g_.index(x, yl, z);
}

void LightingSolver::add_pulse(std::size_t cell, double amount) {
  const std::size_t stride = g_.direction_stride(), c = local_cell(cell);
  for (int k = 0; k < light_dirs; ++k)
    i_[static_cast<std::size_t>(k) * stride + c] += static_cast<float>(amount * (k < 6 ? 1.0 / 12.0 : 1.0 / 24.0));
}

void LightingSolver::add_beam(std::size_t cell, int dir, double amount) {
  i_[static_cast<std::size_t>(dir - 1) * g_.direction_stride() + local_cell(cell)] += static_cast<float>(amount);
}

double LightingSolver::total_in_direction(int dir) const {
  double s = 0;
  const std::size_t stride = g_.direction_stride(), nx = static_cast<std::size_t>(g_.nx);
  for (int z = 0; z < g_.nz; ++z)
    for (int y = halo_; y < g_.ny - halo_; ++y) {
      const float* row = i_.data() + static_cast<std::size_t>(dir - 1) * stride + g_.index(0, y, z);
      for (std::size_t x = 0; x < nx; ++x) s += row[x];
    }
  return s;
}

double LightingSolver::total() const {
  double s = 0;
  for (int k = 1; k <= light_dirs; ++k) s += total_in_direction(k);
  return s;
}

std::vector<float> LightingSolver::light() const {
  const int own = g_.ny - 2 * halo_;
  const std::size_t stride = g_.direction_stride(), nx = static_cast<std::size_t>(g_.nx);
  std::vector<float> out(nx * static_cast<std::size_t>(own) * static_cast<std::size_t>(g_.nz), 0.0f);
  for (int k = 0; k < light_dirs; ++k)
    for (int z = 0; z < g_.nz; ++z)
      for (int yo = 0; yo < own; ++yo) {
        const float* row = i_.data() + static_cast<std::size_t>(k) * stride + g_.index(0, halo_ + yo, z);
        float* o = out.data() + (static_cast<std::size_t>(z) * own + yo) * nx;
        for (std::size_t x = 0; x < nx; ++x) o[x] += row[x];
      }
  return out;
}

std::vector<float> LightingSolver::leaving(Side side) const {
  if (!is_slab()) throw ValueError("leaving() of a lighting solver that is not a slab");
  const int cy = side == Side::below ? -1 : 1, y = side == Side::below ? 0 : g_.ny - 1;
  const std::size_t stride = g_.direction_stride(), nx = static_cast<std::size_t>(g_.nx);
  std::vector<float> out;
  out.reserve(5 * nx * static_cast<std::size_t>(g_.nz));
  for (int z = 0; z < g_.nz; ++z)
    for (int k = 0; k < light_dirs; ++k)
      if (d3q19::cy[static_cast<std::size_t>(k + 1)] == cy) {
        const float* row = i_.data() + static_cast<std::size_t>(k) * stride + g_.index(0, y, z);
        out.insert(out.end(), row, row + nx);
      }
  return out;
}

void LightingSolver::set_arrivals(Side side, const std::vector<float>& photons) {
  if (!is_slab()) throw ValueError("set_arrivals() on a lighting solver that is not a slab");
  const std::size_t nx = static_cast<std::size_t>(g_.nx), stride = g_.direction_stride();
  if (photons.size() != 5 * nx * static_cast<std::size_t>(g_.nz))
    throw ValueError("lighting halo photons of the wrong size");
  const int own_end = y_begin_ + g_.ny - 2 * halo_;
  const bool face = side == Side::below ? y_begin_ == 0 : own_end == global_.ny;
  if (face && !p_.periodic) return;  // the box's face: the step injected the sunlight there
  // Arriving from below, the photons travel up (c_y = +1) into the first own row; from above,
  // down into the last. A row whose source lies beyond the box's bottom or top face (z - c_z
  // outside it) keeps the sunlight the step injected: the neighbour pushed nothing there.
  const int cy = side == Side::below ? 1 : -1, y = side == Side::below ? halo_ : g_.ny - 1 - halo_;
  const float* src = photons.data();
  for (int z = 0; z < g_.nz; ++z)
    for (int k = 0; k < light_dirs; ++k) {
      const auto ku = static_cast<std::size_t>(k + 1);
      if (d3q19::cy[ku] != cy) continue;
      const int sz = z - d3q19::cz[ku];
      if (p_.periodic || (sz >= 0 && sz < g_.nz))
        std::copy_n(src, nx, i_.data() + static_cast<std::size_t>(k) * stride + g_.index(0, y, z));
      src += nx;
    }
}

PhotonBalance LightingSolver::balance_of_planes(const std::vector<std::array<double, 3>>& planes) {
  PhotonBalance b;
  for (const auto& p : planes) b.absorbed += p[0], b.inflow += p[1], b.outflow += p[2];
  return b;
}

void LightingSolver::set_balance(const PhotonBalance& b) {
  balance_ = b;
  residual_ = b.inflow > 0 ? std::abs(b.inflow - b.outflow - b.absorbed) / b.inflow : 0.0;
}

// One row's scratch: its post-collision direction rows, their sum, the phase matrix's
// scattering into one direction, and a row shifted by c_x.
struct LightingSolver::RowScratch {
  explicit RowScratch(std::size_t nx) : post(light_dirs * nx), sum(nx), scat(nx), shifted(nx) {}
  std::vector<float> post, sum, scat, shifted;
};

double LightingSolver::collide_row(std::size_t base, RowScratch& w) const {
  const int nx = g_.nx;
  const auto nxu = static_cast<std::size_t>(nx);
  const std::size_t stride = g_.direction_stride();
  const float* ss = sigma_s_.data() + base;
  const float* sa = sigma_a_.data() + base;
  auto in = [&](int k) { return i_.data() + static_cast<std::size_t>(k) * stride + base; };
  float* sum = w.sum.data();
  for (int x = 0; x < nx; ++x) sum[x] = 0;
  for (int k = 0; k < light_dirs; ++k) {
    const float* ik = in(k);
    for (int x = 0; x < nx; ++x) sum[x] += ik[x];
  }
  double absorbed = 0;
  for (int x = 0; x < nx; ++x) absorbed += static_cast<double>(sa[x]) * sum[x];
  for (int k = 0; k < light_dirs; ++k) {
    const float* ik = in(k);
    float* out = w.post.data() + static_cast<std::size_t>(k) * nxu;
    if (isotropic_) {
      const float wk = k < 6 ? 1.0f / 12.0f : 1.0f / 24.0f;
      for (int x = 0; x < nx; ++x) out[x] = (1 - ss[x] - sa[x]) * ik[x] + ss[x] * wk * sum[x];
    } else {
      float* scat = w.scat.data();
      for (int x = 0; x < nx; ++x) scat[x] = 0;
      for (int j = 0; j < light_dirs; ++j) {
        const float pkj = static_cast<float>(phase_[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)]);
        const float* ij = in(j);
        for (int x = 0; x < nx; ++x) scat[x] += pkj * ij[x];
      }
      for (int x = 0; x < nx; ++x) out[x] = (1 - ss[x] - sa[x]) * ik[x] + ss[x] * scat[x];
    }
  }
  return absorbed;
}

void LightingSolver::push_row(int y, int yg, int z, const std::array<float, light_dirs>& inject, RowScratch& w,
                              double& inflow, double& outflow) {
  const int nx = g_.nx, ny = g_.ny, nz = g_.nz, global_ny = global_.ny;
  const auto nxu = static_cast<std::size_t>(nx);
  const bool periodic = p_.periodic, slab = is_slab();
  for (int k = 0; k < light_dirs; ++k) {
    const auto ku = static_cast<std::size_t>(k + 1);
    const int cx = d3q19::cx[ku];
    const int dyg = yg + d3q19::cy[ku];
    int dz = z + d3q19::cz[ku];
    const float* pk = w.post.data() + static_cast<std::size_t>(k) * nxu;
    if (!periodic && (dyg < 0 || dyg >= global_ny || dz < 0 || dz >= nz)) {  // the whole row leaves
      for (int x = 0; x < nx; ++x) outflow += pk[x];
      continue;
    }
    const int dy = slab ? y + d3q19::cy[ku] : (y + d3q19::cy[ku] + ny) % ny;  // a slab: maybe a halo row
    dz = (dz + nz) % nz;
    const float inj = inject[static_cast<std::size_t>(k)];
    const float* row = pk;
    float* shifted = w.shifted.data();
    if (cx == 1) {
      for (int x = 1; x < nx; ++x) shifted[x] = pk[x - 1];
      shifted[0] = periodic ? pk[nx - 1] : inj;
      if (!periodic) outflow += pk[nx - 1], inflow += inj;
      row = shifted;
    } else if (cx == -1) {
      for (int x = 0; x < nx - 1; ++x) shifted[x] = pk[x + 1];
      shifted[nx - 1] = periodic ? pk[0] : inj;
      if (!periodic) outflow += pk[0], inflow += inj;
      row = shifted;
    }
    store_streaming(next_.data() + static_cast<std::size_t>(k) * g_.direction_stride() + g_.index(0, dy, dz), row, nxu);
  }
}

double LightingSolver::step() {
  // One fused pass per row of cells: collide the row's photons (18 direction rows, read once),
  // then push each direction's post-collision row to its destination row (y + c_y, z + c_z),
  // shifted by c_x, with streaming stores. Every destination row has exactly one source row,
  // so rows are independent (OpenMP over rows, no write conflicts), and the memory traffic is
  // one read and one write of the photon field per step (144 B per cell, plus 8 B of sigma).
  // Open boundaries: photons pushed out of the box are counted as outflow; the cells they
  // leave empty (the x edge of a shifted row, and whole rows whose source lies outside) receive
  // the sunlight injected along that direction. A slab pushes the photons that leave it in y
  // into its halo rows, for the exchange; only the whole grid's faces are open.
  const std::size_t stride = g_.direction_stride();
  const int nx = g_.nx, nz = g_.nz, own = g_.ny - 2 * halo_, global_ny = global_.ny;
  const bool periodic = p_.periodic;
  std::array<float, light_dirs> inject{};
  if (!periodic)
    for (const auto& [k, w] : sun_) inject[static_cast<std::size_t>(k)] = static_cast<float>(w);
  // Photon balance per row, summed over z per row plane and then over the planes in y order:
  // the same total for any thread count (an OpenMP reduction would round differently, and the
  // residual decides when to stop) and for any cut into slabs.
  const std::size_t rows = static_cast<std::size_t>(own) * static_cast<std::size_t>(nz);
  std::vector<std::array<double, 3>> row_balance(rows, {0, 0, 0});  // [y][z]: absorbed, inflow, outflow
  auto balance_at = [&](int yo, int z) -> std::array<double, 3>& {
    return row_balance[static_cast<std::size_t>(yo) * static_cast<std::size_t>(nz) + static_cast<std::size_t>(z)];
  };
#pragma omp parallel
  {
    RowScratch w(static_cast<std::size_t>(nx));
#pragma omp for collapse(2) schedule(static)
    for (int z = 0; z < nz; ++z)
      for (int yo = 0; yo < own; ++yo) {
        const int y = halo_ + yo, yg = y_begin_ + yo;  // local and global row
        double inflow = 0, outflow = 0;
        const double absorbed = collide_row(g_.index(0, y, z), w);
        push_row(y, yg, z, inject, w, inflow, outflow);
        auto& rb = balance_at(yo, z);
        rb[0] += absorbed, rb[1] += inflow, rb[2] += outflow;
      }
    // Rows that no source row inside the box feeds: all sunlight of their direction.
    if (!periodic) {
#pragma omp for collapse(2) schedule(static)
      for (int z = 0; z < nz; ++z)
        for (int yo = 0; yo < own; ++yo)
          for (int k = 0; k < light_dirs; ++k) {
            const auto ku = static_cast<std::size_t>(k + 1);
            const int sy = y_begin_ + yo - d3q19::cy[ku], sz = z - d3q19::cz[ku];
            if (sy >= 0 && sy < global_ny && sz >= 0 && sz < nz) continue;
            const float inj = inject[static_cast<std::size_t>(k)];
            std::fill_n(next_.data() + static_cast<std::size_t>(k) * stride + g_.index(0, halo_ + yo, z), nx, inj);
            balance_at(yo, z)[1] += static_cast<double>(inj) * nx;
          }
    }
    stream_fence();
  }
  i_.swap(next_);
  plane_balance_.assign(static_cast<std::size_t>(own), {0, 0, 0});
  for (int yo = 0; yo < own; ++yo)
    for (int z = 0; z < nz; ++z)
      for (int q = 0; q < 3; ++q)
        plane_balance_[static_cast<std::size_t>(yo)][static_cast<std::size_t>(q)] +=
            balance_at(yo, z)[static_cast<std::size_t>(q)];
  set_balance(balance_of_planes(plane_balance_));
  return residual_;
}

int LightingSolver::solve(const std::function<void(LightingSolver&)>& after_step) {
  if (is_slab() && !after_step)
    throw ValueError("a lighting slab solves only with an exchange of its halo rows after every step");
  int it = 0, quiet = 0;
  while (it < p_.max_iterations) {
    step();
    if (after_step) after_step(*this);
    ++it;
    // Converged once the photon balance has held for 10 consecutive steps.
    quiet = residual_ < p_.tolerance ? quiet + 1 : 0;
    if (quiet >= 10) break;
  }
  return it;
}

}  // namespace nephos::lbm
