// The velocity QP (src/core/math/qp.hpp): closed-form optima, the active-set finish on nearly parallel rows,
// infeasible rows, strided buffers and workspace reuse. Also run under AddressSanitizer and UBSan (make core-test);
// tests/test_core_qp.py holds it to the values it had when it replaced the Python solver, bit for bit.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "harness.hpp"
#include "math/linalg.hpp"
#include "math/qp.hpp"

namespace {

using namespace pfield::math;

// minimise 1/2 x^T H x - c^T x subject to A x >= b, all row-major and compact; x, mu and the result out.
struct Solved {
  std::vector<double> x, mu;
  QpResult result;
};

Solved solve(std::vector<double> h, const std::vector<double>& c, const std::vector<double>& a,
             const std::vector<double>& b, QpSettings settings = {}) {
  const std::size_t n = c.size(), m = b.size();
  QpWorkspace ws(m, n);
  Solved out{std::vector<double>(n), std::vector<double>(m), {}};
  out.result = solve_qp(h.data(), n, c.data(), {a.data(), n, b.data(), m}, n, out.x.data(), ws, settings);
  std::copy(ws.multipliers(), ws.multipliers() + m, out.mu.begin());  // memcpy may not take m = 0's null
  return out;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace

TEST(qp_without_rows_returns_the_unconstrained_optimum) {
  const Solved s = solve({4.0, 2.0, 2.0, 2.0}, {2.0, 2.0}, {}, {});
  CHECK(s.x[0] == 0.0 && s.x[1] == 1.0);  // H x = c: x = (0, 1), exact in binary
  CHECK(s.result.sweeps == 1 && !s.result.active_set && s.result.violation == 0.0);
}

TEST(qp_projects_onto_one_violated_row_in_closed_form) {
  // H = diag(2, 1), c = 0, x1 + x2 >= 1: mu = b / (a^T H^-1 a) = 1 / 1.5, x = H^-1 a mu = (1/3, 2/3)
  const Solved s = solve({2.0, 0.0, 0.0, 1.0}, {0.0, 0.0}, {1.0, 1.0}, {1.0});
  CHECK_NEAR(s.x[0], 1.0 / 3.0, 1e-15);
  CHECK_NEAR(s.x[1], 2.0 / 3.0, 1e-15);
  CHECK_NEAR(s.mu[0], 2.0 / 3.0, 1e-15);
  CHECK(s.result.violation <= 1e-7);
}

TEST(qp_leaves_satisfied_rows_inactive) {
  // the optimum x = c = (1, 1) already has x1 >= 0 and x1 + x2 >= -3
  const Solved s = solve({1.0, 0.0, 0.0, 1.0}, {1.0, 1.0}, {1.0, 0.0, 1.0, 1.0}, {0.0, -3.0});
  CHECK(s.x[0] == 1.0 && s.x[1] == 1.0 && s.mu[0] == 0.0 && s.mu[1] == 0.0);
  CHECK(s.result.sweeps == 1 && s.result.violation == 0.0);
}

TEST(qp_active_set_finish_solves_nearly_parallel_rows) {
  // two links pressing on one surface (tests/planning/test_whole_body.py): both rows active at
  // x = (1, (1 - cos t) / sin t, 0); the third row holds and stays inactive
  const double t = 0.01;
  const Solved s = solve({1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}, {0.0, 0.0, 0.0},
                         {1.0, 0.0, 0.0, std::cos(t), std::sin(t), 0.0, 0.0, 0.0, -1.0}, {1.0, 1.0, -5.0},
                         {200, 1e-12});
  CHECK(s.result.active_set && s.result.violation == 0.0);
  CHECK(s.result.sweeps <= 8);  // the sweeps alone would gain ~t^2 per sweep
  CHECK_NEAR(s.x[0], 1.0, 1e-12);
  CHECK_NEAR(s.x[1], (1.0 - std::cos(t)) / std::sin(t), 1e-12);
  CHECK(s.x[2] == 0.0 && s.mu[2] == 0.0);
  CHECK(s.mu[0] > 0.0 && s.mu[1] > 0.0);
}

TEST(qp_infeasible_rows_stay_finite) {
  // x >= 1 and -x >= 0 cannot both hold: all sweeps run, the compromise is finite
  const Solved s = solve({1.0}, {0.0}, {1.0, -1.0}, {1.0, 0.0});
  CHECK(s.result.sweeps == 200 && !s.result.active_set);
  CHECK(std::isfinite(s.x[0]) && std::isfinite(s.mu[0]) && std::isfinite(s.mu[1]));
  CHECK(s.result.violation > 0.0 && s.result.violation <= 1.0);
}

TEST(qp_zero_row_is_skipped) {
  // 0 x >= 1 has no multiplier that moves x (curvature 0): the sweeps skip it and report nothing for it
  const Solved s = solve({1.0, 0.0, 0.0, 1.0}, {1.0, -1.0}, {0.0, 0.0, 0.0, 1.0}, {1.0, 0.0});
  CHECK(s.mu[0] == 0.0);
  CHECK_NEAR(s.x[1], 0.0, 1e-15);
  CHECK(s.x[0] == 1.0);
}

TEST(qp_reads_strided_buffers_and_reuses_its_workspace) {
  // one problem compact, and embedded in larger buffers (the whole-body step's rows have m_max rows of stride n,
  // its factor may sit in a bigger block); a workspace reused after another solve gives the same bits
  const std::size_t n = 3, m = 4, stride = 5;
  const std::vector<double> h = {3.0, 0.5, 0.2, 0.5, 2.0, -0.3, 0.2, -0.3, 1.5};
  const std::vector<double> c = {0.3, -0.7, 1.1};
  const std::vector<double> a = {1.0, 0.2, 0.0, -0.4, 1.0, 0.3, 0.7, 0.7, 0.1, 0.0, -1.0, 0.9};
  const std::vector<double> b = {0.5, 0.4, 0.8, -0.2};
  const Solved compact = solve(h, c, a, b);

  std::vector<double> big_h(n * stride, 99.0), big_a(m * stride, 99.0), x(n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) big_h[i * stride + j] = h[i * n + j];
  for (std::size_t k = 0; k < m; ++k)
    for (std::size_t j = 0; j < n; ++j) big_a[k * stride + j] = a[k * n + j];
  QpWorkspace ws(10, 8);
  std::vector<double> other_h = {2.0, 0.0, 0.0, 2.0}, other_x(2);
  const std::vector<double> other_c = {1.0, 1.0}, other_a = {-1.0, -1.0}, other_b = {0.0};
  solve_qp(other_h.data(), 2, other_c.data(), {other_a.data(), 2, other_b.data(), 1}, 2, other_x.data(), ws, {});
  const QpResult result = solve_qp(big_h.data(), stride, c.data(), {big_a.data(), stride, b.data(), m}, n, x.data(),
                                   ws, {});
  CHECK(same_bits(x, compact.x));
  CHECK(same_bits(std::vector<double>(ws.multipliers(), ws.multipliers() + m), compact.mu));
  CHECK(result.sweeps == compact.result.sweeps && result.active_set == compact.result.active_set &&
        result.violation == compact.result.violation);

  // hildreth on the factor directly gives the same as solve_qp
  std::vector<double> factor = h, x0(n);
  cholesky_in_place(factor.data(), n, n);
  cholesky_solve(factor.data(), n, c.data(), x0.data(), n);
  hildreth({factor.data(), n, {a.data(), n, b.data(), m}, n}, x0.data(), ws, {});
  CHECK(same_bits(x0, compact.x));
}

TEST(qp_rejects_a_problem_larger_than_its_workspace) {
  QpWorkspace ws(1, 2);
  std::vector<double> h = {1.0, 0.0, 0.0, 1.0}, x(2);
  const std::vector<double> c = {0.0, 0.0}, a = {1.0, 0.0, 0.0, 1.0}, b = {1.0, 1.0};
  bool thrown = false;
  try {
    solve_qp(h.data(), 2, c.data(), {a.data(), 2, b.data(), 2}, 2, x.data(), ws, {});
  } catch (const std::invalid_argument&) {
    thrown = true;
  }
  CHECK(thrown);
  CHECK(h[0] == 1.0);  // refused before H was factored
}

// Jacobi's eigenvalues of symmetric matrices whose eigenvalues are known: a diagonal one (no rotation), a 2 x 2 with
// eigenvalues 1 and 3, and Q diag(1e-6, 1, 2, 3, 5, 1e3) Q^T for an orthogonal Q built from two Householder
// reflections (a Gram matrix's spread of nine orders of magnitude, as near a singularity).
TEST(symmetric_eigenvalues_by_jacobi_rotations) {
  std::vector<double> diagonal = {3.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 7.0};
  double values[6];
  symmetric_eigenvalues(diagonal.data(), 3, values);
  CHECK(values[0] == 3.0 && values[1] == -1.0 && values[2] == 7.0);
  std::vector<double> pair = {2.0, 1.0, 1.0, 2.0};
  symmetric_eigenvalues(pair.data(), 2, values);
  CHECK_NEAR(std::min(values[0], values[1]), 1.0, 1e-15);
  CHECK_NEAR(std::max(values[0], values[1]), 3.0, 1e-15);
  const double expected[6] = {1e-6, 1.0, 2.0, 3.0, 5.0, 1e3};
  const double u[6] = {1, 2, -1, 0.5, 3, -2}, v[6] = {0.3, -1, 2, 1, -0.5, 1};
  auto householder = [](const double* w) {  // I - 2 w w^T / w^T w
    std::vector<double> h(36);
    double norm2 = 0.0;
    for (int i = 0; i < 6; ++i) norm2 += w[i] * w[i];
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) h[i * 6 + j] = (i == j ? 1.0 : 0.0) - 2.0 * w[i] * w[j] / norm2;
    return h;
  };
  const std::vector<double> hu = householder(u), hv = householder(v);
  std::vector<double> q(36, 0.0), a(36, 0.0);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      for (int k = 0; k < 6; ++k) q[i * 6 + j] += hu[i * 6 + k] * hv[k * 6 + j];
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      for (int k = 0; k < 6; ++k) a[i * 6 + j] += q[i * 6 + k] * expected[k] * q[j * 6 + k];
  symmetric_eigenvalues(a.data(), 6, values);
  std::sort(values, values + 6);
  for (int i = 0; i < 6; ++i) CHECK_NEAR(values[i], expected[i], 1e-12);
}

TEST(cholesky_reports_its_smallest_relative_pivot) {
  // The factor of [[4, 2], [2, 2]] is [[2, 0], [1, 1]]; its second squared pivot is 2 - 1 = 1, half its diagonal
  // entry. Dependent rows give 0 and an indefinite block a negative value (the factor stays finite).
  std::vector<double> h = {4.0, 2.0, 2.0, 2.0};
  CHECK(cholesky_in_place(h.data(), 2, 2) == 0.5);
  CHECK(h[0] == 2.0 && h[2] == 1.0 && h[3] == 1.0);
  std::vector<double> ones = {1.0, 1.0, 1.0, 1.0};
  CHECK(cholesky_in_place(ones.data(), 2, 2) == 0.0);
  std::vector<double> indefinite = {1.0, 2.0, 2.0, 1.0};
  CHECK(cholesky_in_place(indefinite.data(), 2, 2) == -3.0);
  CHECK(std::all_of(indefinite.begin(), indefinite.end(), [](double v) { return std::isfinite(v); }));
  std::vector<double> diagonal = {3.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 7.0};
  CHECK(cholesky_in_place(diagonal.data(), 3, 3) == 1.0);
}
