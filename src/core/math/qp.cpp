// Hildreth's dual coordinate ascent with the active-set finish (qp.hpp explains both), step for step as
// the Python kernels it replaced (issue 32: hildreth, _row_curvature, _polish and _active_solve): the same sums in the
// same order and Python's max tie rule, compiled without fused multiply-adds (CMakeLists.txt), so the same bits.
#include "math/qp.hpp"

#include <stdexcept>

#include "math/linalg.hpp"

namespace pfield::math {
namespace {

// The workspace's buffers as the solve sees them.
struct Scratch {
  double* hinv_rows;  // (m, n), row stride n
  double* mu;
  double* curvature;
  double* free;
  std::size_t* active;
  double* schur;      // (n, n), row stride n
  double* target;
  double* lambda;
  double* solution;
};

// b_k - a_k x: how far row k is from holding (> 0: violated).
double slack(const QpProblem& p, std::size_t k, const double* x) {
  const double* a = p.rows.a + k * p.rows.stride;
  double s = p.rows.b[k];
  for (std::size_t j = 0; j < p.n; ++j) s -= a[j] * x[j];
  return s;
}

constexpr double kNotComputed = -1.0;  // a curvature not computed yet (H^-1 a_k neither)

// A row the sweeps skip: a_k^T H^-1 a_k <= 1e-14, a zero row to working precision (no multiplier moves x).
inline bool zero_row(const double* curvature, std::size_t k) {
  return curvature[k] != kNotComputed && curvature[k] <= 1e-14;
}

// max(0, max_k b_k - a_k x) over the rows but zero ones: how far x is from holding the rows the sweeps can act on.
// (A zero row with b_k > 0 is violated in sweep 1, so its curvature is known: one not computed is no zero row.)
double largest_slack(const QpProblem& p, const double* x, const double* curvature) {
  double worst = 0.0;
  for (std::size_t k = 0; k < p.rows.m; ++k) {
    if (zero_row(curvature, k)) continue;
    const double v = slack(p, k, x);
    worst = v > worst ? v : worst;
  }
  return worst;
}

// H^-1 a_k into row k of hinv_rows, and a_k^T H^-1 a_k: the curvature of the dual function along mu_k (the step
// mu_k += slack / curvature maximises the dual along that coordinate). The one place both are computed: the
// sweeps and the finish's joining rows call it.
double row_curvature(const QpProblem& p, std::size_t k, double* hinv_rows) {
  const double* a = p.rows.a + k * p.rows.stride;
  double* g = hinv_rows + k * p.n;
  cholesky_solve(p.factor, p.factor_stride, a, g, p.n);
  double c = 0.0;
  for (std::size_t j = 0; j < p.n; ++j) c += a[j] * g[j];
  return c;
}

// The multipliers lambda of the active rows' equality QP: S lambda = b_act - A_act x_u with the Schur complement
// S = A_act H^-1 A_act^T (its lower triangle, what the factorisation reads). False when S's smallest relative
// pivot is <= 1e-10 (rows dependent to working precision): those are left to the sweeps.
bool active_solve(const QpProblem& p, const Scratch& s, std::size_t count) {
  const std::size_t n = p.n;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t ki = s.active[i];
    const double* a = p.rows.a + ki * p.rows.stride;
    s.target[i] = slack(p, ki, s.free);
    for (std::size_t l = 0; l <= i; ++l) {
      const double* g = s.hinv_rows + s.active[l] * n;
      double v = 0.0;
      for (std::size_t j = 0; j < n; ++j) v += a[j] * g[j];
      s.schur[i * n + l] = v;
    }
  }
  if (cholesky_in_place(s.schur, count, n) <= 1e-10) return false;
  cholesky_solve(s.schur, n, s.target, s.lambda, count);
  return true;
}

// The active-set finish from the sweeps' guess (the rows with mu > 0). With x_u = x - sum_k mu_k H^-1 a_k the
// unconstrained optimum, the active rows' lambda (active_solve) gives x = x_u + H^-1 A_act^T lambda. A negative
// lambda drops its row (the most negative first), else the most violated row joins, until the KKT conditions hold
// (lambda >= 0, every row within tolerance: then x and mu take the optimum and the result is true) or after 2n + 1
// changes. More than n active rows, or a singular S, are left to the sweeps; on false x and mu are unchanged (the
// joining rows' H^-1 a_k and curvatures stay computed).
bool polish(const QpProblem& p, double* x, const Scratch& s, double tolerance) {
  const std::size_t m = p.rows.m, n = p.n;
  for (std::size_t j = 0; j < n; ++j) s.free[j] = x[j];
  std::size_t guessed = 0;
  for (std::size_t k = 0; k < m; ++k) {
    if (s.mu[k] > 0.0) {
      ++guessed;
      const double* g = s.hinv_rows + k * n;
      for (std::size_t j = 0; j < n; ++j) s.free[j] -= s.mu[k] * g[j];
    }
  }
  if (guessed > n) return false;
  std::size_t count = 0;
  for (std::size_t k = 0; k < m; ++k)
    if (s.mu[k] > 0.0) s.active[count++] = k;
  for (std::size_t change = 0; change < 2 * n + 1; ++change) {
    if (!active_solve(p, s, count)) return false;
    std::size_t drop = count;  // none
    double lowest = 0.0;
    for (std::size_t i = 0; i < count; ++i) {
      if (s.lambda[i] < lowest) {
        drop = i;
        lowest = s.lambda[i];
      }
    }
    if (drop < count) {
      s.active[drop] = s.active[count - 1];
      --count;
      continue;
    }
    for (std::size_t j = 0; j < n; ++j) s.solution[j] = s.free[j];
    for (std::size_t i = 0; i < count; ++i) {
      const double* g = s.hinv_rows + s.active[i] * n;
      for (std::size_t j = 0; j < n; ++j) s.solution[j] += s.lambda[i] * g[j];
    }
    std::size_t join = m;  // none
    double violation = tolerance;
    for (std::size_t k = 0; k < m; ++k) {
      const double v = slack(p, k, s.solution);
      if (v > violation) {
        join = k;
        violation = v;
      }
    }
    if (join == m) {
      for (std::size_t j = 0; j < n; ++j) x[j] = s.solution[j];
      for (std::size_t k = 0; k < m; ++k) s.mu[k] = 0.0;
      for (std::size_t i = 0; i < count; ++i) s.mu[s.active[i]] = s.lambda[i];
      return true;
    }
    if (count == n) return false;
    if (s.curvature[join] < 0.0) s.curvature[join] = row_curvature(p, join, s.hinv_rows);  // never swept active
    s.active[count++] = join;
  }
  return false;
}

void check_fits(std::size_t m, std::size_t n, const QpWorkspace& ws) {
  if (m > ws.max_rows() || n > ws.max_variables())
    throw std::invalid_argument("qp: the problem has more rows or variables than its workspace");
}

}  // namespace

QpWorkspace::QpWorkspace(std::size_t max_rows, std::size_t max_variables)
    : max_rows_(max_rows),
      max_variables_(max_variables),
      hinv_rows_(max_rows * max_variables),
      mu_(max_rows),
      curvature_(max_rows),
      free_(max_variables),
      active_(max_variables),
      schur_(max_variables * max_variables),
      target_(max_variables),
      lambda_(max_variables),
      solution_(max_variables) {}

QpResult hildreth(const QpProblem& problem, double* x, QpWorkspace& ws, const QpSettings& settings) {
  const std::size_t m = problem.rows.m, n = problem.n;
  check_fits(m, n, ws);
  const Scratch s{ws.hinv_rows_.data(), ws.mu_.data(),     ws.curvature_.data(), ws.free_.data(),
                  ws.active_.data(),    ws.schur_.data(), ws.target_.data(),    ws.lambda_.data(),
                  ws.solution_.data()};
  for (std::size_t k = 0; k < m; ++k) {
    s.mu[k] = 0.0;
    s.curvature[k] = kNotComputed;
  }
  QpResult result;
  double worst = 0.0;
  bool holds = false;  // x meets every row within tolerance
  std::int64_t polish_at = 1;
  for (std::int64_t sweep = 1; sweep <= settings.max_sweeps; ++sweep) {
    result.sweeps = sweep;
    worst = 0.0;
    for (std::size_t k = 0; k < m; ++k) {
      const double v = slack(problem, k, x);
      if (v <= 0.0 && s.mu[k] == 0.0) continue;  // satisfied and inactive
      const double* g = s.hinv_rows + k * n;
      if (s.curvature[k] < 0.0) s.curvature[k] = row_curvature(problem, k, s.hinv_rows);
      if (s.curvature[k] <= 1e-14) continue;  // a zero row (zero_row): no multiplier moves x
      const double trial = s.mu[k] + v / s.curvature[k];
      const double updated = trial > 0.0 ? trial : 0.0;  // Python's max(0.0, trial)
      const double step = updated - s.mu[k];
      if (step != 0.0) {
        for (std::size_t j = 0; j < n; ++j) x[j] += step * g[j];
        s.mu[k] = updated;
      }
      worst = v > worst ? v : worst;  // Python's max(worst, v)
    }
    // Each row's slack was taken before its own update: the updates after it may have moved x off it (on an
    // ill-conditioned H by far more than the tolerance). Stop only when x itself holds every row (but zero ones).
    if (worst <= settings.tolerance) {
      worst = largest_slack(problem, x, s.curvature);
      if (worst <= settings.tolerance) {
        holds = true;
        break;
      }
    }
    if (sweep == polish_at) {
      polish_at *= 2;
      if (polish(problem, x, s, settings.tolerance)) {
        result.active_set = true;
        result.violation = 0.0;
        return result;
      }
    }
  }
  // out of sweeps: the violation of the x returned (the last sweep's slacks were each taken before later updates)
  result.violation = holds ? worst : largest_slack(problem, x, s.curvature);
  return result;
}

QpResult solve_qp(double* h, std::size_t h_stride, const double* c, const QpRows& rows, std::size_t n, double* x,
                  QpWorkspace& ws, const QpSettings& settings) {
  check_fits(rows.m, n, ws);  // before H is overwritten
  cholesky_in_place(h, n, h_stride);
  cholesky_solve(h, h_stride, c, x, n);
  return hildreth({h, h_stride, rows, n}, x, ws, settings);
}

}  // namespace pfield::math
