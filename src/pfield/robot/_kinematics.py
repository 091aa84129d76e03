"""Compiled forward kinematics and point Jacobians of a serial/tree robot with 1-DoF joints (numba).

The numba twins of the core's ``src/core/robot/kinematics`` (which :class:`pfield.robot.RobotModel` calls): the
numba kernels not yet ported (whole body, assistance, RRT, clearance) inline these; both compute in the same
order without fused multiply-adds, so both give the same bits (tests/robot/test_core_kinematics.py).

The robot is packed once (from the pinocchio model, see :mod:`pfield.robot.model`) into arrays:

* ``parents[i]`` — index of joint i's parent joint (−1 for the fixed base), tree order (parent < child);
* ``place_rot[i]``, ``place_pos[i]`` — rotation and position of joint i's frame in its parent joint's
  frame at q = 0 (pinocchio's ``model.jointPlacements``);
* ``axes[i]`` — unit joint axis in joint i's own frame; ``kinds[i]`` — 0 revolute, 1 prismatic;
* ``support[k, j]`` — 1 when joint j lies on the path from the base to joint k (j ≤ k).

Forward kinematics composes ``T_i = T_parent(i) · X_i · exp(a_i q_i)`` (Featherstone, *Rigid Body Dynamics
Algorithms* 2008, §4.1). The world-aligned Jacobian of a point ``p`` carried by joint k has, for each
supporting revolute joint j, the columns ``[z_j × (p − o_j); z_j]`` and for a prismatic joint ``[z_j; 0]``,
with ``z_j = R_j a_j`` the world axis and ``o_j`` the world origin of joint j (Siciliano et al. 2009, §3.1).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

REVOLUTE, PRISMATIC = 0, 1


@njit(cache=True)
def joint_transforms(q, parents, place_rot, place_pos, axes, kinds, rotations, origins):  # type: ignore[no-untyped-def]
    """World rotation ``rotations[i]`` (3×3) and origin ``origins[i]`` (3,) of every joint frame at ``q``.

    ``place_rot[i]``/``place_pos[i]`` are joint i's placement in its parent joint frame. Rotations about
    the joint axis use Rodrigues' formula. Allocation-free (scalar code) because it runs every step.
    """
    for i in range(q.shape[0]):
        k = parents[i]
        # B = R_parent · P_i and o = R_parent · p_i + o_parent (B = P_i, o = p_i at the base)
        if k < 0:
            b00, b01, b02 = place_rot[i, 0, 0], place_rot[i, 0, 1], place_rot[i, 0, 2]
            b10, b11, b12 = place_rot[i, 1, 0], place_rot[i, 1, 1], place_rot[i, 1, 2]
            b20, b21, b22 = place_rot[i, 2, 0], place_rot[i, 2, 1], place_rot[i, 2, 2]
            o0, o1, o2 = place_pos[i, 0], place_pos[i, 1], place_pos[i, 2]
        else:
            rp = rotations[k]
            pr = place_rot[i]
            b00 = rp[0, 0] * pr[0, 0] + rp[0, 1] * pr[1, 0] + rp[0, 2] * pr[2, 0]
            b01 = rp[0, 0] * pr[0, 1] + rp[0, 1] * pr[1, 1] + rp[0, 2] * pr[2, 1]
            b02 = rp[0, 0] * pr[0, 2] + rp[0, 1] * pr[1, 2] + rp[0, 2] * pr[2, 2]
            b10 = rp[1, 0] * pr[0, 0] + rp[1, 1] * pr[1, 0] + rp[1, 2] * pr[2, 0]
            b11 = rp[1, 0] * pr[0, 1] + rp[1, 1] * pr[1, 1] + rp[1, 2] * pr[2, 1]
            b12 = rp[1, 0] * pr[0, 2] + rp[1, 1] * pr[1, 2] + rp[1, 2] * pr[2, 2]
            b20 = rp[2, 0] * pr[0, 0] + rp[2, 1] * pr[1, 0] + rp[2, 2] * pr[2, 0]
            b21 = rp[2, 0] * pr[0, 1] + rp[2, 1] * pr[1, 1] + rp[2, 2] * pr[2, 1]
            b22 = rp[2, 0] * pr[0, 2] + rp[2, 1] * pr[1, 2] + rp[2, 2] * pr[2, 2]
            px, py, pz = place_pos[i, 0], place_pos[i, 1], place_pos[i, 2]
            o0 = rp[0, 0] * px + rp[0, 1] * py + rp[0, 2] * pz + origins[k, 0]
            o1 = rp[1, 0] * px + rp[1, 1] * py + rp[1, 2] * pz + origins[k, 1]
            o2 = rp[2, 0] * px + rp[2, 1] * py + rp[2, 2] * pz + origins[k, 2]
        x, y, z = axes[i, 0], axes[i, 1], axes[i, 2]
        out = rotations[i]
        if kinds[i] == REVOLUTE:
            c, s = math.cos(q[i]), math.sin(q[i])
            t = 1.0 - c
            l00, l01, l02 = c + x * x * t, x * y * t - z * s, x * z * t + y * s
            l10, l11, l12 = y * x * t + z * s, c + y * y * t, y * z * t - x * s
            l20, l21, l22 = z * x * t - y * s, z * y * t + x * s, c + z * z * t
            out[0, 0] = b00 * l00 + b01 * l10 + b02 * l20
            out[0, 1] = b00 * l01 + b01 * l11 + b02 * l21
            out[0, 2] = b00 * l02 + b01 * l12 + b02 * l22
            out[1, 0] = b10 * l00 + b11 * l10 + b12 * l20
            out[1, 1] = b10 * l01 + b11 * l11 + b12 * l21
            out[1, 2] = b10 * l02 + b11 * l12 + b12 * l22
            out[2, 0] = b20 * l00 + b21 * l10 + b22 * l20
            out[2, 1] = b20 * l01 + b21 * l11 + b22 * l21
            out[2, 2] = b20 * l02 + b21 * l12 + b22 * l22
        else:
            out[0, 0], out[0, 1], out[0, 2] = b00, b01, b02
            out[1, 0], out[1, 1], out[1, 2] = b10, b11, b12
            out[2, 0], out[2, 1], out[2, 2] = b20, b21, b22
            d = q[i]
            o0 += (b00 * x + b01 * y + b02 * z) * d
            o1 += (b10 * x + b11 * y + b12 * z) * d
            o2 += (b20 * x + b21 * y + b22 * z) * d
        origins[i, 0], origins[i, 1], origins[i, 2] = o0, o1, o2


@njit(cache=True, inline="always")
def transform_point_into(rotations, origins, joint, local_point, out):  # type: ignore[no-untyped-def]
    """World position of a point fixed to ``joint`` (−1: the base) at ``local_point``, into ``out`` (3,)."""
    if joint < 0:
        out[0], out[1], out[2] = local_point[0], local_point[1], local_point[2]
        return
    r = rotations[joint]
    x, y, z = local_point[0], local_point[1], local_point[2]
    out[0] = r[0, 0] * x + r[0, 1] * y + r[0, 2] * z + origins[joint, 0]
    out[1] = r[1, 0] * x + r[1, 1] * y + r[1, 2] * z + origins[joint, 1]
    out[2] = r[2, 0] * x + r[2, 1] * y + r[2, 2] * z + origins[joint, 2]


@njit(cache=True)
def frame_pose(rotations, origins, joint, local_rotation, local_position):  # type: ignore[no-untyped-def]
    """World (R, p) of a frame fixed to ``joint`` (−1: the base) at the local placement given."""
    if joint < 0:
        return local_rotation.copy(), local_position.copy()
    r = np.empty((3, 3))
    rj = rotations[joint]
    for a in range(3):
        for c in range(3):
            r[a, c] = (rj[a, 0] * local_rotation[0, c] + rj[a, 1] * local_rotation[1, c]
                       + rj[a, 2] * local_rotation[2, c])
    p = np.empty(3)
    transform_point_into(rotations, origins, joint, local_position, p)
    return r, p


@njit(cache=True, inline="always")
def _joint_column(rotations, origins, axes, kinds, j, px, py, pz):  # type: ignore[no-untyped-def]
    """World axis z_j of joint ``j`` and its linear Jacobian column at the world point (px, py, pz).

    Revolute: v = z_j × (p − o_j); prismatic: v = z_j (Siciliano et al. 2009, §3.1).
    Returns (zx, zy, zz, vx, vy, vz).
    """
    rj = rotations[j]
    ax, ay, az = axes[j, 0], axes[j, 1], axes[j, 2]
    zx = rj[0, 0] * ax + rj[0, 1] * ay + rj[0, 2] * az
    zy = rj[1, 0] * ax + rj[1, 1] * ay + rj[1, 2] * az
    zz = rj[2, 0] * ax + rj[2, 1] * ay + rj[2, 2] * az
    if kinds[j] == REVOLUTE:
        dx, dy, dz = px - origins[j, 0], py - origins[j, 1], pz - origins[j, 2]
        return zx, zy, zz, zy * dz - zz * dy, zz * dx - zx * dz, zx * dy - zy * dx
    return zx, zy, zz, zx, zy, zz


@njit(cache=True)
def point_jacobian(rotations, origins, axes, kinds, support, joint, point, out):  # type: ignore[no-untyped-def]
    """World-aligned 6×n Jacobian (linear rows first) of world ``point`` rigidly attached to ``joint``.

    Columns of joints that do not support ``joint`` are zero; a prismatic joint's angular rows are zero.
    ``out`` (6, n) is overwritten.
    """
    n = axes.shape[0]
    for j in range(n):
        for r in range(6):
            out[r, j] = 0.0
    if joint < 0:
        return
    for j in range(n):
        if support[joint, j] == 0:
            continue
        zx, zy, zz, out[0, j], out[1, j], out[2, j] = _joint_column(
            rotations, origins, axes, kinds, j, point[0], point[1], point[2])
        if kinds[j] == REVOLUTE:
            out[3, j] = zx
            out[4, j] = zy
            out[5, j] = zz


@njit(cache=True, inline="always")
def linear_point_jacobian(rotations, origins, axes, kinds, support, joint, px, py, pz, out):  # type: ignore[no-untyped-def]
    """Linear rows only (3×n) of :func:`point_jacobian` at the world point (px, py, pz); overwrites ``out``."""
    n = axes.shape[0]
    for j in range(n):
        out[0, j] = 0.0
        out[1, j] = 0.0
        out[2, j] = 0.0
    if joint < 0:
        return
    for j in range(n):
        if support[joint, j] == 0:
            continue
        _, _, _, out[0, j], out[1, j], out[2, j] = _joint_column(rotations, origins, axes, kinds, j, px, py, pz)


@njit(cache=True)
def end_effector_kinematics(  # type: ignore[no-untyped-def]
        q, parents, place_rot, place_pos, axes, kinds, support, ee_joint, ee_rotation, ee_position, rotations,
        origins, jacobian):
    """Forward kinematics of all joints, then the end effector's world (R, p) and its 6×n Jacobian."""
    joint_transforms(q, parents, place_rot, place_pos, axes, kinds, rotations, origins)
    r, p = frame_pose(rotations, origins, ee_joint, ee_rotation, ee_position)
    point_jacobian(rotations, origins, axes, kinds, support, ee_joint, p, jacobian)
    return r, p


@njit(cache=True)
def check_limits(values, lower, upper, tolerance):  # type: ignore[no-untyped-def]
    """Clamp ``values`` onto [lower, upper] in place; −1 if fine, else the first bad index i (beyond the limits
    by more than ``tolerance``) or −2 − i (not finite)."""
    for i in range(values.shape[0]):
        v = values[i]
        if not math.isfinite(v):
            return -2 - i
        if v < lower[i] - tolerance or v > upper[i] + tolerance:
            return i
        values[i] = min(max(v, lower[i]), upper[i])
    return -1
