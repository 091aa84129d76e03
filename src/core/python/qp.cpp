// Bindings of the velocity QP (math/qp.hpp) for tests/test_core_qp.py, which holds it to a digest of the results of
// the numba solver it replaced (issue 32) and to the KKT conditions: not a public pfield API (the whole-body step
// calls the QP inside the core).
#include <nanobind/nanobind.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "math/qp.hpp"
#include "python/arrays.hpp"

namespace pfield::python {
namespace {

using namespace nb::literals;

// One solve's outcome: the solution, the multipliers and row curvatures the workspace holds afterwards (what the
// numba solver's x, mu and curvature arrays held after hildreth), and the result.
struct Solution {
  nb::object x, multipliers, curvatures;  // NumPy arrays
  math::QpResult result;
};

// The shapes the QP reads: a square (n, n) matrix, x or c of n, rows (m, n) and b of m.
void check_shapes(const Matrix& square, const Vector& vector, const Matrix& rows, const Vector& b) {
  const std::size_t n = square.shape(0);
  if (square.shape(1) != n || vector.shape(0) != n || rows.shape(1) != n || b.shape(0) != rows.shape(0))
    throw std::invalid_argument("expected an (n, n) matrix, a vector of n, rows (m, n) and b (m,)");
}

// One solve: the shapes checked, run(rows, x, workspace) with the GIL released (x (n,) a new array), then the
// workspace's multipliers and curvatures copied out next to x and the result.
template <typename Run>
Solution solve_with(const Matrix& square, const Vector& vector, const Matrix& rows, const Vector& b, Run run) {
  check_shapes(square, vector, rows, b);
  const std::size_t n = square.shape(0), m = rows.shape(0);
  auto [x, data] = new_array({n});
  math::QpWorkspace ws(m, n);
  math::QpResult result;
  {
    nb::gil_scoped_release release;
    result = run(math::QpRows{rows.data(), n, b.data(), m}, data, ws);
  }
  auto [multipliers, mu] = new_array({m});
  auto [curvatures, curvature] = new_array({m});
  std::copy(ws.multipliers(), ws.multipliers() + m, mu);
  std::copy(ws.curvatures(), ws.curvatures() + m, curvature);
  return {nb::cast(std::move(x)), nb::cast(std::move(multipliers)), nb::cast(std::move(curvatures)), result};
}

}  // namespace

void bind_qp(nb::module_& m) {
  m.doc() = "The velocity QP (Hildreth with the active-set finish) of the compiled core, for its tests.";

  nb::class_<math::QpResult>(m, "Result")
      .def_ro("sweeps", &math::QpResult::sweeps, "Sweeps run, the last included.")
      .def_ro("active_set", &math::QpResult::active_set, "The active-set finish found the optimum.")
      .def_ro("violation", &math::QpResult::violation, "max(0, max_k b_k - a_k x) of the x returned (0 after the active-set finish).");

  nb::class_<Solution>(m, "Solution")
      .def_ro("x", &Solution::x)
      .def_ro("multipliers", &Solution::multipliers)
      .def_ro("curvatures", &Solution::curvatures, "a^T H^-1 a per row; -1 where never needed.")
      .def_ro("result", &Solution::result);

  m.def(
      "hildreth",
      [](const Matrix& factor, const Vector& x0, const Matrix& rows, const Vector& b, std::int64_t max_sweeps,
         double tolerance) {
        return solve_with(factor, x0, rows, b, [&](const math::QpRows& constraints, double* x, math::QpWorkspace& ws) {
          const std::size_t n = factor.shape(0);
          std::copy(x0.data(), x0.data() + n, x);
          return math::hildreth({factor.data(), n, constraints, n}, x, ws, {max_sweeps, tolerance});
        });
      },
      "factor"_a, "x"_a, "rows"_a, "b"_a, "max_sweeps"_a = 200, "tolerance"_a = 1e-7,
      "Enforce rows @ x >= b from the unconstrained optimum x, H = factor factor^T.");

  m.def(
      "solve",
      [](const Matrix& h, const Vector& c, const Matrix& rows, const Vector& b, std::int64_t max_sweeps,
         double tolerance) {
        return solve_with(h, c, rows, b, [&](const math::QpRows& constraints, double* x, math::QpWorkspace& ws) {
          const std::size_t n = h.shape(0);
          std::vector<double> factor(h.data(), h.data() + n * n);  // solve_qp factors H in place
          return math::solve_qp(factor.data(), n, c.data(), constraints, n, x, ws, {max_sweeps, tolerance});
        });
      },
      "h"_a, "c"_a, "rows"_a, "b"_a, "max_sweeps"_a = 200, "tolerance"_a = 1e-7,
      "minimise 1/2 x^T H x - c^T x subject to rows @ x >= b (H symmetric positive definite).");
}

}  // namespace pfield::python
