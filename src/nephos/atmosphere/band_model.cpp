#include "nephos/atmosphere/band_model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <tuple>

#include "nephos/atmosphere/nnls.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/simd_math.hpp"

namespace nephos::atmosphere {

namespace data {
extern const double lowtran7_band_model[];  // [nu, (C', region) x H2O, O3, CO2, CH4, N2O, O2]
extern const std::size_t lowtran7_band_model_rows, lowtran7_band_model_cols;
extern const double lowtran7_band_regions[];  // [region, a, n, m]
extern const std::size_t lowtran7_band_regions_rows, lowtran7_band_regions_cols;
extern const double lowtran7_h2o_continuum[];  // [nu, self 296, self 260, foreign 296], 10 cm-1 from 0
extern const std::size_t lowtran7_h2o_continuum_rows, lowtran7_h2o_continuum_cols;
extern const double lowtran7_n2_continuum[];  // [nu, km^-1], 2080-2740 by 5
extern const std::size_t lowtran7_n2_continuum_rows, lowtran7_n2_continuum_cols;
extern const double lowtran7_o3_visible[];  // [nu, (atm-cm)^-1], 13000-24200 by 200
extern const std::size_t lowtran7_o3_visible_rows, lowtran7_o3_visible_cols;
}  // namespace data

const char* name(Gas g) {
  static const char* names[] = {"H2O", "CO2", "O3", "N2O", "CH4", "O2"};
  return names[static_cast<int>(g)];
}

double ExpSum::transmittance(double w_scaled) const {
  double t;
  transmittances(&w_scaled, 1, &t);
  return t;
}

void ExpSum::transmittances(const double* a, std::size_t count, double* out) const {
  for (std::size_t j = 0; j < count; ++j) out[j] = n == 0 ? 1.0 : 0.0;
  for (int i = 0; i < n; ++i) {
    const double wi = w[static_cast<std::size_t>(i)], ki = k[static_cast<std::size_t>(i)];
    for (std::size_t j = 0; j < count; ++j) out[j] += wi * std::exp(-ki * a[j]);
  }
}

namespace {

constexpr double bin_cm1 = 5;  // the band model's bin spacing
// The band-model table's column of each gas (C'; its region follows), in Gas order.
constexpr std::array<int, gas_count> column = {1, 5, 3, 9, 7, 11};

struct Bin {
  double nu;                          // centre [cm^-1]
  double weight;                      // its wavelength width, d(lambda) ~ d(nu) / nu^2
  std::array<double, gas_count> c;    // C' (-20: no band)
  std::array<int, gas_count> region;  // 0: no band
};

struct Region {
  double a, n, m;
};

const Region& region(int r) {
  static const std::map<int, Region> table = [] {
    std::map<int, Region> t;
    for (std::size_t i = 0; i < data::lowtran7_band_regions_rows; ++i) {
      const double* row = &data::lowtran7_band_regions[i * data::lowtran7_band_regions_cols];
      t[static_cast<int>(row[0])] = {row[1], row[2], row[3]};
    }
    return t;
  }();
  return table.at(r);
}

// The bins whose centres lie in [nu_lo, nu_hi] (at least the nearest one).
std::vector<Bin> bins(double nu_lo, double nu_hi) {
  std::vector<Bin> out;
  const std::size_t rows = data::lowtran7_band_model_rows, cols = data::lowtran7_band_model_cols;
  auto make = [&](std::size_t r) {
    const double* row = &data::lowtran7_band_model[r * cols];
    Bin b{row[0], 1 / (row[0] * row[0]), {}, {}};
    for (int g = 0; g < gas_count; ++g) {
      b.c[static_cast<std::size_t>(g)] = row[column[static_cast<std::size_t>(g)]];
      b.region[static_cast<std::size_t>(g)] = static_cast<int>(row[column[static_cast<std::size_t>(g)] + 1]);
    }
    return b;
  };
  for (std::size_t r = 0; r < rows; ++r) {
    const double nu = data::lowtran7_band_model[r * cols];
    if (nu >= nu_lo && nu <= nu_hi) out.push_back(make(r));
  }
  if (out.empty()) {
    const auto r = static_cast<std::size_t>(
        std::clamp(std::lround(0.5 * (nu_lo + nu_hi) / bin_cm1), 0L, static_cast<long>(rows) - 1));
    out.push_back(make(r));
  }
  return out;
}

// Linear interpolation in a table of rows (x, y...) with uniform x spacing; 0 outside.
double table_value(const double* t, std::size_t rows, std::size_t cols, std::size_t col, double x) {
  const double x0 = t[0], dx = t[cols] - t[0];
  const double f = (x - x0) / dx;
  if (f < 0 || f > static_cast<double>(rows - 1)) return 0.0;
  const auto i = std::min(static_cast<std::size_t>(f), rows - 2);
  const double u = f - static_cast<double>(i);
  return (1 - u) * t[i * cols + col] + u * t[(i + 1) * cols + col];
}

// The bins' mean transmittance of gas g for scaled amount w (bins weighted by wavelength width).
double mean_transmittance(const std::vector<Bin>& bs, Gas g, double w) {
  const auto gi = static_cast<std::size_t>(g);
  double t = 0, sum = 0;
  for (const Bin& b : bs) {
    sum += b.weight;
    if (b.region[gi] == 0 || b.c[gi] <= -19.9 || w <= 0) {
      t += b.weight;
      continue;
    }
    t += b.weight * std::exp(-std::pow(w * std::pow(10.0, b.c[gi]), region(b.region[gi]).a));
  }
  return t / sum;
}

// The largest scaled amount a path through the atmosphere holds of each gas (a tropical column
// along the horizon's air mass, ~40): H2O [g cm^-2], the others [atm-cm].
constexpr std::array<double, gas_count> max_amount = {2e3, 3e4, 50, 30, 150, 2e7};
// The largest transmittance error the fits (and a gas left out) may make.
constexpr double fit_tolerance = 2e-3;

// Fits the bins' mean transmittance of gas g by a positive sum of exponentials (NNLS on a fixed
// logarithmic grid of k, the weights summing to one) over the amounts a path can hold (8
// decades below the largest); returns the fit and its largest error on those amounts.
std::pair<ExpSum, double> fit(const std::vector<Bin>& bs, Gas g) {
  const auto gi = static_cast<std::size_t>(g);
  bool absorbs = false;
  for (const Bin& b : bs) absorbs = absorbs || (b.region[gi] != 0 && b.c[gi] > -19.9);
  if (!absorbs) return {ExpSum{}, 0.0};
  const double w_max = max_amount[gi], w_min = w_max * 1e-8;
  // A gas that absorbs less than the fit's tolerance along the longest path is left out.
  if (1 - mean_transmittance(bs, g, w_max) < fit_tolerance) return {ExpSum{}, 1 - mean_transmittance(bs, g, w_max)};
  std::vector<double> amounts, rates;
  for (double x = std::log10(w_min); x <= std::log10(w_max) + 1e-9; x += 0.1) amounts.push_back(std::pow(10.0, x));
  for (double x = std::log10(1e-5 / w_max); x <= std::log10(30 / w_min) + 1e-9; x += 1.0 / 3)
    rates.push_back(std::pow(10.0, x));
  const std::size_t m = amounts.size() + 1;
  std::vector<double> b(m);
  for (std::size_t i = 0; i < amounts.size(); ++i) b[i] = mean_transmittance(bs, g, amounts[i]);
  constexpr double sum_weight = 100;  // the row that holds sum w = 1 (t(0) = 1)
  b[m - 1] = sum_weight;
  // The fit on the rates in `cols` (NNLS; those with a zero weight dropped, and while more than
  // max_terms remain, the smallest weight dropped and the rest refitted) and its error.
  auto fit_on = [&](std::vector<std::size_t> cols) {
    std::vector<double> w;
    for (;;) {
      const std::size_t n = cols.size();
      std::vector<double> a(m * n);
      for (std::size_t i = 0; i < amounts.size(); ++i)
        for (std::size_t j = 0; j < n; ++j) a[i * n + j] = std::exp(-rates[cols[j]] * amounts[i]);
      for (std::size_t j = 0; j < n; ++j) a[(m - 1) * n + j] = sum_weight;
      const std::vector<double> all_w = nnls(a, b, m, n);
      std::vector<std::size_t> nonzero;
      w.clear();
      for (std::size_t j = 0; j < n; ++j)
        if (all_w[j] > 1e-9) nonzero.push_back(cols[j]), w.push_back(all_w[j]);
      cols = nonzero;
      if (cols.size() <= static_cast<std::size_t>(ExpSum::max_terms)) break;
      const auto smallest = std::min_element(w.begin(), w.end()) - w.begin();
      cols.erase(cols.begin() + smallest);
    }
    std::vector<std::size_t> kept_cols = cols;
    ExpSum e;
    for (std::size_t j = 0; j < cols.size(); ++j) {
      e.k[static_cast<std::size_t>(e.n)] = rates[cols[j]], e.w[static_cast<std::size_t>(e.n)] = w[j];
      ++e.n;
    }
    double err = 0;
    for (double x = std::log10(w_min); x <= std::log10(w_max) + 1e-9; x += 0.05) {
      const double amount = std::pow(10.0, x);
      err = std::max(err, std::abs(e.transmittance(amount) - mean_transmittance(bs, g, amount)));
    }
    return std::make_tuple(e, err, kept_cols);
  };
  std::vector<std::size_t> all(rates.size());
  for (std::size_t j = 0; j < all.size(); ++j) all[j] = j;
  auto best = fit_on(all);
  // Fewer terms while the error stays within the tolerance (or the first fit's, if larger): the
  // smallest weight dropped and the rest refitted.
  const double tolerance = std::max(fit_tolerance, std::get<1>(best));
  while (std::get<0>(best).n > 1) {
    const ExpSum& e = std::get<0>(best);
    std::vector<std::size_t> fewer = std::get<2>(best);
    const auto smallest = std::min_element(e.w.begin(), e.w.begin() + e.n) - e.w.begin();
    fewer.erase(fewer.begin() + smallest);
    auto candidate = fit_on(fewer);
    if (std::get<1>(candidate) > tolerance) break;
    best = candidate;
  }
  return {std::get<0>(best), std::get<1>(best)};
}

// Cuts a band's bins into sub-bands: a new one where any gas changes region, and after
// max_width of wavenumber.
std::vector<std::vector<Bin>> cut(const std::vector<Bin>& all, double max_width) {
  std::vector<std::vector<Bin>> out;
  for (const Bin& b : all) {
    const bool start = out.empty() || b.region != out.back().back().region ||
                       b.nu - out.back().front().nu >= max_width - 0.5 * bin_cm1;
    if (start) out.emplace_back();
    out.back().push_back(b);
  }
  return out;
}

SubBand make_sub_band(const std::vector<Bin>& bs, double band_weight) {
  SubBand s;
  s.nu_lo_cm1 = bs.front().nu, s.nu_hi_cm1 = bs.back().nu;
  double wsum = 0, lsum = 0;
  for (const Bin& b : bs) {
    wsum += b.weight, lsum += b.weight * 1e4 / b.nu;
    s.self_296 += b.weight * table_value(data::lowtran7_h2o_continuum, data::lowtran7_h2o_continuum_rows,
                                         data::lowtran7_h2o_continuum_cols, 1, b.nu);
    s.self_260 += b.weight * table_value(data::lowtran7_h2o_continuum, data::lowtran7_h2o_continuum_rows,
                                         data::lowtran7_h2o_continuum_cols, 2, b.nu);
    s.foreign_296 += b.weight * table_value(data::lowtran7_h2o_continuum, data::lowtran7_h2o_continuum_rows,
                                            data::lowtran7_h2o_continuum_cols, 3, b.nu);
    s.n2_per_km += b.weight * table_value(data::lowtran7_n2_continuum, data::lowtran7_n2_continuum_rows,
                                          data::lowtran7_n2_continuum_cols, 1, b.nu);
    s.o3_visible += b.weight * table_value(data::lowtran7_o3_visible, data::lowtran7_o3_visible_rows,
                                           data::lowtran7_o3_visible_cols, 1, b.nu);
  }
  for (double* v : {&s.self_296, &s.self_260, &s.foreign_296, &s.n2_per_km, &s.o3_visible}) *v /= wsum;
  s.wavelength_um = lsum / wsum;
  s.weight = wsum / band_weight;
  for (int g = 0; g < gas_count; ++g) {
    const auto gi = static_cast<std::size_t>(g);
    const int r = bs.front().region[gi];
    if (r == 0) continue;
    s.n[gi] = region(r).n, s.m[gi] = region(r).m;
    const auto [e, err] = fit(bs, static_cast<Gas>(g));
    s.gas[gi] = e;
    s.fit_error = std::max(s.fit_error, err);
  }
  return s;
}

BandGasModel build(const optics::Band& band) {
  const double nu_lo = 1e4 / band.hi_um, nu_hi = 1e4 / band.lo_um;
  const std::vector<Bin> all = bins(nu_lo, nu_hi);
  double total = 0;
  for (const Bin& b : all) total += b.weight;
  BandGasModel m;
  for (const auto& group : cut(all, band.thermal ? 60.0 : 1e9)) {
    m.sub.push_back(make_sub_band(group, total));
    m.fit_error = std::max(m.fit_error, m.sub.back().fit_error);
  }
  return m;
}

}  // namespace

const BandGasModel& gas_model(const optics::Band& band) {
  static std::mutex mutex;
  static std::map<std::string, std::unique_ptr<const BandGasModel>> models;
  {
    const std::lock_guard lock(mutex);
    if (const auto it = models.find(band.name); it != models.end()) return *it->second;
  }
  // Fitted outside the lock, so that threads fit different bands at once; a band fitted twice
  // meanwhile keeps its first model (the fits are deterministic: the same).
  auto fitted = std::make_unique<const BandGasModel>(build(band));
  const std::lock_guard lock(mutex);
  auto& model = models[band.name];
  if (!model) model = std::move(fitted);
  return *model;
}

double band_model_transmittance(Gas g, double nu_lo, double nu_hi, double w) {
  return mean_transmittance(bins(nu_lo, nu_hi), g, w);
}

}  // namespace nephos::atmosphere
