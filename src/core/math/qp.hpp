// The velocity QP of the whole-body step (the only QP of the core):
//
//     minimise  1/2 x^T H x - c^T x    subject to  A x >= b        (H symmetric positive definite, n <= ~10)
//
// Hildreth's method (Hildreth 1957; Luenberger & Ye, Linear and Nonlinear Programming, 4th ed., sec. 14.7): dual
// coordinate ascent on the multipliers mu >= 0 of x = H^-1 (c + A^T mu). One sweep updates each multiplier in turn
// in closed form, mu_k <- max(0, mu_k + (b_k - a_k x) / (a_k^T H^-1 a_k)), and moves x by the change times H^-1 a_k.
// It converges to the optimum when the rows are feasible and stays bounded when they are not (callers then get the
// best compromise after max_sweeps, never NaN).
//
// Coordinate ascent crawls when active rows are nearly parallel (two links pressing on one table), so after sweeps
// 1, 2, 4, 8, ... the rows with mu > 0 are taken as the active set and the equality-constrained QP on them is solved
// exactly through the Schur complement S = A_act H^-1 A_act^T (Nocedal & Wright, Numerical Optimization, 2nd ed.,
// eq. 16.5 and the primal active-set method of sec. 16.5): when its multipliers are >= 0 and every row holds, the
// KKT conditions hold and the sweeps stop.
//
// The same operations in the same order as the Python kernel it replaced (issue 32), so the same bits, but for the
// stopping test: the kernel stopped on the last sweep's slacks alone, this also checks x against every row
// (QpResult::violation; tests/test_core_qp.py holds the recorded values and says what changed). The Cholesky factor
// and solve are math/linalg.hpp's (the one home of both).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pfield::math {

// The constraints A x >= b: m rows of n coefficients (row k at a + k * stride) and their bounds b (m,).
struct QpRows {
  const double* a = nullptr;
  std::size_t stride = 0;
  const double* b = nullptr;
  std::size_t m = 0;
};

// The QP as Hildreth reads it: H through its lower Cholesky factor L (H = L L^T, math::cholesky_in_place's output,
// n x n with row stride factor_stride) and the rows.
struct QpProblem {
  const double* factor = nullptr;
  std::size_t factor_stride = 0;
  QpRows rows;
  std::size_t n = 0;
};

struct QpSettings {
  std::int64_t max_sweeps = 200;  // the whole-body step's
  double tolerance = 1e-7;        // largest violation accepted (the rows' unit: m/s or rad/s)
};

struct QpResult {
  std::int64_t sweeps = 0;   // sweeps run (the last one included; 0 when max_sweeps <= 0)
  bool active_set = false;   // the active-set finish found the optimum (then violation is 0)
  // max(0, max_k b_k - a_k x) of the x returned. The sweeps stop when every row's slack, taken before its own
  // update, is within tolerance AND x then holds every row within it: on an ill-conditioned H the updates after a
  // row's may move x off it by far more (the numba kernel stopped and reported the former alone; tests/
  // test_core_qp.py). 0 after the active-set finish, which checks every row within tolerance at its solution.
  double violation = 0.0;
};

// The QP's scratch, sized once for at most max_rows rows and max_variables variables and reused by every solve
// (the whole-body stepper keeps one): no allocation per solve, where the Python kernel's finish allocated six arrays
// per call. After a solve it also holds the multipliers and the row curvatures, which tests and diagnostics read.
class QpWorkspace {
 public:
  QpWorkspace(std::size_t max_rows, std::size_t max_variables);

  std::size_t max_rows() const { return max_rows_; }
  std::size_t max_variables() const { return max_variables_; }
  // mu of the last solve's rows (m,)
  const double* multipliers() const { return mu_.data(); }
  // a_k^T H^-1 a_k of the last solve's rows (m,); -1 for a row whose H^-1 a_k was never needed
  const double* curvatures() const { return curvature_.data(); }

 private:
  friend QpResult hildreth(const QpProblem& problem, double* x, QpWorkspace& ws, const QpSettings& settings);

  std::size_t max_rows_, max_variables_;
  std::vector<double> hinv_rows_;  // (m, n): H^-1 a_k, filled only for rows that become active
  std::vector<double> mu_;         // (m,)
  std::vector<double> curvature_;  // (m,)
  // the active-set finish's scratch
  std::vector<double> free_;       // (n,) x_u, the unconstrained optimum
  std::vector<std::size_t> active_;  // (n,) the active rows
  std::vector<double> schur_;      // (n, n) S and its factor
  std::vector<double> target_;     // (n,) b_act - A_act x_u
  std::vector<double> lambda_;     // (n,) the active rows' multipliers
  std::vector<double> solution_;   // (n,) x_u + H^-1 A_act^T lambda
};

// Enforces A x >= b on the unconstrained optimum x = H^-1 c (n,), updated in place into the QP's solution;
// ws.multipliers() then holds mu. Throws std::invalid_argument when the problem exceeds the workspace.
QpResult hildreth(const QpProblem& problem, double* x, QpWorkspace& ws, const QpSettings& settings);

// The whole QP from H and c: H's n x n block (row stride h_stride) is factored in place (math::cholesky_in_place),
// x = H^-1 c, then hildreth. The whole-body step's three lines (velocity_from_segments), in their order.
QpResult solve_qp(double* h, std::size_t h_stride, const double* c, const QpRows& rows, std::size_t n, double* x,
                  QpWorkspace& ws, const QpSettings& settings);

}  // namespace pfield::math
