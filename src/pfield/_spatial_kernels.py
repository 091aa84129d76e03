"""Compiled quaternion and SO(3) kernels (numba), the functional core under :mod:`pfield.spatial`.

Quaternions are in ROS order ``(x, y, z, w)``. Rotation vectors ("rotvec") are axis * angle in radians
(the so(3) exponential coordinates, Sola et al. 2018, "A micro Lie theory", eqs. 101-102).

These are the *scalar* kernels on plain floats and tuples (:func:`so3_exp`, :func:`so3_log`, :func:`hamilton`,
:func:`rotation_error`, :func:`left_increment`, :func:`matrix_to_quat`) that the numba kernels not yet moved to the
compiled core (whole body, IK, the assistance, the field's batches) inline. The batched functions of
:mod:`pfield.spatial` and the core's own loops use ``src/core/math/so3.hpp``, the same formulas in the same order
(the same bits, tested in tests/test_spatial_kernels.py).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_SMALL_ANGLE = 1e-8
"""Below this angle (rad) exp and log use their Taylor series: sin(θ/2)/θ ≈ ½ − θ²/48 and
atan2(‖v‖, w)/‖v‖ ≈ 1/w. The next terms are relative θ⁴/1920 and ‖v‖²/3 ≤ 3.4e-17, under half an ulp of
double precision, so the series equals the closed form there while avoiding its 0/0 at θ = 0."""


@njit(cache=True, inline="always")
def hamilton(
    ax: float, ay: float, az: float, aw: float, bx: float, by: float, bz: float, bw: float
) -> tuple[float, float, float, float]:
    """Hamilton product ``a ⊗ b`` of two quaternions given by their components (apply b first, then a)."""
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


@njit(cache=True, inline="always")
def so3_exp(ax: float, ay: float, az: float) -> tuple[float, float, float, float]:
    """Exponential map so(3) → S³ of the rotation vector a: (sin(θ/2) a/θ, cos(θ/2)), θ = ‖a‖."""
    theta = math.sqrt(ax * ax + ay * ay + az * az)
    if theta < _SMALL_ANGLE:
        s, w = 0.5 - theta * theta / 48.0, 1.0 - theta * theta / 8.0
    else:
        s, w = math.sin(0.5 * theta) / theta, math.cos(0.5 * theta)
    return s * ax, s * ay, s * az, w


@njit(cache=True, inline="always")
def so3_log(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """Logarithm map S³ → so(3) on the short arc (q and −q alike): the rotation vector, angle in [0, π]."""
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    vnorm = math.sqrt(x * x + y * y + z * z)
    if vnorm < _SMALL_ANGLE:
        scale = 2.0 / w  # w ≈ 1 here: the unit quaternion is almost the identity
    else:
        scale = 2.0 * math.atan2(vnorm, w) / vnorm
    return scale * x, scale * y, scale * z


@njit(cache=True, inline="always")
def rotation_error(
    qx: float, qy: float, qz: float, qw: float, gx: float, gy: float, gz: float, gw: float
) -> tuple[float, float, float]:
    """World-frame rotation error log(q_g ⊗ q⁻¹) (rad, axis·angle, angle in [0, π]) of unit quaternions.

    Integrating ω = k · error on the left, q ← exp(ω dt) ⊗ q (:func:`left_increment`), shrinks the error
    along its own axis, so every start rotation up to 180° converges (Sola et al. 2018, eq. 26, left ⊖).
    q and −q give the same (short-arc) error.
    """
    ex, ey, ez, ew = hamilton(gx, gy, gz, gw, -qx, -qy, -qz, qw)
    return so3_log(ex, ey, ez, ew)


@njit(cache=True, inline="always")
def left_increment(
    qx: float, qy: float, qz: float, qw: float, wx: float, wy: float, wz: float, h: float
) -> tuple[float, float, float, float]:
    """exp(h ω) ⊗ q, renormalised: the world-frame (left) SO(3) update of a unit quaternion by ω (rad/s)."""
    ex, ey, ez, ew = so3_exp(h * wx, h * wy, h * wz)
    x, y, z, w = hamilton(ex, ey, ez, ew, qx, qy, qz, qw)
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    return x / norm, y / norm, z / norm, w / norm


@njit(cache=True)
def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (w >= 0) of a rotation matrix, by Shepperd's method (numerically stable)."""
    out = np.empty(4)
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0.0:
        s = 2.0 * math.sqrt(1.0 + trace)
        out[3] = 0.25 * s
        out[0] = (r[2, 1] - r[1, 2]) / s
        out[1] = (r[0, 2] - r[2, 0]) / s
        out[2] = (r[1, 0] - r[0, 1]) / s
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        out[3] = (r[2, 1] - r[1, 2]) / s
        out[0] = 0.25 * s
        out[1] = (r[0, 1] + r[1, 0]) / s
        out[2] = (r[0, 2] + r[2, 0]) / s
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        out[3] = (r[0, 2] - r[2, 0]) / s
        out[0] = (r[0, 1] + r[1, 0]) / s
        out[1] = 0.25 * s
        out[2] = (r[1, 2] + r[2, 1]) / s
    else:
        s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        out[3] = (r[1, 0] - r[0, 1]) / s
        out[0] = (r[0, 2] + r[2, 0]) / s
        out[1] = (r[1, 2] + r[2, 1]) / s
        out[2] = 0.25 * s
    if out[3] < 0.0:
        out = -out
    return out
