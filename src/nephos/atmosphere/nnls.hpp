#pragma once
// Non-negative least squares: min |A x - b| subject to x >= 0 (Lawson & Hanson 1974, "Solving
// least squares problems", algorithm NNLS, chapter 23), with the passive set's unconstrained
// problems solved by Householder QR.
#include <cstddef>
#include <vector>

namespace nephos::atmosphere {

/// @param a  m x n, row-major
/// @param b  m values
/// @return x, n values, all >= 0
std::vector<double> nnls(const std::vector<double>& a, const std::vector<double>& b, std::size_t m, std::size_t n);

/// The least-squares solution of A[:, cols] z = b by Householder QR (A m x n row-major).
std::vector<double> least_squares(const std::vector<double>& a, const std::vector<double>& b, std::size_t m,
                                  std::size_t n, const std::vector<std::size_t>& cols);

}  // namespace nephos::atmosphere
