// Damped least squares, the one home of this step in the core (the IK, the shared-control assistance, the teleop
// demo's baseline):
//
//     x = J_f^T (J_f J_f^T + damping I)^-1 e
//
// (Wampler 1986; Buss, "Introduction to inverse kinematics with Jacobian transpose, pseudoinverse and damped least
// squares methods", 2004, eq. 11) for an m x n Jacobian J (m <= kMaxDlsRows task rows, row-major), where J_f is J
// with the columns of frozen joints removed (their x_j is 0) and `damping` is lambda^2. The m x m system is solved
// by math/linalg.hpp's Cholesky. Same operation order as the Python kernels it replaced (issue 32: the IK's DLS
// step, the assistance's user-velocity map), so the same bits.
//
// In two steps for callers that inspect the undamped Gram matrix first (the assistance's singularity test on
// J J^T): dls_gram, then dls_from_gram; damped_least_squares does both.
#pragma once

#include <cstddef>
#include <cstdint>

#include "math/linalg.hpp"

namespace pfield::math {

constexpr std::size_t kMaxDlsRows = 6;

// How the x_j = sum_k J_kj y_k sums start. The two kernels this replaced differed only here, and only in the sign of
// a zero (0.0 + (-0.0) is +0.0): the IK starts from its first term, the assistance from 0.0. Kept so both keep their
// recorded bits; one form would do, at the cost of those values' signed zeros.
enum class DlsSum { FromFirstTerm, FromZero };

// gram (m x m, row-major, every entry written) = J_f J_f^T; frozen (n,) nonzero marks a removed column, or null.
inline void dls_gram(const double* jacobian, std::size_t m, std::size_t n, const std::uint8_t* frozen,
                     double* gram) {
  for (std::size_t r = 0; r < m; ++r) {
    const double* row_r = jacobian + r * n;
    for (std::size_t c = 0; c <= r; ++c) {
      const double* row_c = jacobian + c * n;
      double s = 0.0;
      for (std::size_t j = 0; j < n; ++j)
        if (frozen == nullptr || frozen[j] == 0) s += row_r[j] * row_c[j];
      gram[r * m + c] = s;
      gram[c * m + r] = s;
    }
  }
}

// x (n,) = J_f^T (gram + damping I)^-1 e from gram = J_f J_f^T (dls_gram); gram is overwritten by its factor.
// Returns cholesky_in_place's smallest relative pivot (<= 0: the damped matrix was not positive definite).
inline double dls_from_gram(const double* jacobian, std::size_t m, std::size_t n, const std::uint8_t* frozen,
                            double* gram, double damping, const double* e, double* x,
                            DlsSum sum = DlsSum::FromFirstTerm) {
  for (std::size_t r = 0; r < m; ++r) gram[r * m + r] += damping;
  const double smallest = cholesky_in_place(gram, m, m);
  double y[kMaxDlsRows];
  cholesky_solve(gram, m, e, y, m);
  for (std::size_t j = 0; j < n; ++j) {
    if (frozen != nullptr && frozen[j] != 0) {
      x[j] = 0.0;
      continue;
    }
    double s = sum == DlsSum::FromZero ? 0.0 + jacobian[j] * y[0] : jacobian[j] * y[0];
    for (std::size_t k = 1; k < m; ++k) s += jacobian[k * n + j] * y[k];
    x[j] = s;
  }
  return smallest;
}

// The whole step: x (n,) = J_f^T (J_f J_f^T + damping I)^-1 e, for m <= kMaxDlsRows rows.
inline double damped_least_squares(const double* jacobian, std::size_t m, std::size_t n, const std::uint8_t* frozen,
                                   double damping, const double* e, double* x, DlsSum sum = DlsSum::FromFirstTerm) {
  double gram[kMaxDlsRows * kMaxDlsRows];
  dls_gram(jacobian, m, n, frozen, gram);
  return dls_from_gram(jacobian, m, n, frozen, gram, damping, e, x, sum);
}

}  // namespace pfield::math
