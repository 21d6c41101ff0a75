#include "nephos/lbm/percolation.hpp"

#include <bit>
#include <cmath>
#include <limits>

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
    : coarse_(coarse), p_(params), seed_(seed) {
  const int k = p_.refinement;
  if (k < 1 || k > 16) throw ValueError("refinement K must be 1..16", {.key = "--percolation"});
  if (vapour.size() != coarse.cells()) throw ValueError("vapour field does not match the grid");
  fine_ = {coarse.nx * k, coarse.ny * k, coarse.nz * k};
  words_ = (fine_.nx + 63) / 64;
  const std::size_t total = static_cast<std::size_t>(words_) * fine_.ny * fine_.nz;
  hum_.assign(total, 0);
  act_.assign(total, 0);
  cld_.assign(total, 0);
  next_act_.assign(total, 0);
  next_hum_.assign(total, 0);
  const double lo = p_.rho10 - p_.epsilon_below, hi = p_.rho10 + p_.epsilon_above;
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < fine_.nz; ++z)
    for (int y = 0; y < fine_.ny; ++y) {
      Word* h = &hum_[row(y, z)];
      Word* a = &act_[row(y, z)];
      for (int x = 0; x < fine_.nx; ++x) {
        const double v = vapour[coarse.index(x / k, y / k, z / k)];
        // Linear seeding probability between the two thresholds (section 4.2).
        const double prob = v <= lo ? 0.0 : v >= hi ? 1.0 : (v - lo) / (hi - lo);
        const std::uint64_t cell = fine_.index(x, y, z);
        if (uniform01(seed, 0x4e52, cell, 0) < prob) {
          h[x >> 6] |= 1ULL << (x & 63);
          if (uniform01(seed, 0x4e52, cell, 1) < p_.initial_activation) a[x >> 6] |= 1ULL << (x & 63);
        }
      }
    }
}

void Percolation::set_active(int x, int y, int z) {
  const std::size_t w = row(y, z) + static_cast<std::size_t>(x >> 6);
  act_[w] |= 1ULL << (x & 63);
  hum_[w] |= 1ULL << (x & 63);
}

std::size_t Percolation::popcount(const std::vector<Word>& v) {
  std::size_t n = 0;
  for (Word w : v) n += static_cast<std::size_t>(std::popcount(w));
  return n;
}

bool Percolation::bit(const std::vector<Word>& v, int x, int y, int z) const {
  return (v[row(y, z) + static_cast<std::size_t>(x >> 6)] >> (x & 63)) & 1ULL;
}

std::size_t Percolation::step() {
  const int w = words_, ny = fine_.ny, nz = fine_.nz, len = fine_.nx;
  std::size_t active = 0;
#pragma omp parallel reduction(+ : active)
  {
    std::vector<Word> sh(static_cast<std::size_t>(w));
#pragma omp for collapse(2) schedule(static)
    for (int z = 0; z < nz; ++z)
      for (int y = 0; y < ny; ++y) {
        const std::size_t r = row(y, z);
        const Word* a = &act_[r];
        std::vector<Word> f(static_cast<std::size_t>(w), 0);
        for (int s : {1, 2, -1, -2}) {
          shift_row(a, sh.data(), w, len, s);
          for (int j = 0; j < w; ++j) f[static_cast<std::size_t>(j)] |= sh[static_cast<std::size_t>(j)];
        }
        for (int dy : {1, 2, -1, -2}) {
          const Word* b = &act_[row((y + dy + ny) % ny, z)];
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
            if (uniform01(seed_, 0xe87, static_cast<std::uint64_t>(step_), fine_.index(x, y, z)) < p_.extinction)
              c[x >> 6] &= ~(1ULL << (x & 63));
        }
      }
  }
  act_.swap(next_act_);
  hum_.swap(next_hum_);
  ++step_;
  return active;
}

int Percolation::run() {
  int steps = 0;
  while (steps < p_.max_steps && count_active() > 0) {
    step();
    ++steps;
  }
  return steps;
}

std::vector<float> Percolation::coarse_density() const {
  const int k = p_.refinement;
  std::vector<float> out(coarse_.cells(), 0.0f);
  const float inv = 1.0f / static_cast<float>(k * k * k);
#pragma omp parallel for collapse(2) schedule(static)
  for (int z = 0; z < coarse_.nz; ++z)
    for (int y = 0; y < coarse_.ny; ++y)
      for (int x = 0; x < coarse_.nx; ++x) {
        int n = 0;
        for (int dz = 0; dz < k; ++dz)
          for (int dy = 0; dy < k; ++dy)
            for (int dx = 0; dx < k; ++dx) n += bit(cld_, x * k + dx, y * k + dy, z * k + dz) ? 1 : 0;
        out[coarse_.index(x, y, z)] = static_cast<float>(n) * inv;
      }
  return out;
}

std::vector<std::uint8_t> Percolation::projected_cloud() const {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(fine_.nx) * fine_.ny, 0);
  for (int z = 0; z < fine_.nz; ++z)
    for (int y = 0; y < fine_.ny; ++y)
      for (int x = 0; x < fine_.nx; ++x)
        if (bit(cld_, x, y, z)) out[static_cast<std::size_t>(y) * fine_.nx + x] = 1;
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
