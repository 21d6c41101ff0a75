#include "nephos/lbm/percolation.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"

namespace nephos::lbm {
namespace {

using Word = std::uint64_t;

// out[x] = in[(x - s) mod L] for a bit row of length L in w words (bits >= L are zero).
void shift_row(const Word* in, Word* out, int w, int len, int s) {
  auto get = [&](int pos) { return (in[pos >> 6] >> (pos & 63)) & 1ULL; };
  if (s > 0) {
    for (int j = w - 1; j >= 0; --j) out[j] = (in[j] << s) | (j > 0 ? in[j - 1] >> (64 - s) : 0);
    for (int b = 0; b < s; ++b) out[0] |= get(len - s + b) << b;  // wrap-around
  } else {
    const int a = -s;
    for (int j = 0; j < w; ++j) out[j] = (in[j] >> a) | (j + 1 < w ? in[j + 1] << (64 - a) : 0);
    // Bits L-a..L-1 came from beyond the row (zero); they wrap to in[0..a-1].
    for (int b = 0; b < a; ++b) {
      const int pos = len - a + b;
      out[pos >> 6] = (out[pos >> 6] & ~(1ULL << (pos & 63))) | (get(b) << (pos & 63));
    }
  }
  if (len & 63) out[w - 1] &= (1ULL << (len & 63)) - 1;  // keep bits >= L zero
}

}  // namespace

Percolation::Percolation(const Grid3& coarse, const std::vector<float>& vapour, const PercolationParams& params,
                         std::uint64_t seed)
    : Percolation(coarse, vapour, params, seed, 0, coarse.ny, 0) {}

Percolation::Percolation(const Grid3& coarse, const std::vector<float>& vapour, const PercolationParams& params,
                         std::uint64_t seed, int y_begin, int y_end)
    : Percolation(coarse, vapour, params, seed, y_begin, y_end, 2) {}  // activation spreads two rows per step

Percolation::Percolation(const Grid3& coarse, const std::vector<float>& vapour, const PercolationParams& params,
                         std::uint64_t seed, int y_begin, int y_end, int halo)
    : coarse_(coarse), p_(params), seed_(seed), y_begin_(y_begin), y_end_(y_end), halo_(halo) {
  const int k = p_.refinement;
  if (k < 1 || k > 16) throw ValueError("refinement K must be 1..16", {.key = "percolation"});
  // The thresholds rho10 -/+ eps and the probabilities must be numbers in their ranges (a NaN
  // threshold would silently make every site dry).
  if (!(p_.rho10 > 0 && std::isfinite(p_.rho10)))
    throw ValueError(fmt::format("the condensation density rho10 must be finite and > 0, got {:g}", p_.rho10),
                     {.key = "rho10"});
  if (!(p_.epsilon_below >= 0 && p_.epsilon_above >= 0 && std::isfinite(p_.epsilon_below) &&
        std::isfinite(p_.epsilon_above)))
    throw ValueError("the thresholds eps1, eps2 must be finite and >= 0", {.key = "epsilon"});
  if (!(p_.initial_activation >= 0 && p_.initial_activation <= 1 && p_.extinction >= 0 && p_.extinction <= 1))
    throw ValueError("the activation and extinction probabilities must be in [0, 1]", {.key = "probability"});
  if (!(y_begin >= 0 && y_begin < y_end && y_end <= coarse.ny))
    throw ValueError(
        fmt::format("percolation slab rows {}..{} outside the grid's 0..{}", y_begin, y_end - 1, coarse.ny - 1));
  const std::size_t own_cells = static_cast<std::size_t>(coarse.nx) * (y_end - y_begin) * coarse.nz;
  if (vapour.size() != own_cells) throw ValueError("vapour field does not match the percolation grid");
  fine_ = {coarse.nx * k, coarse.ny * k, coarse.nz * k};
  own_ = (y_end - y_begin) * k;
  if (halo_ > 0 && own_ < halo_) throw ValueError("a percolation slab needs at least two refined rows");
  local_ny_ = own_ + 2 * halo_;
  seed_sites(vapour);
}

void Percolation::seed_sites(const std::vector<float>& vapour) {
  const int k = p_.refinement;
  words_ = (fine_.nx + 63) / 64;
  const std::size_t total = static_cast<std::size_t>(words_) * local_ny_ * fine_.nz;
  hum_.assign(total, 0);
  act_.assign(total, 0);
  cld_.assign(total, 0);
  next_act_.assign(total, 0);
  next_hum_.assign(total, 0);
  const double lo = p_.rho10 - p_.epsilon_below, hi = p_.rho10 + p_.epsilon_above;
  const int own_coarse = y_end_ - y_begin_, y0 = y_begin_ * k;
  // Locals, not members, in the loop: the sites' stores (64-bit words) could alias the 64-bit
  // seed member, which the compiler would then reload per site.
  const std::uint64_t seed = seed_;
  const double initial_activation = p_.initial_activation;
  const Grid3 fine = fine_;
  const int nx_coarse = coarse_.nx, y_begin = y_begin_;
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < fine.nz; ++z)
    for (int yo = 0; yo < own_; ++yo) {
      const int y = y0 + yo;  // global fine row
      Word* h = &hum_[row(halo_ + yo, z)];
      Word* a = &act_[row(halo_ + yo, z)];
      const std::size_t vrow = (static_cast<std::size_t>(z / k) * own_coarse + (y / k - y_begin)) * nx_coarse;
      for (int x = 0; x < fine.nx; ++x) {
        const double v = vapour[vrow + static_cast<std::size_t>(x / k)];
        // Linear seeding probability between the two thresholds (section 4.2).
        const double prob = v <= lo ? 0.0 : v >= hi ? 1.0 : (v - lo) / (hi - lo);
        const std::uint64_t cell = fine.index(x, y, z);  // global: the same sites whatever the slabs
        if (uniform01(seed, 0x4e52, cell, 0) < prob) {
          h[x >> 6] |= 1ULL << (x & 63);
          if (uniform01(seed, 0x4e52, cell, 1) < initial_activation) a[x >> 6] |= 1ULL << (x & 63);
        }
      }
    }
}

int Percolation::local_row(int y_global) const {
  const int yl = y_global - y_begin_ * p_.refinement + halo_;
  if (yl < halo_ || yl >= halo_ + own_)
    throw ValueError(fmt::format("fine row {} is not in this percolation slab", y_global));
  return yl;
}

void Percolation::set_active(int x, int y, int z) {
  const std::size_t w = row(local_row(y), z) + static_cast<std::size_t>(x >> 6);
  act_[w] |= 1ULL << (x & 63);
  hum_[w] |= 1ULL << (x & 63);
}

std::size_t Percolation::popcount(const std::vector<Word>& v) const {
  std::size_t n = 0;  // own rows only (a slab's halo rows hold its neighbours' sites)
  for (int z = 0; z < fine_.nz; ++z)
    for (std::size_t j = row(halo_, z), e = row(halo_ + own_, z); j < e; ++j)
      n += static_cast<std::size_t>(std::popcount(v[j]));
  return n;
}

bool Percolation::bit(const std::vector<Word>& v, int x, int y, int z) const {
  return bit_local(v, x, local_row(y), z);
}

std::vector<std::uint64_t> Percolation::edge_rows(Side side) const {
  if (!is_slab()) throw ValueError("edge_rows() of a percolation that is not a slab");
  const int first = side == Side::below ? halo_ : halo_ + own_ - halo_;
  const auto span = static_cast<std::size_t>(halo_) * words_;
  std::vector<std::uint64_t> out(span * fine_.nz);
  for (int z = 0; z < fine_.nz; ++z) std::copy_n(&act_[row(first, z)], span, &out[static_cast<std::size_t>(z) * span]);
  return out;
}

void Percolation::set_halo(Side side, const std::vector<std::uint64_t>& rows) {
  if (!is_slab()) throw ValueError("set_halo() on a percolation that is not a slab");
  const auto span = static_cast<std::size_t>(halo_) * words_;
  if (rows.size() != span * fine_.nz) throw ValueError("percolation halo rows of the wrong size");
  const int first = side == Side::below ? 0 : halo_ + own_;
  for (int z = 0; z < fine_.nz; ++z) std::copy_n(&rows[static_cast<std::size_t>(z) * span], span, &act_[row(first, z)]);
}

std::size_t Percolation::step() {
  const int w = words_, ny = local_ny_, nz = fine_.nz, len = fine_.nx, y0 = y_begin_ * p_.refinement;
  const bool slab = is_slab();
  std::size_t active = 0;
#pragma omp parallel reduction(+ : active)
  {
    std::vector<Word> sh(static_cast<std::size_t>(w)), f(static_cast<std::size_t>(w));
#pragma omp for collapse(2) schedule(static)
    for (int z = 0; z < nz; ++z)
      for (int yo = 0; yo < own_; ++yo) {
        const int y = halo_ + yo;
        const std::size_t r = row(y, z);
        const Word* a = &act_[r];
        std::fill(f.begin(), f.end(), Word{0});
        for (int s : {1, 2, -1, -2}) {
          shift_row(a, sh.data(), w, len, s);
          for (int j = 0; j < w; ++j) f[static_cast<std::size_t>(j)] |= sh[static_cast<std::size_t>(j)];
        }
        for (int dy : {1, 2, -1, -2}) {  // a slab reads its halo rows; the whole grid wraps
          const Word* b = &act_[row(slab ? y + dy : (y + dy + ny) % ny, z)];
          for (int j = 0; j < w; ++j) f[static_cast<std::size_t>(j)] |= b[j];
        }
        for (int dz : {1, 2})  // from below only
          if (z - dz >= 0) {
            const Word* b = &act_[row(y, z - dz)];
            for (int j = 0; j < w; ++j) f[static_cast<std::size_t>(j)] |= b[j];
          }
        const Word* h = &hum_[r];
        Word* c = &cld_[r];
        Word* na = &next_act_[r];
        Word* nh = &next_hum_[r];
        for (int j = 0; j < w; ++j) {
          nh[j] = h[j] & ~a[j];
          c[j] |= a[j];
          na[j] = ~a[j] & h[j] & f[static_cast<std::size_t>(j)];
          active += static_cast<std::size_t>(std::popcount(na[j]));
        }
        if (p_.extinction > 0) {
          for (int x = 0; x < len; ++x)
            if (uniform01(seed_, 0xe87, static_cast<std::uint64_t>(step_), fine_.index(x, y0 + yo, z)) < p_.extinction)
              c[x >> 6] &= ~(1ULL << (x & 63));
        }
      }
  }
  act_.swap(next_act_);
  hum_.swap(next_hum_);
  ++step_;
  return active;
}

int Percolation::run(const RunHooks& hooks) {
  if (is_slab() && !(hooks.exchange && hooks.total))
    throw ValueError("a percolation slab runs only with a halo exchange and a total over the slabs");
  auto sum = [&](std::size_t n) { return hooks.total ? hooks.total(n) : n; };
  std::size_t active = sum(count_active());
  int steps = 0;
  while (steps < p_.max_steps && active > 0) {
    if (hooks.exchange) hooks.exchange(*this);
    active = sum(step());
    ++steps;
    if (hooks.after_step) hooks.after_step(steps, active);
  }
  return steps;
}

std::vector<float> Percolation::coarse_density() const {
  const int k = p_.refinement, own_coarse = y_end_ - y_begin_;
  std::vector<float> out(static_cast<std::size_t>(coarse_.nx) * own_coarse * coarse_.nz, 0.0f);
  const float inv = 1.0f / static_cast<float>(k * k * k);
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < coarse_.nz; ++z)
    for (int yo = 0; yo < own_coarse; ++yo) {
      const int yl = halo_ + yo * k;  // the block's first local fine row
      for (int x = 0; x < coarse_.nx; ++x) {
        int n = 0;
        for (int dz = 0; dz < k; ++dz)
          for (int dy = 0; dy < k; ++dy)
            for (int dx = 0; dx < k; ++dx) n += bit_local(cld_, x * k + dx, yl + dy, z * k + dz) ? 1 : 0;
        out[(static_cast<std::size_t>(z) * own_coarse + yo) * coarse_.nx + x] = static_cast<float>(n) * inv;
      }
    }
  return out;
}

std::vector<std::uint8_t> Percolation::projected_cloud() const {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(fine_.nx) * own_, 0);
  for (int z = 0; z < fine_.nz; ++z)
    for (int yo = 0; yo < own_; ++yo)
      for (int x = 0; x < fine_.nx; ++x)
        if (bit_local(cld_, x, halo_ + yo, z)) out[static_cast<std::size_t>(yo) * fine_.nx + x] = 1;
  return out;
}

std::vector<ClusterSize> cluster_sizes(const std::vector<std::uint8_t>& field, int nx, int ny) {
  std::vector<int> label(field.size(), -1);    // cluster of each cloud site
  std::vector<int> counted(field.size(), -1);  // last cluster whose perimeter counted this clear site
  std::vector<ClusterSize> out;
  std::vector<std::size_t> stack;
  int id = 0;
  for (std::size_t start = 0; start < field.size(); ++start) {
    if (!field[start] || label[start] >= 0) continue;
    ClusterSize c{0, 0};
    stack.assign(1, start);
    label[start] = id;
    while (!stack.empty()) {
      const std::size_t s = stack.back();
      stack.pop_back();
      ++c.area;
      const int x = static_cast<int>(s % static_cast<std::size_t>(nx)),
                y = static_cast<int>(s / static_cast<std::size_t>(nx));
      const int nbx[4] = {(x + 1) % nx, (x + nx - 1) % nx, x, x};
      const int nby[4] = {y, y, (y + 1) % ny, (y + ny - 1) % ny};
      for (int q = 0; q < 4; ++q) {
        const std::size_t nb = static_cast<std::size_t>(nby[q]) * nx + nbx[q];
        if (!field[nb]) {
          if (counted[nb] != id) counted[nb] = id, ++c.perimeter;  // a perimeter site, counted once
        } else if (label[nb] < 0) {
          label[nb] = id;
          stack.push_back(nb);
        }
      }
    }
    out.push_back(c);
    ++id;
  }
  return out;
}

double perimeter_area_dimension(const std::vector<std::uint8_t>& field, int nx, int ny, int min_area) {
  std::vector<double> la, lp;
  for (const ClusterSize& c : cluster_sizes(field, nx, ny))
    if (c.area >= min_area) {
      la.push_back(std::log(static_cast<double>(c.area)));
      lp.push_back(std::log(static_cast<double>(c.perimeter)));
    }
  if (la.size() < 10) return std::numeric_limits<double>::quiet_NaN();
  double ma = 0, mp = 0;
  for (std::size_t i = 0; i < la.size(); ++i) ma += la[i], mp += lp[i];
  ma /= static_cast<double>(la.size());
  mp /= static_cast<double>(lp.size());
  double sap = 0, saa = 0;
  for (std::size_t i = 0; i < la.size(); ++i) {
    sap += (la[i] - ma) * (lp[i] - mp);
    saa += (la[i] - ma) * (la[i] - ma);
  }
  return 2.0 * sap / saa;
}

}  // namespace nephos::lbm
