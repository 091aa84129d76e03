"""The whole-body field's compiled core (``src/core/planning/whole_body``) from Python.

A :class:`~pfield.planning._whole_body_layout.RobotArrays` and a :class:`~pfield.planning._whole_body_layout.Scene`
are bound once into ``pfield._core.whole_body`` objects (their arrays read in place, no copies), with the goal and
the parameter vector into a ``Planner``, whose plan and steps then take q only. :func:`plan_loop` returns what the
numba loop it replaces returned, so the planner and its global fallback read it unchanged. Nothing here imports
numba: the first whole-body plan in a new process compiles nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pfield._core import robot_distance as _distance
from pfield._core import whole_body as _core
from pfield.planning.status import PlanStatus

if TYPE_CHECKING:
    from pfield.planning._whole_body_layout import RobotArrays, Scene

__all__ = ["culprit", "pair_distances", "plan_loop", "planner"]


def planner(robot: RobotArrays, scene: Scene, goal_p: NDArray[np.float64], goal_q: NDArray[np.float64],
            params: NDArray[np.float64]) -> Any:
    """The core's ``Planner``: ``robot`` and ``scene`` bound (read in place for its life), the goal position (3,),
    orientation (4,) (x, y, z, w) and the parameter vector (``_whole_body_layout.PARAMS``) copied."""
    bound = _core.Robot(*robot)
    where = _core.Scene(bound, *scene.packed, scene.centres, scene.bounds, scene.obstacle_offsets,
                        scene.self_offsets)
    return _core.Planner(bound, where, goal_p, goal_q, params)


def culprit(last: Any) -> NDArray[np.float64]:
    """The loop's ``culprit`` (5,) of a step result: the capsule and obstacle of its closest link–obstacle pair,
    that pair's distance (m, less its start offset), the closest self pair and its distance (−1: none)."""
    return np.array((last.nearest_capsule, last.nearest_obstacle, last.nearest_distance, last.nearest_self_pair,
                     last.self_clearance))


def plan_loop(q0: NDArray[np.float64], robot: RobotArrays, scene: Scene, goal_p: NDArray[np.float64],
              goal_q: NDArray[np.float64], params: NDArray[np.float64], max_iterations: int,
              cancel: NDArray[np.uint8]) -> tuple[Any, ...]:
    """Integrate q ← clip(q + q̇ dt) from ``q0`` until the goal, a collision, stagnation, the iteration limit or
    ``cancel[0] != 0`` (a :class:`~pfield.planning.CancelToken`'s flag, read every step; the GIL is released).

    Returns ``(status, count, q, qdot, positions, quaternions, twists, clearances, culprit)`` with ``count``
    recorded waypoints (the start included) and ``status`` a :class:`PlanStatus`. Waypoint k holds the
    configuration q_k, the velocity applied from it (zero at the last waypoint of a successful plan) and the
    end-effector twist J(q_k) q̇_k; ``culprit`` (:func:`culprit`) describes the last step evaluated.
    """
    n, total = len(q0), max_iterations + 1
    qs, qds = np.empty((total, n)), np.empty((total, n))
    positions, quats, twists, clear = np.empty((total, 3)), np.empty((total, 4)), np.empty((total, 6)), np.empty(total)
    result = planner(robot, scene, goal_p, goal_q, params).plan(
        np.ascontiguousarray(q0, dtype=np.float64), max_iterations, cancel, qs, qds, positions, quats, twists, clear)
    count = result.count
    return PlanStatus(result.status), count, qs[:count], qds[:count], positions[:count], quats[:count], \
        twists[:count], clear[:count], culprit(result.last)


def pair_distances(q: NDArray[np.float64], robot: RobotArrays, scene: Scene) -> tuple[NDArray[np.float64],
                                                                                       NDArray[np.float64]]:
    """Clearances (m) of the fitted model at ``q``: link × obstacle (L, M) and self pairs (P,), by the compiled
    core (``src/core/robot/clearance``; the same bits as the numba kernels' two-level distances)."""
    model = _distance.LinkModel(robot.cap_joint, robot.cap_a, robot.cap_b, robot.cap_r, robot.self_r,
                                robot.self_pairs, robot.link_start, robot.prim_joint, robot.prim_a, robot.prim_b,
                                robot.prim_r)
    clearances = model.clearances_at(q, robot.parents, robot.place_rot, robot.place_pos, robot.axes, robot.kinds,
                                     _distance.Obstacles(*scene.packed, scene.centres, scene.bounds))
    return clearances.obstacle, clearances.own
