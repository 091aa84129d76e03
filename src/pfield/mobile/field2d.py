"""The seed's 2D potential, its exact gradient and the clamped command (functional API over the compiled core).

Seed document 004:

    V(p) = V_a(p) + Σ_i w_i · (kr_height / kr_slope) · exp(kr_slope · (kr_dist − ‖p − p_ri‖))

    power law (seed, default):  V_a = ‖p − p_a‖^ka,        −∇V_a = ka · ‖p − p_a‖^(ka−2) · (p_a − p)
    linear law (original node): V_a = (ka/2)·‖p − p_a‖²,   −∇V_a = ka · (p_a − p)
    repulsion:                 −∇V_r = Σ_i w_i · kr_height · exp(kr_slope·(kr_dist − r_i)) · (p − p_ri) / r_i

with r_i = ‖p − p_ri‖ and per-point weights w_i (1 for point lists; the scan weighting of
:mod:`pfield.mobile.scan` otherwise). The seed prints the attractive gradient with exponent ka−1 on ‖p − p_a‖
times the unnormalised (p − p_a); the exact gradient above has ka−2 (its norm is ka·‖p − p_a‖^(ka−1)).
Where a direction is undefined (p on the goal, p on an obstacle point) that term is zero, so no NaN arises.
All points are 2D in one fixed frame (m); no goal (``None``) means no attraction. The loops run in the compiled
core (``src/core/mobile/field2d.cpp``, :mod:`pfield._core`), on the arrays validated here.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import mobile as _mobile
from pfield._validation import as_points, as_vector
from pfield.errors import InvalidInput
from pfield.mobile.clamping import clamped_sum_batch
from pfield.mobile.params import VectorFieldParams

__all__ = ["FieldComponents", "components_at", "field_components", "gradient", "potential", "velocity",
           "velocity_at"]

components_at = _mobile.components_at
"""``components_at(px, py, goal, has_goal, obstacles_x, obstacles_y, weights, params.core_field)`` → the core's
``Components`` at one point (validated inputs): ``potential`` V, ``attraction`` and ``repulsion`` the (x, y) of the
raw attractive and repulsive parts of −∇V."""
velocity_at = _mobile.velocity_at
"""``velocity_at(px, py, goal, has_goal, obstacles_x, obstacles_y, weights, params.core_field, params.core_limits)``
→ (v_x, v_y): the clamped command at one point, what the controller runs every tick (validated inputs)."""


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
    return FieldComponents(*_mobile.components_batch(query, goal_xy, has_goal, *_columns(obs), w, params.core_field))


def potential(points: ArrayLike, goal: ArrayLike | None, obstacles: ArrayLike | None,
              params: VectorFieldParams, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """V at ``points`` (N, 2) → (N,), see the module docstring for the equation."""
    query = as_points("points", points, dim=2)
    goal_xy, has_goal = _goal_array(goal)
    obs, w = obstacle_arrays(obstacles, weights)
    potentials: NDArray[np.float64] = _mobile.potential_batch(query, goal_xy, has_goal, *_columns(obs), w,
                                                              params.core_field)
    return potentials


def gradient(points: ArrayLike, goal: ArrayLike | None, obstacles: ArrayLike | None,
             params: VectorFieldParams, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """∇V at ``points`` (N, 2) → (N, 2), unclamped (the robot follows the negative of this)."""
    parts = field_components(points, goal, obstacles, params, weights)
    return -(parts.attraction + parts.repulsion)


def velocity(points: ArrayLike, goal: ArrayLike | None, obstacles: ArrayLike | None,
             params: VectorFieldParams, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """The clamped command (m/s) at ``points`` (N, 2) → (N, 2): :mod:`pfield.mobile.clamping` applied to −∇V."""
    parts = field_components(points, goal, obstacles, params, weights)
    commands: NDArray[np.float64] = clamped_sum_batch(parts.attraction, parts.repulsion, params.core_limits)
    return commands


def _columns(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The (M, 2) obstacle points as two contiguous columns (the core's structure of arrays)."""
    return np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1])
