"""A low-overhead Python entry to one whole-body field step (the autonomy vector's hot path).

Calling a numba function costs about a microsecond per array argument (type dispatch and unboxing), and
the whole-body step takes ~60 arrays in its named tuples. Here the robot, the scene offsets and the
workspace live in flat buffers laid out by the specs of :mod:`pfield.planning._whole_body_layout`
(``ROBOT_FLOATS``, ``ROBOT_INTS``, ``SCENE_FLOATS``, ``WORKSPACE``), which :func:`flat_step` re-views as the
named tuples inside compiled code (views generated from the same specs), so a call from Python unboxes a
dozen arrays instead.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from pfield._bound import BoundArrays, float_view1, float_view2, float_view3, int_view1, int_view2
from pfield.geometry._packed import PackedObstacles
from pfield.planning import _whole_body_layout as _wb
from pfield.planning._whole_body_loop import autonomy_step
from pfield.robot._kinematics import check_limits
from pfield.robot.model import LIMIT_TOLERANCE

__all__ = ["FlatStep", "bound_step", "bound_workspace", "flat_step"]


class FlatStep:
    """Flat buffers of (robot, scene) plus a workspace; ``buffers`` are the trailing arguments of :func:`flat_step`."""

    def __init__(self, robot: _wb.RobotArrays, scene: _wb.Scene) -> None:
        n, caps, obstacles, pairs = len(robot.parents), len(robot.cap_joint), len(scene.bounds), len(robot.self_pairs)
        m_max, prims = caps * obstacles + pairs + 2 * n, len(robot.prim_r)
        self.dims = np.array([n, caps, obstacles, pairs, m_max, robot.ee_joint, prims], dtype=np.int64)
        values = robot._asdict()
        self.floats = _wb.ROBOT_FLOATS.pack(values, n=n, caps=caps, pairs=pairs, prims=prims)
        self.ints = _wb.ROBOT_INTS.pack(values, n=n, caps=caps, pairs=pairs, prims=prims, starts=caps + 1)
        self.scene = _wb.SCENE_FLOATS.pack(scene._asdict(), caps=caps, obstacles=obstacles, pairs=pairs)
        self.work = np.zeros(_wb.WORKSPACE.size(n=n, caps=caps, m=m_max, prims=prims))
        self.packed = scene.packed

    def bind(self, goal_p: np.ndarray, goal_q: np.ndarray, params: np.ndarray, lower: np.ndarray,
             upper: np.ndarray) -> BoundArrays:
        """The table of :func:`bound_step`: these buffers, the goal, ``params`` (rewritten in place by the
        caller when ``dt`` changes) and the joint limits that ``q`` is checked against."""
        return BoundArrays([self.dims, self.floats, self.ints, self.scene, self.work, goal_p, goal_q, params, lower,
                            upper, *self.packed])

    def buffers(self) -> tuple[Any, ...]:
        """The trailing arguments of :func:`flat_step` (the obstacles' arrays one by one: a named tuple
        argument costs microseconds of type dispatch per call)."""
        return (self.dims, self.floats, self.ints, self.scene, self.work, *self.packed)


@njit(cache=True)
def flat_step(
        q: np.ndarray, previous: np.ndarray, has_prev: bool, goal_p: np.ndarray, goal_q: np.ndarray, params: np.ndarray,
        dims: np.ndarray, floats: np.ndarray, ints: np.ndarray, scene_floats: np.ndarray, work: np.ndarray,
        kinds: np.ndarray, rows: np.ndarray, triangles: np.ndarray, pseudo_normals: np.ndarray, bvh_lower: np.ndarray,
        bvh_upper: np.ndarray, bvh_nodes: np.ndarray, mesh_table: np.ndarray) -> np.ndarray:
    """:func:`~pfield.planning._whole_body_loop.autonomy_step` on the flat buffers of :class:`FlatStep`.

    Returns the step's result row (``_wb.STEP_OUT``, read it with :class:`~._whole_body_layout.StepResult`)
    followed by q̇ (n,).
    """
    n, caps, obstacles, pairs, m_max, ee_joint, prims = dims[0], dims[1], dims[2], dims[3], dims[4], dims[5], dims[6]
    packed = PackedObstacles(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
    robot = _wb.robot_views(floats, ints, n, caps, pairs, prims, caps + 1, ee_joint)
    scene = _wb.scene_views(scene_floats, caps, obstacles, pairs, packed)
    ws = _wb.workspace_views(work, n, caps, m_max, prims)
    autonomy_step(q, previous, has_prev, robot, scene, goal_p, goal_q, params, ws)
    size = ws.out.shape[0]
    result = np.empty(size + q.shape[0])
    result[:size] = ws.out
    result[size:] = ws.x
    return result


@njit(cache=True, inline="always")
def bound_workspace(table: np.ndarray) -> _wb.Workspace:
    """The workspace of :func:`bound_step`'s ``table``: after a step it holds that step's joint frames, its
    end-effector Jacobian and world segments (for a caller that continues from them in compiled code)."""
    dims = int_view1(table, 0)
    return _wb.workspace_views(float_view1(table, 4), dims[0], dims[1], dims[4], dims[6])


@njit(cache=True)
def bound_step(q: np.ndarray, previous: np.ndarray, given: bool, use_previous: bool, table: np.ndarray) -> np.ndarray:
    """:func:`flat_step` on the arrays bound by :meth:`FlatStep.bind`, checking its inputs in compiled code.

    ``q`` is checked and clamped as :meth:`pfield.robot.RobotModel.check_joint_angles` does (a copy);
    ``previous`` (when ``given``) must have n finite values. Returns an empty array when an input is bad (the
    caller then takes the validating path, which raises the standard message), else the row of :func:`flat_step`.
    """
    dims = int_view1(table, 0)
    n, caps, obstacles, pairs, m_max, ee_joint, prims = dims[0], dims[1], dims[2], dims[3], dims[4], dims[5], dims[6]
    if q.shape[0] != n or (given and previous.shape[0] != n):
        return np.empty(0)
    values = np.empty(n)
    for j in range(n):
        values[j] = q[j]
    if check_limits(values, float_view1(table, 8), float_view1(table, 9), LIMIT_TOLERANCE) != -1:
        return np.empty(0)
    if given:
        for j in range(n):
            if not math.isfinite(previous[j]):
                return np.empty(0)
    packed = PackedObstacles(int_view1(table, 10), float_view2(table, 11), float_view3(table, 12),
                             float_view3(table, 13), float_view2(table, 14), float_view2(table, 15),
                             int_view2(table, 16), int_view2(table, 17))
    robot = _wb.robot_views(float_view1(table, 1), int_view1(table, 2), n, caps, pairs, prims, caps + 1, ee_joint)
    scene = _wb.scene_views(float_view1(table, 3), caps, obstacles, pairs, packed)
    ws = _wb.workspace_views(float_view1(table, 4), n, caps, m_max, prims)
    autonomy_step(values, previous, use_previous, robot, scene, float_view1(table, 5), float_view1(table, 6),
                  float_view1(table, 7), ws)
    size = ws.out.shape[0]
    result = np.empty(size + n)
    result[:size] = ws.out
    result[size:] = ws.x
    return result
