"""Dense linear algebra of the compiled kernels (numba): Cholesky factor and solve, and a tiny QP solver.

The bottom layer next to :mod:`pfield._spatial_kernels`: the whole-body velocity QP
(:mod:`pfield.planning._whole_body_kernel`) and the damped least-squares IK (:mod:`pfield.robot.ik`)
both solve with these, on n ≤ ~10 variables, so plain loops beat LAPACK calls from compiled code.

QP (:func:`hildreth`)::

    minimise   ½ xᵀ H x − cᵀ x      subject to   A x ≥ b        (H symmetric positive definite)

Hildreth's method (Hildreth 1957; Luenberger & Ye, *Linear and Nonlinear Programming*, §14.7): dual
coordinate ascent on the multipliers μ ≥ 0 of x = H⁻¹(c + Aᵀ μ). Each sweep updates one multiplier at a
time in closed form; it converges to the QP optimum when the rows are feasible, and when they are not
it stays bounded after ``max_sweeps`` (callers then get the best compromise, never NaN).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def cholesky_inplace(h: np.ndarray, n: int) -> None:
    """Lower Cholesky factor of the leading n×n block of ``h`` written into its lower triangle."""
    for j in range(n):
        s = h[j, j]
        for k in range(j):
            s -= h[j, k] * h[j, k]
        h[j, j] = math.sqrt(max(s, 1e-300))
        for i in range(j + 1, n):
            s = h[i, j]
            for k in range(j):
                s -= h[i, k] * h[j, k]
            h[i, j] = s / h[j, j]


@njit(cache=True)
def cholesky_solve(factor: np.ndarray, rhs: np.ndarray, out: np.ndarray, n: int) -> None:
    """Solve L Lᵀ x = rhs with the factor of :func:`cholesky_inplace`; x into ``out``."""
    for i in range(n):
        s = rhs[i]
        for k in range(i):
            s -= factor[i, k] * out[k]
        out[i] = s / factor[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, n):
            s -= factor[k, i] * out[k]
        out[i] = s / factor[i, i]


@njit(cache=True)
def hildreth(factor: np.ndarray, x: np.ndarray, rows: np.ndarray, b: np.ndarray, m: int, n: int, hinv_rows: np.ndarray,
             mu: np.ndarray, curvature: np.ndarray, max_sweeps: int, tolerance: float) -> float:
    """Enforce ``rows[:m] @ x ≥ b[:m]`` on the unconstrained optimum ``x`` (updated in place).

    ``factor`` is the Cholesky factor of H; ``hinv_rows`` (m, n), ``mu`` and ``curvature`` (m,) are
    workspace. H⁻¹aₖ is computed only for rows that become active (most damper rows never do). Returns the
    largest remaining violation (m/s or rad/s).
    """
    for k in range(m):
        mu[k] = 0.0
        curvature[k] = -1.0
    worst = 0.0
    for _ in range(max_sweeps):
        worst = 0.0
        for k in range(m):
            slack = b[k]
            for j in range(n):
                slack -= rows[k, j] * x[j]
            if slack <= 0.0 and mu[k] == 0.0:
                continue  # satisfied and inactive
            g = hinv_rows[k]
            if curvature[k] < 0.0:
                cholesky_solve(factor, rows[k], g, n)
                c = 0.0
                for j in range(n):
                    c += rows[k, j] * g[j]
                curvature[k] = c
            if curvature[k] <= 1e-14:
                continue
            new = max(0.0, mu[k] + slack / curvature[k])
            step = new - mu[k]
            if step != 0.0:
                for j in range(n):
                    x[j] += step * g[j]
                mu[k] = new
            worst = max(worst, slack)
        if worst <= tolerance:
            break
    return worst
