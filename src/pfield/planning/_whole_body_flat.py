"""A low-overhead Python entry to one whole-body field step (the autonomy vector's hot path).

Calling a numba function costs about a microsecond per array argument (type dispatch and unboxing), and
the whole-body step takes ~60 arrays in its named tuples. Here the robot, the scene offsets and the
workspace live in three flat buffers (float, int, workspace) that :func:`flat_step` re-views as the named
tuples inside compiled code, so a call from Python unboxes a dozen arrays instead.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from pfield.geometry._packed import PackedObstacles
from pfield.planning import _whole_body_kernel as _wb
from pfield.planning._whole_body_loop import autonomy_step

__all__ = ["FlatStep", "flat_step"]


def _dims(robot: _wb.RobotArrays, scene: _wb.Scene) -> NDArray[np.int64]:
    n, caps, obstacles, pairs = len(robot.parents), len(robot.cap_joint), len(scene.bounds), len(robot.self_pairs)
    return np.array([n, caps, obstacles, pairs, caps * obstacles + pairs + 2 * n, robot.ee_joint, len(robot.prim_r)],
                    dtype=np.int64)


class FlatStep:
    """Flat buffers of (robot, scene) plus a workspace; ``buffers`` are the arguments of :func:`flat_step`."""

    def __init__(self, robot: _wb.RobotArrays, scene: _wb.Scene) -> None:
        dims = _dims(robot, scene)
        floats = [robot.place_rot, robot.place_pos, robot.axes, robot.ee_rot, robot.ee_pos, robot.cap_a, robot.cap_b,
                  robot.cap_r, robot.lower, robot.upper, robot.max_velocity, robot.max_acceleration, scene.centres,
                  scene.bounds, scene.obstacle_offsets, scene.self_offsets, robot.prim_a, robot.prim_b, robot.prim_r,
                  robot.self_r]
        ints = [robot.parents, robot.kinds, robot.support, robot.cap_joint, robot.self_pairs, robot.link_start,
                robot.prim_joint]
        self.dims = dims
        self.floats = np.concatenate([np.ravel(a).astype(np.float64) for a in floats])
        self.ints = np.concatenate([np.ravel(a).astype(np.int64) for a in ints])
        n, caps, _, _, m_max, _, prims = (int(v) for v in dims)
        self.work = np.zeros(_workspace_size(n, caps, m_max, prims))
        self.packed = scene.packed

    def buffers(self) -> tuple[Any, ...]:
        """The trailing arguments of :func:`flat_step` (the obstacles' arrays one by one: a named tuple
        argument costs microseconds of type dispatch per call)."""
        return (self.dims, self.floats, self.ints, self.work, *self.packed)


def _workspace_size(n: int, caps: int, m_max: int, prims: int) -> int:
    return (n * 9 + n * 3 + 6 * n + 3 * n + 3 * n + m_max * n + m_max + m_max * n + m_max + m_max + n * n + n + n
            + n + caps * 3 + caps * 3 + n + 6 + 12 + 20 + prims * 3 + prims * 3)


@njit(cache=True, inline="always")
def _take(buffer, offset, size):  # type: ignore[no-untyped-def]
    return buffer[offset:offset + size], offset + size


@njit(cache=True)
def _views(dims, floats, ints, work, packed):  # type: ignore[no-untyped-def]
    n, caps, obstacles, pairs, m_max, ee_joint, prims = dims[0], dims[1], dims[2], dims[3], dims[4], dims[5], dims[6]
    o = 0
    place_rot, o = _take(floats, o, n * 9)
    place_pos, o = _take(floats, o, n * 3)
    axes, o = _take(floats, o, n * 3)
    ee_rot, o = _take(floats, o, 9)
    ee_pos, o = _take(floats, o, 3)
    cap_a, o = _take(floats, o, caps * 3)
    cap_b, o = _take(floats, o, caps * 3)
    cap_r, o = _take(floats, o, caps)
    lower, o = _take(floats, o, n)
    upper, o = _take(floats, o, n)
    max_velocity, o = _take(floats, o, n)
    max_acceleration, o = _take(floats, o, n)
    centres, o = _take(floats, o, obstacles * 3)
    bounds, o = _take(floats, o, obstacles)
    obstacle_offsets, o = _take(floats, o, caps * obstacles)
    self_offsets, o = _take(floats, o, pairs)
    prim_a, o = _take(floats, o, prims * 3)
    prim_b, o = _take(floats, o, prims * 3)
    prim_r, o = _take(floats, o, prims)
    self_r, o = _take(floats, o, caps)
    i = 0
    parents, i = _take(ints, i, n)
    kinds, i = _take(ints, i, n)
    support, i = _take(ints, i, n * n)
    cap_joint, i = _take(ints, i, caps)
    self_pairs, i = _take(ints, i, pairs * 2)
    link_start, i = _take(ints, i, caps + 1)
    prim_joint, i = _take(ints, i, prims)
    robot = _wb.RobotArrays(parents, place_rot.reshape((n, 3, 3)), place_pos.reshape((n, 3)), axes.reshape((n, 3)),
                            kinds, support.reshape((n, n)), ee_joint, ee_rot.reshape((3, 3)), ee_pos,
                            cap_joint, cap_a.reshape((caps, 3)), cap_b.reshape((caps, 3)), cap_r,
                            self_pairs.reshape((pairs, 2)), lower, upper, max_velocity, max_acceleration,
                            link_start, prim_joint, prim_a.reshape((prims, 3)), prim_b.reshape((prims, 3)), prim_r,
                            self_r)
    scene = _wb.Scene(packed, centres.reshape((obstacles, 3)), bounds, obstacle_offsets.reshape((caps, obstacles)),
                      self_offsets)
    return robot, scene, _workspace_views(work, n, caps, m_max, prims)


@njit(cache=True)
def _workspace_views(work, n, caps, m_max, prims):  # type: ignore[no-untyped-def]
    o = 0
    rotations, o = _take(work, o, n * 9)
    origins, o = _take(work, o, n * 3)
    jac, o = _take(work, o, 6 * n)
    jlin, o = _take(work, o, 3 * n)
    jlin2, o = _take(work, o, 3 * n)
    rows, o = _take(work, o, m_max * n)
    b, o = _take(work, o, m_max)
    hinv, o = _take(work, o, m_max * n)
    mu, o = _take(work, o, m_max)
    curvature, o = _take(work, o, m_max)
    h, o = _take(work, o, n * n)
    rhs, o = _take(work, o, n)
    x, o = _take(work, o, n)
    free, o = _take(work, o, n)
    seg_a, o = _take(work, o, caps * 3)
    seg_b, o = _take(work, o, caps * 3)
    limited, o = _take(work, o, n)
    scratch, o = _take(work, o, 6)
    task, o = _take(work, o, 12)
    out, o = _take(work, o, 20)
    prim_seg_a, o = _take(work, o, prims * 3)
    prim_seg_b, o = _take(work, o, prims * 3)
    return _wb.Workspace(rotations.reshape((n, 3, 3)), origins.reshape((n, 3)), jac.reshape((6, n)),
                         jlin.reshape((3, n)), jlin2.reshape((3, n)), rows.reshape((m_max, n)), b,
                         hinv.reshape((m_max, n)), mu, curvature, h.reshape((n, n)), rhs, x, free,
                         seg_a.reshape((caps, 3)), seg_b.reshape((caps, 3)), limited, scratch.reshape((2, 3)),
                         task.reshape((2, 6)), out, prim_seg_a.reshape((prims, 3)), prim_seg_b.reshape((prims, 3)))


@njit(cache=True)
def flat_step(  # type: ignore[no-untyped-def]
        q, previous, has_prev, goal_p, goal_q, params, dims, floats, ints, work, kinds, rows, triangles,
        pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table):
    """:func:`~pfield.planning._whole_body_loop.autonomy_step` on the flat buffers of :class:`FlatStep`.

    Returns the (20,) output row (twist 0:6, position 6:9, quaternion 9:13, clearance 13, …) followed by q̇.
    """
    packed = PackedObstacles(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
    robot, scene, ws = _views(dims, floats, ints, work, packed)
    autonomy_step(q, previous, has_prev, robot, scene, goal_p, goal_q, params, ws)
    result = np.empty(20 + q.shape[0])
    result[:20] = ws.out
    result[20:] = ws.x
    return result
