"""Compiled core of shared-control assistance at one robot point (see :mod:`pfield.assistance` for the laws).

One call, arrays in and out: the nearest obstacle (exact signed distance), the arbitration weight α, the
blend u = α u_auto + (1 − α) u_user, the relative velocity dampers applied to it, MoveIt Servo's speed scale
and the time to collision of the operator's command. No allocation; obstacle velocities are an (M, 3) array.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pfield.field.forces import damper_speed, project_damper
from pfield.geometry._sdf import obstacle_signed_distance

# parameter vector layout
INFLUENCE, SAFETY, GAIN, MAX_SPEED, MAX_ACCELERATION, MODE, GOAL_SHARE, SCALE_THRESHOLD = range(8)
N_PARAMS = 8
# arbitration modes (MODE)
MODE_LINEAR, MODE_LINEAR_GOAL, MODE_SAFETY_ONLY = 0, 1, 2
# output layout
BLENDED, ALPHA, SCALE, NEAREST, DISTANCE, NORMAL, TTC, LIMITED = 0, 6, 7, 8, 9, 10, 13, 14
N_OUT = 15
_SWEEPS = 8  # alternating projections over the active dampers (von Neumann); 1–2 suffice in practice


@njit(cache=True)
def obstacle_share(distance: float, influence: float, safety: float) -> float:
    """α_obs = clip((Q − d)/(Q − d_s), 0, 1): 0 beyond the influence distance Q, 1 at the safety distance."""
    return min(max((influence - distance) / (influence - safety), 0.0), 1.0)


@njit(cache=True)
def servo_scale(distance: float, threshold: float) -> float:
    """MoveIt Servo's collision velocity scale: exp(k (d − d_t)) for 0 < d < d_t, k = −ln(0.001)/d_t.

    1 beyond the threshold d_t, 0.001 at contact, 0 in collision (d ≤ 0) as Servo halts there.
    """
    if distance >= threshold:
        return 1.0
    if distance <= 0.0:
        return 0.0
    k = -math.log(0.001) / threshold
    return math.exp(k * (distance - threshold))


@njit(cache=True)
def limit_approach(p, packed, velocities, vx, vy, vz, params):  # type: ignore[no-untyped-def]
    """The nearest velocity whose approach speed −n̂ᵀ(v − v_obs) to every obstacle within Q obeys its damper.

    Alternating projections onto the half-spaces −n̂ᵀ(v − v_obs,i) ≤ s_i(d_i) (s_i = NEO damper speed,
    :func:`pfield.field.forces.damper_speed`); each projection only adds velocity along n̂_i (away from
    obstacle i), so motion away from an obstacle is never slowed. Returns (vx, vy, vz, changed).
    """
    changed = False
    count = packed.kinds.shape[0]
    for _ in range(_SWEEPS):
        moved = False
        for i in range(count):
            d, nx, ny, nz = obstacle_signed_distance(packed, i, p)
            if d >= params[INFLUENCE]:
                continue
            allowed = damper_speed(d, params[INFLUENCE], params[SAFETY], params[GAIN], params[MAX_SPEED],
                                   params[MAX_ACCELERATION])
            ox, oy, oz = velocities[i, 0], velocities[i, 1], velocities[i, 2]
            wx, wy, wz, hit = project_damper(vx - ox, vy - oy, vz - oz, nx, ny, nz, allowed)
            if hit:
                vx, vy, vz = wx + ox, wy + oy, wz + oz
                moved = changed = True
        if not moved:
            break
    return vx, vy, vz, changed


@njit(cache=True)
def assist_point(p, packed, velocities, user, auto, params, out):  # type: ignore[no-untyped-def]
    """Fill ``out`` (:data:`N_OUT`,) for robot point ``p``, operator twist ``user`` (6,), autonomy ``auto`` (6,)."""
    best, nearest = math.inf, -1
    bx, by, bz = 0.0, 0.0, 0.0
    ttc = math.inf
    for i in range(packed.kinds.shape[0]):
        d, nx, ny, nz = obstacle_signed_distance(packed, i, p)
        if d < best:
            best, nearest, bx, by, bz = d, i, nx, ny, nz
        # first-order time to collision: d / (relative approach speed), for the operator's command held
        approach = -(nx * (user[0] - velocities[i, 0]) + ny * (user[1] - velocities[i, 1])
                     + nz * (user[2] - velocities[i, 2]))
        if d <= 0.0:
            ttc = 0.0
        elif approach > 0.0:
            ttc = min(ttc, d / approach)
    mode = int(params[MODE])
    if mode == MODE_SAFETY_ONLY:
        alpha = 0.0
    else:
        alpha = obstacle_share(best, params[INFLUENCE], params[SAFETY]) if nearest >= 0 else 0.0
        if mode == MODE_LINEAR_GOAL:
            alpha = max(alpha, params[GOAL_SHARE])
    for k in range(6):
        out[BLENDED + k] = alpha * auto[k] + (1.0 - alpha) * user[k]
    vx, vy, vz, changed = limit_approach(p, packed, velocities, out[0], out[1], out[2], params)
    out[0], out[1], out[2] = vx, vy, vz
    out[ALPHA] = alpha
    out[SCALE] = servo_scale(best, params[SCALE_THRESHOLD])
    out[NEAREST] = nearest
    out[DISTANCE] = best
    out[NORMAL], out[NORMAL + 1], out[NORMAL + 2] = bx, by, bz
    out[TTC] = ttc
    out[LIMITED] = 1.0 if changed else 0.0


def empty_output() -> np.ndarray:
    return np.zeros(N_OUT)
