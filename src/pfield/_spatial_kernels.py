"""Compiled quaternion and SO(3) kernels (numba), the functional core under :mod:`pfield.spatial`.

Quaternions are 4-arrays in ROS order ``(x, y, z, w)``. Every kernel here works on one quaternion or
vector and is meant to be called from other compiled code; :mod:`pfield.spatial` wraps batched versions
for Python callers. Rotation vectors ("rotvec") are axis * angle in radians (the so(3) exponential
coordinates, Sola et al. 2018, "A micro Lie theory", eqs. 101-102).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_SMALL_ANGLE = 1e-8


@njit(cache=True)
def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` (apply ``b`` first, then ``a``)."""
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    out = np.empty(4)
    out[0] = aw * bx + ax * bw + ay * bz - az * by
    out[1] = aw * by - ax * bz + ay * bw + az * bx
    out[2] = aw * bz + ax * by - ay * bx + az * bw
    out[3] = aw * bw - ax * bx - ay * by - az * bz
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
    """Exponential map so(3) -> S3: q = (sin(θ/2) ω/θ, cos(θ/2)), θ = |ω|."""
    theta = math.sqrt(rotvec[0] ** 2 + rotvec[1] ** 2 + rotvec[2] ** 2)
    out = np.empty(4)
    if theta < _SMALL_ANGLE:
        # sin(θ/2)/θ ≈ 1/2 − θ²/48
        s = 0.5 - theta * theta / 48.0
        out[3] = 1.0 - theta * theta / 8.0
    else:
        s = math.sin(0.5 * theta) / theta
        out[3] = math.cos(0.5 * theta)
    out[0] = s * rotvec[0]
    out[1] = s * rotvec[1]
    out[2] = s * rotvec[2]
    return out


@njit(cache=True)
def quat_log(q: np.ndarray) -> np.ndarray:
    """Logarithm map S3 -> so(3) on the short arc: the rotation vector with angle in [0, π]."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    vnorm = math.sqrt(x * x + y * y + z * z)
    out = np.empty(3)
    if vnorm < _SMALL_ANGLE:
        # θ ≈ 2|v|/w  ->  rotvec ≈ 2 v / w
        scale = 2.0 / w
    else:
        scale = 2.0 * math.atan2(vnorm, w) / vnorm
    out[0] = scale * x
    out[1] = scale * y
    out[2] = scale * z
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
