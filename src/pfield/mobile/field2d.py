"""The seed's 2D potential, its exact gradient and the clamped command (compiled kernels + functional API).

Seed document 004:

    V(p) = V_a(p) + Σ_i w_i · (kr_height / kr_slope) · exp(kr_slope · (kr_dist − ‖p − p_ri‖))

    power law (seed, default):  V_a = ‖p − p_a‖^ka,        −∇V_a = ka · ‖p − p_a‖^(ka−2) · (p_a − p)
    linear law (original node): V_a = (ka/2)·‖p − p_a‖²,   −∇V_a = ka · (p_a − p)
    repulsion:                 −∇V_r = Σ_i w_i · kr_height · exp(kr_slope·(kr_dist − r_i)) · (p − p_ri) / r_i

with r_i = ‖p − p_ri‖ and per-point weights w_i (1 for point lists; the scan weighting of
:mod:`pfield.mobile.scan` otherwise). The seed prints the attractive gradient with exponent ka−1 on ‖p − p_a‖
times the unnormalised (p − p_a); the exact gradient above has ka−2 (its norm is ka·‖p − p_a‖^(ka−1)).
Where a direction is undefined (p on the goal, p on an obstacle point) that term is zero, so no NaN arises.
All points are 2D in one fixed frame (m); no goal (``None``) means no attraction.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from pfield._validation import as_points, as_vector
from pfield.errors import InvalidInput
from pfield.mobile._fastexp import fast_exp
from pfield.mobile.clamping import clamped_sum, clamped_sum_batch
from pfield.mobile.params import VectorFieldParams

__all__ = ["FieldComponents", "field_components", "gradient", "potential", "velocity"]

POWER, LINEAR = 0, 1
_MAX_MAGNITUDE = 1e300  # cap of the power law's ka·d^(ka−1) for ka < 1 at d → 0 (clamped away anyway)
# Reassociation lets LLVM vectorise the obstacle sums; 'nnan'/'ninf' (2× faster again) are safe because
# the object layer only passes finite coordinates and weights, fast_exp clips its argument and 1/r is
# guarded, so no intermediate is NaN or inf. Kernel callers must keep that precondition.
_FASTMATH = {"reassoc", "contract", "arcp", "nsz", "nnan", "ninf"}


@njit(cache=True, inline="always")
def attraction_at(px: float, py: float, gx: float, gy: float, ka: float, law: int) -> tuple[float, float]:
    """−∇V_a at (px, py) for the goal (gx, gy); zero at the goal itself."""
    dx = gx - px
    dy = gy - py
    if law == LINEAR:
        return ka * dx, ka * dy
    distance = math.hypot(dx, dy)  # hypot: no underflow to 0 next to the goal
    if distance == 0.0 or ka == 0.0:
        return 0.0, 0.0
    # magnitude ka·d^(ka−1), capped so that ka < 1 right next to the goal stays finite
    magnitude = min(ka * distance ** (ka - 1.0), _MAX_MAGNITUDE)
    return magnitude * (dx / distance), magnitude * (dy / distance)


@njit(cache=True, inline="always")
def attraction_potential(px: float, py: float, gx: float, gy: float, ka: float, law: int) -> float:
    """V_a at (px, py): ‖d‖^ka (power; 0^0 = 1) or (ka/2)‖d‖² (linear)."""
    d2 = (gx - px) ** 2 + (gy - py) ** 2
    if law == LINEAR:
        return 0.5 * ka * d2
    return d2 ** (0.5 * ka)


@njit(cache=True, fastmath=_FASTMATH)
def repulsion_at(px: float, py: float, obstacles_x: NDArray[np.float64], obstacles_y: NDArray[np.float64],
                 weights: NDArray[np.float64], kr_dist: float, kr_height: float,
                 kr_slope: float) -> tuple[float, float, float]:
    """(V_r, −∂V_r/∂x, −∂V_r/∂y) at (px, py) summed over the weighted obstacle points.

    Coordinates come as two contiguous columns (structure of arrays) so that LLVM vectorises the loop.
    """
    value = 0.0
    fx = 0.0
    fy = 0.0
    for j in range(obstacles_x.shape[0]):
        dx = px - obstacles_x[j]
        dy = py - obstacles_y[j]
        r = math.sqrt(dx * dx + dy * dy)
        hill = weights[j] * fast_exp(kr_slope * (kr_dist - r))
        value += hill
        inv_r = 1.0 / max(r, 1e-300)
        inv_r = inv_r if r > 0.0 else 0.0
        fx += hill * dx * inv_r
        fy += hill * dy * inv_r
    return value * (kr_height / kr_slope), fx * kr_height, fy * kr_height


@njit(cache=True)
def components_at(px: float, py: float, goal: NDArray[np.float64], has_goal: bool,
                  obstacles_x: NDArray[np.float64], obstacles_y: NDArray[np.float64],
                  weights: NDArray[np.float64], ka: float, law: int,
                  kr_dist: float, kr_height: float, kr_slope: float) -> tuple[float, float, float, float, float]:
    """(V, a_x, a_y, r_x, r_y): the potential and the raw attractive and repulsive parts of −∇V."""
    value, rx, ry = repulsion_at(px, py, obstacles_x, obstacles_y, weights, kr_dist, kr_height, kr_slope)
    ax = 0.0
    ay = 0.0
    if has_goal:
        ax, ay = attraction_at(px, py, goal[0], goal[1], ka, law)
        value += attraction_potential(px, py, goal[0], goal[1], ka, law)
    return value, ax, ay, rx, ry


@njit(cache=True)
def velocity_at(px: float, py: float, goal: NDArray[np.float64], has_goal: bool,
                obstacles_x: NDArray[np.float64], obstacles_y: NDArray[np.float64],
                weights: NDArray[np.float64], ka: float, law: int,
                kr_dist: float, kr_height: float, kr_slope: float, min_spd: float, max_spd: float,
                mode: int) -> tuple[float, float]:
    """The clamped command at one point (what the controller runs every tick)."""
    _, ax, ay, rx, ry = components_at(px, py, goal, has_goal, obstacles_x, obstacles_y, weights, ka, law,
                                      kr_dist, kr_height, kr_slope)
    return clamped_sum(ax, ay, rx, ry, min_spd, max_spd, mode)


@njit(cache=True)
def components_batch(points: NDArray[np.float64], goal: NDArray[np.float64], has_goal: bool,
                     obstacles: NDArray[np.float64], weights: NDArray[np.float64], ka: float, law: int,
                     kr_dist: float, kr_height: float,
                     kr_slope: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`components_at` over (N, 2) points: V (N,), attraction (N, 2), repulsion (N, 2)."""
    n = points.shape[0]
    obstacles_x = np.ascontiguousarray(obstacles[:, 0])
    obstacles_y = np.ascontiguousarray(obstacles[:, 1])
    value = np.empty(n)
    attraction = np.empty((n, 2))
    repulsion = np.empty((n, 2))
    for i in range(n):
        value[i], attraction[i, 0], attraction[i, 1], repulsion[i, 0], repulsion[i, 1] = components_at(
            points[i, 0], points[i, 1], goal, has_goal, obstacles_x, obstacles_y, weights, ka, law, kr_dist,
            kr_height, kr_slope)
    return value, attraction, repulsion


@njit(cache=True, fastmath=_FASTMATH)
def potential_batch(points: NDArray[np.float64], goal: NDArray[np.float64], has_goal: bool,
                    obstacles: NDArray[np.float64], weights: NDArray[np.float64], ka: float, law: int,
                    kr_dist: float, kr_height: float, kr_slope: float) -> NDArray[np.float64]:
    """V only at (N, 2) points (images): one exponential per point and obstacle, nothing else."""
    obstacles_x = np.ascontiguousarray(obstacles[:, 0])
    obstacles_y = np.ascontiguousarray(obstacles[:, 1])
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        px = points[i, 0]
        py = points[i, 1]
        hills = 0.0
        for j in range(obstacles_x.shape[0]):
            dx = px - obstacles_x[j]
            dy = py - obstacles_y[j]
            hills += weights[j] * fast_exp(kr_slope * (kr_dist - math.sqrt(dx * dx + dy * dy)))
        out[i] = hills * (kr_height / kr_slope)
        if has_goal:
            out[i] += attraction_potential(px, py, goal[0], goal[1], ka, law)
    return out


class FieldComponents(NamedTuple):
    """Unclamped field at N points: ``potential`` V (N,), ``attraction`` −∇V_a and ``repulsion`` −∇V_r (N, 2)."""

    potential: NDArray[np.float64]
    attraction: NDArray[np.float64]
    repulsion: NDArray[np.float64]


def _goal_array(goal: ArrayLike | None) -> tuple[NDArray[np.float64], bool]:
    if goal is None:
        return np.zeros(2), False
    return np.array(as_vector("goal", goal, 2)), True


def obstacle_arrays(obstacles: ArrayLike | None,
                    weights: ArrayLike | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validate obstacle points (M, 2) and their weights (M,) (default 1) for the kernels."""
    if obstacles is None or np.size(obstacles) == 0:
        points = np.empty((0, 2))
    else:
        points = as_points("obstacles", obstacles, dim=2)
    if weights is None:
        return points, np.ones(points.shape[0])
    try:
        w = np.ascontiguousarray(weights, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InvalidInput("weights", weights, "expected one number per obstacle point") from exc
    if w.shape != (points.shape[0],):
        raise InvalidInput("weights", f"array{w.shape}", f"expected shape ({points.shape[0]},)")
    if not np.all(np.isfinite(w)) or np.any(w < 0.0):
        raise InvalidInput("weights", "array", "must be finite and >= 0")
    return points, w


def field_components(points: ArrayLike, goal: ArrayLike | None, obstacles: ArrayLike | None,
                     params: VectorFieldParams, weights: ArrayLike | None = None) -> FieldComponents:
    """V and the two raw parts of −∇V at ``points`` (N, 2) for ``goal`` (2,) or None and ``obstacles`` (M, 2)."""
    query = as_points("points", points, dim=2)
    goal_xy, has_goal = _goal_array(goal)
    obs, w = obstacle_arrays(obstacles, weights)
    return FieldComponents(*components_batch(query, goal_xy, has_goal, obs, w, *_shape_args(params)))


def potential(points: ArrayLike, goal: ArrayLike | None, obstacles: ArrayLike | None,
              params: VectorFieldParams, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """V at ``points`` (N, 2) → (N,), see the module docstring for the equation."""
    query = as_points("points", points, dim=2)
    goal_xy, has_goal = _goal_array(goal)
    obs, w = obstacle_arrays(obstacles, weights)
    return potential_batch(query, goal_xy, has_goal, obs, w, *_shape_args(params))


def gradient(points: ArrayLike, goal: ArrayLike | None, obstacles: ArrayLike | None,
             params: VectorFieldParams, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """∇V at ``points`` (N, 2) → (N, 2), unclamped (the robot follows the negative of this)."""
    parts = field_components(points, goal, obstacles, params, weights)
    return -(parts.attraction + parts.repulsion)


def velocity(points: ArrayLike, goal: ArrayLike | None, obstacles: ArrayLike | None,
             params: VectorFieldParams, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """The clamped command (m/s) at ``points`` (N, 2) → (N, 2): :mod:`pfield.mobile.clamping` applied to −∇V."""
    parts = field_components(points, goal, obstacles, params, weights)
    return clamped_sum_batch(parts.attraction, parts.repulsion, params.min_spd_norm, params.max_spd_norm,
                             params.clamping_code)


def _shape_args(params: VectorFieldParams) -> tuple[Any, ...]:
    return (params.ka, params.attraction_code, params.kr_dist, params.kr_height, params.kr_slope)
