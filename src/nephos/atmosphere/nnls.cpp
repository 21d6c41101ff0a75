#include "nephos/atmosphere/nnls.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nephos::atmosphere {

std::vector<double> least_squares(const std::vector<double>& a, const std::vector<double>& b, std::size_t m,
                                  std::size_t n, const std::vector<std::size_t>& cols) {
  const std::size_t p = cols.size();
  std::vector<double> r(m * p), y(b);  // the chosen columns, then R in place
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < p; ++j) r[i * p + j] = a[i * n + cols[j]];
  // Householder reflections H_k = I - 2 v v^T / (v^T v), applied to R and y.
  for (std::size_t k = 0; k < p && k < m; ++k) {
    double norm = 0;
    for (std::size_t i = k; i < m; ++i) norm += r[i * p + k] * r[i * p + k];
    norm = std::sqrt(norm);
    if (norm == 0) continue;
    const double alpha = r[k * p + k] > 0 ? -norm : norm;
    std::vector<double> v(m - k);
    for (std::size_t i = k; i < m; ++i) v[i - k] = r[i * p + k];
    v[0] -= alpha;
    double vv = 0;
    for (double x : v) vv += x * x;
    if (vv == 0) continue;
    for (std::size_t j = k; j < p; ++j) {
      double d = 0;
      for (std::size_t i = k; i < m; ++i) d += v[i - k] * r[i * p + j];
      d *= 2 / vv;
      for (std::size_t i = k; i < m; ++i) r[i * p + j] -= d * v[i - k];
    }
    double d = 0;
    for (std::size_t i = k; i < m; ++i) d += v[i - k] * y[i];
    d *= 2 / vv;
    for (std::size_t i = k; i < m; ++i) y[i] -= d * v[i - k];
  }
  // Back substitution R z = Q^T b (a vanishing pivot leaves its unknown at zero).
  std::vector<double> z(p, 0.0);
  for (std::size_t kk = p; kk-- > 0;) {
    if (kk >= m) continue;
    double s = y[kk];
    for (std::size_t j = kk + 1; j < p; ++j) s -= r[kk * p + j] * z[j];
    const double piv = r[kk * p + kk];
    z[kk] = std::abs(piv) > 1e-300 ? s / piv : 0.0;
  }
  return z;
}

std::vector<double> nnls(const std::vector<double>& a, const std::vector<double>& b, std::size_t m, std::size_t n) {
  std::vector<double> x(n, 0.0);
  std::vector<char> passive(n, 0);
  const double tol = 1e-12;
  for (std::size_t outer = 0; outer < 3 * n; ++outer) {
    // The gradient -A^T (A x - b) on the zero set; stop when no coordinate would decrease |Ax - b|.
    std::vector<double> res(b);
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t j = 0; j < n; ++j) res[i] -= a[i * n + j] * x[j];
    std::size_t best = n;
    double best_g = tol;
    for (std::size_t j = 0; j < n; ++j) {
      if (passive[j]) continue;
      double g = 0;
      for (std::size_t i = 0; i < m; ++i) g += a[i * n + j] * res[i];
      if (g > best_g) best_g = g, best = j;
    }
    if (best == n) break;
    passive[best] = 1;
    for (std::size_t inner = 0; inner < 3 * n; ++inner) {
      std::vector<std::size_t> cols;
      for (std::size_t j = 0; j < n; ++j)
        if (passive[j]) cols.push_back(j);
      const std::vector<double> z = least_squares(a, b, m, n, cols);
      bool feasible = true;
      for (double v : z) feasible = feasible && v > 0;
      if (feasible) {
        std::fill(x.begin(), x.end(), 0.0);
        for (std::size_t c = 0; c < cols.size(); ++c) x[cols[c]] = z[c];
        break;
      }
      // Step from x towards z as far as feasibility allows; drop the coordinates that reach zero.
      double alpha = std::numeric_limits<double>::infinity();
      for (std::size_t c = 0; c < cols.size(); ++c)
        if (z[c] <= 0) alpha = std::min(alpha, x[cols[c]] / (x[cols[c]] - z[c]));
      for (std::size_t c = 0; c < cols.size(); ++c) {
        x[cols[c]] += alpha * (z[c] - x[cols[c]]);
        if (x[cols[c]] <= 1e-15) x[cols[c]] = 0, passive[cols[c]] = 0;
      }
    }
  }
  return x;
}

}  // namespace nephos::atmosphere
