"""Compiled quaternion and SO(3) kernels (numba), the functional core under :mod:`pfield.spatial`.

Quaternions are in ROS order ``(x, y, z, w)``. Rotation vectors ("rotvec") are axis * angle in radians
(the so(3) exponential coordinates, Sola et al. 2018, "A micro Lie theory", eqs. 101-102).

The SO(3) maths lives here once, in two forms side by side: *scalar* kernels on plain floats and tuples
(:func:`so3_exp`, :func:`so3_log`, :func:`hamilton`, :func:`rotation_error`, :func:`left_increment`),
which the planners' inner loops call without allocating (inlined into their callers: a call that
returns a tuple costs as much as the arithmetic), and *array* kernels on 3- and 4-arrays
(:func:`quat_exp`, :func:`quat_log`, :func:`quat_mul` …) that wrap them for the batched functions of
:mod:`pfield.spatial`.
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
def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` (apply ``b`` first, then ``a``); array form of :func:`hamilton`."""
    out = np.empty(4)
    out[0], out[1], out[2], out[3] = hamilton(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3])
    return out


@njit(cache=True)
def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vector ``v`` by unit quaternion ``q``: v' = v + 2w (u × v) + 2 u × (u × v)."""
    ux, uy, uz, w = q[0], q[1], q[2], q[3]
    tx = 2.0 * (uy * v[2] - uz * v[1])
    ty = 2.0 * (uz * v[0] - ux * v[2])
    tz = 2.0 * (ux * v[1] - uy * v[0])
    out = np.empty(3)
    out[0] = v[0] + w * tx + (uy * tz - uz * ty)
    out[1] = v[1] + w * ty + (uz * tx - ux * tz)
    out[2] = v[2] + w * tz + (ux * ty - uy * tx)
    return out


@njit(cache=True)
def quat_exp(rotvec: np.ndarray) -> np.ndarray:
    """Exponential map so(3) -> S3; array form of :func:`so3_exp`."""
    out = np.empty(4)
    out[0], out[1], out[2], out[3] = so3_exp(rotvec[0], rotvec[1], rotvec[2])
    return out


@njit(cache=True)
def quat_log(q: np.ndarray) -> np.ndarray:
    """Logarithm map S3 -> so(3) on the short arc; array form of :func:`so3_log`."""
    out = np.empty(3)
    out[0], out[1], out[2] = so3_log(q[0], q[1], q[2], q[3])
    return out


@njit(cache=True)
def quat_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Geodesic angle between two unit quaternions, in [0, π]."""
    d = abs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3])
    if d > 1.0:
        d = 1.0
    return 2.0 * math.acos(d)


@njit(cache=True)
def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (maps local vectors to the parent frame)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    r = np.empty((3, 3))
    r[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    r[0, 1] = 2.0 * (x * y - z * w)
    r[0, 2] = 2.0 * (x * z + y * w)
    r[1, 0] = 2.0 * (x * y + z * w)
    r[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    r[1, 2] = 2.0 * (y * z - x * w)
    r[2, 0] = 2.0 * (x * z - y * w)
    r[2, 1] = 2.0 * (y * z + x * w)
    r[2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return r


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


# ----------------------------------------------------------------------------------------------------
# Batched loops over the kernels above, used by the vectorised functions of pfield.spatial.


@njit(cache=True)
def batch_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty((a.shape[0], 4))
    for i in range(a.shape[0]):
        out[i] = quat_mul(a[i], b[i])
    return out


@njit(cache=True)
def batch_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    out = np.empty((q.shape[0], 3))
    for i in range(q.shape[0]):
        out[i] = quat_rotate(q[i], v[i])
    return out


@njit(cache=True)
def batch_exp(rotvec: np.ndarray) -> np.ndarray:
    out = np.empty((rotvec.shape[0], 4))
    for i in range(rotvec.shape[0]):
        out[i] = quat_exp(rotvec[i])
    return out


@njit(cache=True)
def batch_log(q: np.ndarray) -> np.ndarray:
    out = np.empty((q.shape[0], 3))
    for i in range(q.shape[0]):
        out[i] = quat_log(q[i])
    return out


@njit(cache=True)
def batch_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        out[i] = quat_angle(a[i], b[i])
    return out


@njit(cache=True)
def batch_to_matrix(q: np.ndarray) -> np.ndarray:
    out = np.empty((q.shape[0], 3, 3))
    for i in range(q.shape[0]):
        out[i] = quat_to_matrix(q[i])
    return out


@njit(cache=True)
def batch_from_matrix(r: np.ndarray) -> np.ndarray:
    out = np.empty((r.shape[0], 4))
    for i in range(r.shape[0]):
        out[i] = matrix_to_quat(r[i])
    return out
