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

Coordinate ascent is slow when active rows are nearly parallel (two links pressing on one table: on
MotionBenchMaker's table_under_pick, 363 of 401 steps used all 200 sweeps and still left 7e-5 m/s of
violation). So after sweeps 1, 2, 4, 8, … the rows with μ > 0 are taken as the active set and the
equality-constrained QP on them is solved exactly (:func:`_polish`, the Schur complement A H⁻¹ Aᵀ): when
its multipliers are all ≥ 0 and every row holds, that is the QP's optimum (the KKT conditions hold) and the
sweeps stop. Otherwise nothing changes and the sweeps go on.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def cholesky_inplace(h: np.ndarray, n: int) -> float:
    """Lower Cholesky factor of the leading n×n block of ``h`` written into its lower triangle (read from it).

    Returns the smallest squared pivot relative to its diagonal entry of ``h`` (1 for a diagonal matrix, near
    0 for nearly dependent rows, ≤ 0 when the block is not positive definite); a pivot ≤ 0 is clamped to
    1e-300 so that the factor stays finite, and callers that may meet such blocks test the returned value."""
    smallest = 1.0
    for j in range(n):
        diagonal = h[j, j]
        s = diagonal
        for k in range(j):
            s -= h[j, k] * h[j, k]
        smallest = min(smallest, s / diagonal if diagonal > 0.0 else 0.0)
        h[j, j] = math.sqrt(max(s, 1e-300))
        for i in range(j + 1, n):
            s = h[i, j]
            for k in range(j):
                s -= h[i, k] * h[j, k]
            h[i, j] = s / h[j, j]
    return smallest


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
    polish_at = 1
    for sweep in range(1, max_sweeps + 1):
        worst = 0.0
        for k in range(m):
            slack = b[k]
            for j in range(n):
                slack -= rows[k, j] * x[j]
            if slack <= 0.0 and mu[k] == 0.0:
                continue  # satisfied and inactive
            g = hinv_rows[k]
            if curvature[k] < 0.0:
                curvature[k] = _row_curvature(factor, rows, k, hinv_rows, n)
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
        if sweep == polish_at:
            polish_at *= 2
            if _polish(factor, x, rows, b, m, n, hinv_rows, mu, curvature, tolerance):
                return 0.0
    return worst


@njit(cache=True)
def _row_curvature(factor: np.ndarray, rows: np.ndarray, k: int, hinv_rows: np.ndarray, n: int) -> float:
    """H⁻¹aₖ into ``hinv_rows[k]``, and aₖᵀ H⁻¹ aₖ: the curvature of the dual along row k's multiplier."""
    cholesky_solve(factor, rows[k], hinv_rows[k], n)
    c = 0.0
    for j in range(n):
        c += rows[k, j] * hinv_rows[k, j]
    return c


@njit(cache=True)
def _polish(factor: np.ndarray, x: np.ndarray, rows: np.ndarray, b: np.ndarray, m: int, n: int,
            hinv_rows: np.ndarray, mu: np.ndarray, curvature: np.ndarray, tolerance: float) -> bool:
    """Finish the QP by active-set steps from the sweeps' guess (the rows with μ > 0; see the module
    docstring); when the optimum is found, write it into ``x`` and ``mu`` and return True, else change nothing.

    With x_u = x − Σ μ_k H⁻¹a_k the unconstrained optimum, the active rows' multipliers λ solve
    (A H⁻¹ Aᵀ) λ = b_A − A x_u and x = x_u + H⁻¹Aᵀ λ. A negative λ drops its row, else the most violated
    row joins, until the KKT conditions hold (λ ≥ 0, every row within ``tolerance``) or after 2n changes.
    More than n active rows, or a Schur complement singular to working precision (linearly dependent rows),
    are left to the sweeps."""
    free = x.copy()
    guessed = 0
    for k in range(m):
        if mu[k] > 0.0:
            guessed += 1
            for j in range(n):
                free[j] -= mu[k] * hinv_rows[k, j]
    if guessed > n:
        return False
    active = np.empty(n, dtype=np.int64)
    count = 0 * m  # a run-time zero: with the literal, _active_solve would compile for Literal[int](0) too
    for k in range(m):
        if mu[k] > 0.0:
            active[count] = k
            count += 1
    schur, target, lam, solution = np.empty((n, n)), np.empty(n), np.empty(n), np.empty(n)
    for _ in range(2 * n + 1):
        if not _active_solve(rows, b, n, hinv_rows, free, active, count, schur, target, lam):
            return False
        drop, lowest = -1, 0.0
        for i in range(count):
            if lam[i] < lowest:
                drop, lowest = i, lam[i]
        if drop >= 0:
            active[drop] = active[count - 1]
            count -= 1
            continue
        solution[:] = free
        for i in range(count):
            for j in range(n):
                solution[j] += lam[i] * hinv_rows[active[i], j]
        join, violation = 0 * m - 1, tolerance  # a run-time -1: else _row_curvature compiles for Literal[int](-1)
        for k in range(m):
            slack = b[k]
            for j in range(n):
                slack -= rows[k, j] * solution[j]
            if slack > violation:
                join, violation = k, slack
        if join < 0:
            x[:n] = solution
            mu[:m] = 0.0
            for i in range(count):
                mu[active[i]] = lam[i]
            return True
        if count == n:
            return False
        if curvature[join] < 0.0:  # H⁻¹a of a row the sweeps never activated
            curvature[join] = _row_curvature(factor, rows, join, hinv_rows, n)
        active[count] = join
        count += 1
    return False


@njit(cache=True)
def _active_solve(rows: np.ndarray, b: np.ndarray, n: int, hinv_rows: np.ndarray, free: np.ndarray,
                  active: np.ndarray, count: int, schur: np.ndarray, target: np.ndarray, lam: np.ndarray) -> bool:
    """λ of (A H⁻¹ Aᵀ) λ = b_A − A x_u for the ``count`` rows of ``active`` into ``lam``; False when the
    Schur complement's Cholesky meets a pivot below 1e-10 of its diagonal (dependent rows)."""
    for i in range(count):
        ki = active[i]
        s = b[ki]
        for j in range(n):
            s -= rows[ki, j] * free[j]
        target[i] = s
        for l in range(i + 1):
            kl = active[l]
            s = 0.0
            for j in range(n):
                s += rows[ki, j] * hinv_rows[kl, j]
            schur[i, l] = s  # the lower triangle: what the factorisation reads
    if cholesky_inplace(schur, count) <= 1e-10:
        return False
    cholesky_solve(schur, target, lam, count)
    return True
