// Dense linear algebra of the per-step kernels: the Cholesky factor and solve, and the eigenvalues of a symmetric
// matrix, on n <= ~10 variables, where plain loops beat a LAPACK call. One home: the velocity QP (math/qp), damped
// least squares (IK, the assistance), the condition number (robot/kinematics) and every other solve in the core use
// these. Same operation order as the Python kernels they replaced (issue 32).
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

// The eigenvalues of the symmetric n x n matrix a (row-major, overwritten: it ends near diagonal) by cyclic Jacobi
// rotations (Golub & Van Loan, "Matrix Computations", 4th ed., section 8.5.3; each rotation with the smaller angle of
// Rutishauser's form, which keeps it accurate): sweeps until every off-diagonal entry is negligible beside its two
// diagonal entries (or 50 sweeps; a 6 x 6 Gram matrix needs 5 to 8). Accurate to a few ulps of the largest
// eigenvalue; written into values (n,), in no particular order.
inline void symmetric_eigenvalues(double* a, std::size_t n, double* values) {
  for (int sweep = 0; sweep < 50; ++sweep) {
    bool rotated = false;
    for (std::size_t p = 0; p + 1 < n; ++p) {
      for (std::size_t q = p + 1; q < n; ++q) {
        const double apq = a[p * n + q];
        const double app = a[p * n + p], aqq = a[q * n + q];
        if (std::abs(apq) <= 1e-300 || std::abs(apq) <= 1e-18 * std::sqrt(std::abs(app * aqq))) {
          a[p * n + q] = a[q * n + p] = 0.0;
          continue;
        }
        rotated = true;
        const double theta = (aqq - app) / (2.0 * apq);
        const double t = (theta >= 0.0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (std::size_t k = 0; k < n; ++k) {  // columns p and q, then rows p and q: A <- J^T A J
          const double akp = a[k * n + p], akq = a[k * n + q];
          a[k * n + p] = c * akp - s * akq;
          a[k * n + q] = s * akp + c * akq;
        }
        for (std::size_t k = 0; k < n; ++k) {
          const double apk = a[p * n + k], aqk = a[q * n + k];
          a[p * n + k] = c * apk - s * aqk;
          a[q * n + k] = s * apk + c * aqk;
        }
        a[p * n + q] = a[q * n + p] = 0.0;
      }
    }
    if (!rotated) break;
  }
  for (std::size_t i = 0; i < n; ++i) values[i] = a[i * n + i];
}

}  // namespace pfield::math
