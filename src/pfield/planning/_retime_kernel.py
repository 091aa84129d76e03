"""Compiled local time stretching of a sampled joint path (numba, ``cache=True``); see :mod:`.retime`.

Intervals h_k separate the samples q_k. At sample k the velocity and acceleration are the derivatives of
the parabola through samples k−1, k, k+1 (:func:`differences`); the ends are at rest. Each round lengthens
every interval next to a sample that breaks a limit by that sample's violation ratio
r = max_j(|q̇_j|/v_j, √(|q̈_j|/a_j)): velocities scale with 1/r and accelerations with 1/r² under a
uniform stretch, so an isolated violation is removed in one round and its neighbours settle in the next
ones. No interval is ever shortened, so the rounds converge.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def differences(q, h, v, a):  # type: ignore[no-untyped-def]
    """Velocities and accelerations of the samples ``q`` (N, n) with interval lengths ``h`` (N−1,): the
    derivatives at t_k of the parabola through samples k−1, k, k+1 (exact for quadratic motion on a
    non-uniform grid); zero velocity at both ends, where the parabola starts or ends at rest."""
    count, n = q.shape
    for j in range(n):
        v[0, j], v[count - 1, j] = 0.0, 0.0
        a[0, j] = 2.0 * (q[1, j] - q[0, j]) / (h[0] * h[0])
        a[count - 1, j] = 2.0 * (q[count - 2, j] - q[count - 1, j]) / (h[count - 2] * h[count - 2])
    for k in range(1, count - 1):
        h0, h1 = h[k - 1], h[k]
        for j in range(n):
            d0, d1 = (q[k, j] - q[k - 1, j]) / h0, (q[k + 1, j] - q[k, j]) / h1
            v[k, j] = (h1 * d0 + h0 * d1) / (h0 + h1)
            a[k, j] = 2.0 * (d1 - d0) / (h0 + h1)


@njit(cache=True)
def _ratios(v, a, v_max, a_max, ratio):  # type: ignore[no-untyped-def]
    """ratio[k] = max over joints of |v|/v_max and √(|a|/a_max) at sample k; returns the largest."""
    worst = 0.0
    for k in range(v.shape[0]):
        r = 0.0
        for j in range(v.shape[1]):
            r = max(r, abs(v[k, j]) / v_max[j], math.sqrt(abs(a[k, j]) / a_max[j]))
        ratio[k] = r
        worst = max(worst, r)
    return worst


@njit(cache=True)
def stretch_intervals(q, h0, v_max, a_max, rounds):  # type: ignore[no-untyped-def]
    """Durations h ≥ ``h0`` of the intervals between the samples ``q`` under which the samples keep the
    limits: each round lengthens every interval next to an offending sample by the larger violation ratio
    r = max(|q̇|/v, √(|q̈|/a)) of its two ends (q̇ scales with 1/r, q̈ with 1/r²); ratios within 10⁻⁹ of 1
    are left to the caller's final uniform stretch. Returns (h, velocities, accelerations)."""
    count, n = q.shape
    h = h0.copy()
    v, a, ratio = np.zeros((count, n)), np.zeros((count, n)), np.empty(count)
    for _ in range(rounds):
        differences(q, h, v, a)
        if _ratios(v, a, v_max, a_max, ratio) <= 1.0 + 1e-9:
            break
        for k in range(count - 1):
            factor = max(ratio[k], ratio[k + 1])
            if factor > 1.0 + 1e-9:
                h[k] *= factor
    differences(q, h, v, a)
    return h, v, a


@njit(cache=True)
def knot_indices(arc, spacing):  # type: ignore[no-untyped-def]
    """Indices of the waypoints that carry the timing: the first, each next one at least ``spacing`` of
    joint-space arc length ``arc`` (N,) after the previous one, and the last (distinct positions only).

    Dense planner output turns by fractions of a milliradian from step to step; through every step those
    turns would be accelerations that force a crawl."""
    keep = np.empty(arc.shape[0], dtype=np.int64)
    keep[0], count, last = 0, 1, 0.0
    for k in range(1, arc.shape[0]):
        if arc[k] - last >= spacing:
            keep[count], count, last = k, count + 1, arc[k]
    if arc[-1] > arc[keep[count - 1]]:
        keep[count], count = arc.shape[0] - 1, count + 1
    return keep[:count].copy()


@njit(cache=True)
def strictly_increasing(times):  # type: ignore[no-untyped-def]
    """``times`` (N,) with each repeat (a waypoint that did not move) nudged one representable step later."""
    out = times.copy()
    for k in range(1, out.shape[0]):
        if out[k] <= out[k - 1]:
            out[k] = np.nextafter(out[k - 1], np.inf)
    return out
