"""The whole-body field's compiled core (``src/core/planning/whole_body``) from Python.

A :class:`~pfield.planning._whole_body_layout.RobotArrays`, the obstacles of a
:class:`~pfield.planning._whole_body_layout.Scene` and the scene itself are bound into ``pfield._core.robot``
objects (``Robot``, ``Obstacles``, ``Scene``: their arrays read in place, no copies) once each, by
:func:`core_robot`, :func:`core_obstacles` and :func:`core_scene`, and every consumer takes those: the plan and its
steps (a ``Planner``: the scene with the goal and the parameter vector, then q only), the stepper, the clearances
(:func:`pair_distances`), the global search's checker, tracking and overlap test, the assistance.
:func:`plan_loop` returns the tuple the numba plan loop it replaced (issue 32) returned, so the planner and its
global fallback read it unchanged.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from pfield._core import robot as _robot_core
from pfield._core import robot_distance as _distance
from pfield._core import whole_body as _core
from pfield.planning.status import PlanStatus
from pfield.robot.collision import motion_bounds, self_pair_weights

if TYPE_CHECKING:
    from pfield.planning._whole_body_layout import RobotArrays, Scene
    from pfield.robot.model import RobotModel

__all__ = ["core_obstacles", "core_robot", "core_scene", "culprit", "pair_distances", "pair_tables", "pair_weights",
           "plan_loop", "planner"]

_T = TypeVar("_T")


class _Bindings:
    """Core objects by the identity of the Python values they were bound from, so that each value is bound once
    and every consumer gets that one object. The last ``size`` are kept, with their values (so an identity is not
    reused while its entry lives); the arrays are read in place, so a value and its binding always agree."""

    def __init__(self, size: int) -> None:
        self._size = size
        self._entries: OrderedDict[tuple[int, ...], tuple[tuple[object, ...], Any]] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, values: tuple[object, ...], bind: Callable[[], _T]) -> _T:
        key = tuple(id(value) for value in values)
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None:
                self._entries.move_to_end(key)
                bound: _T = entry[1]
                return bound
        made = bind()  # outside the lock: binding checks every array
        with self._lock:
            self._entries[key] = (values, made)
            while len(self._entries) > self._size:
                self._entries.popitem(last=False)
        return made


# a plan binds one robot and one obstacle set, and a few scenes (the start's offsets, the search's endpoint
# offsets, the tracking's zero offsets); a few concurrent plans fit
_ROBOTS, _OBSTACLES, _SCENES = _Bindings(8), _Bindings(8), _Bindings(16)
_PAIR_TABLES = _Bindings(8)  # per robot and link model: the searches of one robot share their cells


def core_robot(robot: RobotArrays) -> Any:
    """The core's ``robot.Robot`` of ``robot`` (its arrays read in place), bound once per RobotArrays."""
    return _ROBOTS.get((robot,), lambda: _robot_core.Robot(*robot))


def pair_tables(robot: RobotModel, arrays: RobotArrays) -> Any:
    """The core's ``robot.PairTables`` of ``robot``'s fitted self pairs (``src/core/robot/pair_tables.hpp``): one per
    robot (and link model), made from ``arrays`` (``robot`` packed, :func:`pfield.planning.whole_body.pack_robot`) the
    first time, so that every search of the robot fills and reads the same cells; weights :func:`pair_weights`."""
    return _PAIR_TABLES.get((robot, robot.geometry), lambda: _robot_core.PairTables(
        _robot_core.Robot(*arrays._replace(pair_tables=None)), pair_weights(robot, arrays)))


def pair_weights(robot: RobotModel, arrays: RobotArrays) -> NDArray[np.float64]:
    """(pairs, n) how fast each self pair's fitted distance can change with each joint (m/rad or m/m):
    :func:`pfield.robot.collision.self_pair_weights` of the two links' primitives (their segments' ends, in the
    frame of the link's joint; a link without primitives has a point at its joint's origin, and no table)."""
    ends = [np.vstack([arrays.prim_a[s:e], arrays.prim_b[s:e]]) if e > s else np.zeros((1, 3))
            for s, e in zip(arrays.link_start[:-1].tolist(), arrays.link_start[1:].tolist(), strict=True)]
    bounds, supports, cross = motion_bounds(robot, arrays.cap_joint, ends)
    pairs = np.asarray(arrays.self_pairs, dtype=np.int64).reshape(-1, 2)
    return np.ascontiguousarray(self_pair_weights(bounds, supports, cross, pairs[:, 0], pairs[:, 1]),
                                dtype=np.float64)


def core_obstacles(scene: Scene) -> Any:
    """The core's ``robot.Obstacles`` of ``scene``'s packed obstacles and bounding spheres, bound once per set
    (scenes that differ in their offsets alone share it)."""
    return _OBSTACLES.get((scene.packed, scene.centres, scene.bounds),
                          lambda: _robot_core.Obstacles(*scene.packed, scene.centres, scene.bounds))


def core_scene(robot: RobotArrays, scene: Scene) -> Any:
    """The core's ``robot.Scene``: ``robot`` among ``scene``'s obstacles with its offsets, bound once per pair."""
    return _SCENES.get((robot, scene), lambda: _robot_core.Scene(core_robot(robot), core_obstacles(scene),
                                                                 scene.obstacle_offsets, scene.self_offsets,
                                                                 scene.fitted_self))


def planner(robot: RobotArrays, scene: Scene, goal_p: NDArray[np.float64], goal_q: NDArray[np.float64],
            params: NDArray[np.float64], goal_joints: NDArray[np.float64] | None = None,
            joint_gain: float = 0.0) -> Any:
    """The core's ``Planner``: ``robot`` in ``scene`` (:func:`core_scene`), the goal position (3,), orientation (4,)
    (x, y, z, w) and the parameter vector (``_whole_body_layout.PARAMS``) copied; ``goal_joints`` (n,): a joint
    goal the steps are drawn toward at ``joint_gain`` (1/s, :attr:`WholeBodyOptions.posture_gain`), copied."""
    return _core.Planner(core_scene(robot, scene), goal_p, goal_q, params, goal_joints, joint_gain)


def culprit(last: Any) -> NDArray[np.float64]:
    """The loop's ``culprit`` (5,) of a step result: the capsule and obstacle of its closest link–obstacle pair,
    that pair's distance (m, less its start offset), the closest self pair and its distance (−1: none)."""
    return np.array((last.nearest_capsule, last.nearest_obstacle, last.nearest_distance, last.nearest_self_pair,
                     last.self_clearance))


def plan_loop(q0: NDArray[np.float64], robot: RobotArrays, scene: Scene, goal_p: NDArray[np.float64],
              goal_q: NDArray[np.float64], params: NDArray[np.float64], max_iterations: int,
              cancel: NDArray[np.uint8], goal_joints: NDArray[np.float64] | None = None,
              joint_gain: float = 0.0) -> tuple[Any, ...]:
    """Integrate q ← clip(q + q̇ dt) from ``q0`` until the goal, a collision, stagnation, the iteration limit or
    ``cancel[0] != 0`` (a :class:`~pfield.planning.CancelToken`'s flag, read every step; the GIL is released).
    ``goal_joints``, ``joint_gain``: the posture term (:func:`planner`).

    Returns ``(status, count, q, qdot, positions, quaternions, twists, clearances, culprit)`` with ``count``
    recorded waypoints (the start included) and ``status`` a :class:`PlanStatus`. Waypoint k holds the
    configuration q_k, the velocity applied from it (zero at the last waypoint of a successful plan) and the
    end-effector twist J(q_k) q̇_k; ``culprit`` (:func:`culprit`) describes the last step evaluated.
    """
    n, total = len(q0), max_iterations + 1
    qs, qds = np.empty((total, n)), np.empty((total, n))
    positions, quats, twists, clear = np.empty((total, 3)), np.empty((total, 4)), np.empty((total, 6)), np.empty(total)
    result = planner(robot, scene, goal_p, goal_q, params, goal_joints, joint_gain).plan(
        np.ascontiguousarray(q0, dtype=np.float64), max_iterations, cancel, qs, qds, positions, quats, twists, clear)
    count = result.count
    return PlanStatus(result.status), count, qs[:count], qds[:count], positions[:count], quats[:count], \
        twists[:count], clear[:count], culprit(result.last)


def pair_distances(q: NDArray[np.float64], robot: RobotArrays, scene: Scene, cutoff: float = np.inf
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Clearances (m) of the fitted model at ``q``: link × obstacle (L, M) and self pairs (P,), by the compiled
    core (``src/core/robot/clearance``: the same bits as the numba kernels it replaced, issue 32); the self pairs on
    the fitted primitives when ``scene.fitted_self``, else on the covering capsules. Exact below ``cutoff`` (m);
    a pair at least that far may get any value at least ``cutoff`` (the covering capsules' self pairs are always
    exact): a caller that compares the values with a margin up to ``cutoff`` gets the same answers."""
    clearances = _distance.clearances_at(core_robot(robot), q, core_obstacles(scene), cutoff)
    if scene.fitted_self:
        return clearances.obstacle, np.asarray(_distance.fitted_self_clearances_at(core_robot(robot), q, cutoff))
    return clearances.obstacle, clearances.own
