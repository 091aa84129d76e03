// Dense linear algebra of the per-step kernels: the Cholesky factor and solve on n <= ~10 variables, where plain
// loops beat a LAPACK call. One home: the velocity QP (math/qp), damped least squares (IK, the assistance) and
// every other solve in the core use these. Same operation order as the Python kernels they replaced (issue 32).
//
// Matrices are row-major with a row stride (the leading n x n block of a larger buffer is factored in place).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace pfield::math {

// Lower Cholesky factor L (H = L L^T) of the leading n x n block of h, written into its lower triangle (read from
// it). Returns the smallest squared pivot relative to its diagonal entry (1 for a diagonal matrix, near 0 for
// nearly dependent rows, <= 0 when the block is not positive definite); a pivot <= 0 is clamped to 1e-300 so the
// factor stays finite, and callers that may meet such blocks test the returned value.
inline double cholesky_in_place(double* h, std::size_t n, std::size_t stride) {
  double smallest = 1.0;
  for (std::size_t j = 0; j < n; ++j) {
    double* row_j = h + j * stride;
    const double diagonal = row_j[j];
    double s = diagonal;
    for (std::size_t k = 0; k < j; ++k) s -= row_j[k] * row_j[k];
    const double relative = diagonal > 0.0 ? s / diagonal : 0.0;
    smallest = relative < smallest ? relative : smallest;  // Python's min(smallest, relative)
    row_j[j] = std::sqrt(1e-300 > s ? 1e-300 : s);        // Python's max(s, 1e-300) (NaN stays NaN)
    for (std::size_t i = j + 1; i < n; ++i) {
      double* row_i = h + i * stride;
      double t = row_i[j];
      for (std::size_t k = 0; k < j; ++k) t -= row_i[k] * row_j[k];
      row_i[j] = t / row_j[j];
    }
  }
  return smallest;
}

// Solves L L^T x = rhs with the factor of cholesky_in_place; x into out (may not alias rhs).
inline void cholesky_solve(const double* factor, std::size_t stride, const double* rhs, double* out, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    double s = rhs[i];
    for (std::size_t k = 0; k < i; ++k) s -= factor[i * stride + k] * out[k];
    out[i] = s / factor[i * stride + i];
  }
  for (std::size_t i = n; i-- > 0;) {
    double s = out[i];
    for (std::size_t k = i + 1; k < n; ++k) s -= factor[k * stride + i] * out[k];
    out[i] = s / factor[i * stride + i];
  }
}

}  // namespace pfield::math
