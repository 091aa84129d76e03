"""The field at a pose in numba: the raw wrench and the constrained twist, for the lane-wise batches.

One pose, the planning loop and :class:`~pfield.field.PreparedTwist` run in the compiled core
(``src/core/field/evaluate.cpp``, the same steps in the same order: the same bits). These numba versions remain
for :mod:`pfield.field._batch_parallel`, whose lanes evaluate eight poses side by side in SIMD instructions, until
that moves to the core too.

Inputs shared by every kernel here:

* ``goal`` (7,): goal position (m) then orientation quaternion (x, y, z, w), world frame;
* ``params`` (16,): :meth:`FieldConfig.packed` (layout :data:`pfield.field.config.PARAMS`), indexed by the
  constants below;
* ``packed``: :class:`~pfield.geometry._packed.PackedObstacles`;
* ``aux`` (M, 8): per obstacle the unit circulation axis c (3), a bounding radius (m), the shape centre
  (3) and 1.0 for spheres, built by :func:`obstacle_aux`. The bound lets far obstacles be skipped
  exactly, since the signed distance is at least ‖p − centre‖ − radius; for a sphere it is the distance.

Kernels that take ``packed`` are inlined (``inline="always"``) into their callers: numba reference-counts
every array of a tuple argument at each non-inlined call (two atomic operations per array), which would
cost more than the whole evaluation without obstacles. For the same reason the obstacle count and
centres are read from ``aux`` (a plain array): reading a field of the ``packed`` named tuple also costs
a reference-count pair, so ``packed`` is touched only to evaluate an obstacle's signed distance.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pfield._spatial_kernels import rotation_error
from pfield.field.config import PARAMS
from pfield.field.forces import (
    attraction,
    damper_speed,
    deflect,
    khatib_magnitude,
    project_damper,
    soft_saturate,
)
from pfield.geometry._packed import PackedObstacles
from pfield.geometry._sdf import obstacle_signed_distance

# Slots of FieldConfig.packed(), by name from its layout (numba freezes these module constants).
ATTRACTIVE_GAIN, ROTATIONAL_GAIN = PARAMS.index("attractive_gain"), PARAMS.index("rotational_attractive_gain")
REPULSIVE_GAIN = PARAMS.index("repulsive_gain")
MAX_LINEAR_VELOCITY, MAX_ANGULAR_VELOCITY = PARAMS.index("max_linear_velocity"), PARAMS.index("max_angular_velocity")
MAX_LINEAR_ACCELERATION = PARAMS.index("max_linear_acceleration")
MAX_ANGULAR_ACCELERATION = PARAMS.index("max_angular_acceleration")
INFLUENCE_DISTANCE, ATTRACTIVE_THRESHOLD = PARAMS.index("influence_distance"), PARAMS.index("attractive_threshold")
ROTATION_TOLERANCE, MAX_REPULSIVE_FORCE = PARAMS.index("rotation_tolerance"), PARAMS.index("max_repulsive_force")
SAFETY_DISTANCE, DAMPER_GAIN = PARAMS.index("safety_distance"), PARAMS.index("damper_gain")
CIRCULATION_GAIN, STAGNATION_WINDOW = PARAMS.index("circulation_gain"), PARAMS.index("stagnation_window")
STAGNATION_PROGRESS = PARAMS.index("stagnation_progress")
SPHERE_ROWS = 5  # a sphere's sweep-0 geometry in the batch kernels' cache (see damper_sweeps): rows
DISTANCE_ROW, NX_ROW, NY_ROW, NZ_ROW, ALLOWANCE_ROW = range(SPHERE_ROWS)
_SWEEPS = 16  # damper sweeps: one deflecting, then alternating projections (narrow wedges converge slowly)


@njit(cache=True, inline="always")
def _lower_bound(aux: np.ndarray, i: int, p: np.ndarray) -> tuple[float, float, float, float, float]:
    """(‖p − c‖ − radius, p − c, ‖p − c‖): a lower bound of obstacle i's signed distance at p."""
    dx, dy, dz = p[0] - aux[i, 4], p[1] - aux[i, 5], p[2] - aux[i, 6]
    norm = math.sqrt(dx * dx + dy * dy + dz * dz)
    return norm - aux[i, 3], dx, dy, dz, norm


@njit(cache=True, inline="always")
def _signed_distance(
    packed: PackedObstacles, aux: np.ndarray, i: int, p: np.ndarray,
    bound: float, dx: float, dy: float, dz: float, norm: float,
) -> tuple[float, float, float, float]:
    """Signed distance and normal of obstacle i at p; spheres reuse the (exact) bound of :func:`_lower_bound`."""
    if aux[i, 7] != 0.0 and norm > 0.0:
        inverse = 1.0 / norm
        return bound, dx * inverse, dy * inverse, dz * inverse
    return obstacle_signed_distance(packed, i, p)


@njit(cache=True, inline="always")
def field_wrench(
    p: np.ndarray, qx: float, qy: float, qz: float, qw: float,
    goal: np.ndarray, params: np.ndarray, packed: PackedObstacles, aux: np.ndarray,
) -> tuple[float, float, float, float, float, float]:
    """Raw wrench (N, N·m) at pose (p, q): attraction + Σ saturated Khatib repulsion, rotational torque."""
    fx, fy, fz = attraction(goal[0] - p[0], goal[1] - p[1], goal[2] - p[2],
                            params[ATTRACTIVE_GAIN], params[ATTRACTIVE_THRESHOLD])
    influence = params[INFLUENCE_DISTANCE]
    for i in range(aux.shape[0]):
        bound, dx, dy, dz, norm = _lower_bound(aux, i, p)
        if bound >= influence:
            continue
        d, nx, ny, nz = _signed_distance(packed, aux, i, p, bound, dx, dy, dz, norm)
        m = khatib_magnitude(d, params[REPULSIVE_GAIN], influence, params[MAX_REPULSIVE_FORCE])
        fx, fy, fz = fx + m * nx, fy + m * ny, fz + m * nz
    rx, ry, rz = rotation_error(qx, qy, qz, qw, goal[3], goal[4], goal[5], goal[6])
    k = params[ROTATIONAL_GAIN]
    return fx, fy, fz, k * rx, k * ry, k * rz


@njit(cache=True, inline="always")
def damper_allowance(d: float, params: np.ndarray) -> float:
    """The approach speed (m/s) that obstacle dampers allow at signed distance d < Q (:func:`damper_speed`)."""
    vmax = params[MAX_LINEAR_VELOCITY]
    return damper_speed(d, params[INFLUENCE_DISTANCE], params[SAFETY_DISTANCE], params[DAMPER_GAIN] * vmax, vmax,
                        params[MAX_LINEAR_ACCELERATION])


@njit(cache=True, inline="always")
def first_sweep_obstacle(
    vx: float, vy: float, vz: float, sx: float, sy: float, sz: float, active: int, active_previous: int,
    clearance: float, nearest: int, mx: float, my: float, mz: float,
    d: float, nx: float, ny: float, nz: float, i: int, params: np.ndarray, aux: np.ndarray,
) -> tuple[float, float, float, float, float, float, int, int, float, int, float, float, float]:
    """Sweep 0 of :func:`damper_sweeps` for obstacle i at signed distance d with normal n: the nearest
    obstacle so far (clearance, index, normal m); within Q, deflect the twist v and project the previous
    linear twist s, counting the dampers that bind on each. Returns the updated state."""
    if d < clearance:
        clearance, nearest, mx, my, mz = d, i, nx, ny, nz
    if d < params[INFLUENCE_DISTANCE]:
        allowed = damper_allowance(d, params)
        sx, sy, sz, moved = project_damper(sx, sy, sz, nx, ny, nz, allowed)
        vx, vy, vz, hit = deflect(vx, vy, vz, nx, ny, nz, aux[i, 0], aux[i, 1], aux[i, 2], allowed,
                                  params[CIRCULATION_GAIN])
        active, active_previous = active + hit, active_previous + moved
    return vx, vy, vz, sx, sy, sz, active, active_previous, clearance, nearest, mx, my, mz


@njit(cache=True, inline="always")
def damper_sweeps(
    p: np.ndarray, vx: float, vy: float, vz: float, sx: float, sy: float, sz: float, active: int,
    active_previous: int, clearance: float, mx: float, my: float, mz: float, first: int,
    params: np.ndarray, packed: PackedObstacles, aux: np.ndarray, spheres: np.ndarray, lane: int, lanes: int,
) -> tuple[float, float, float, float, float, float, int, int, float, int, float, float, float]:
    """The damper sweeps of the constrained twist (``avoid`` in ``src/core/field/evaluate.cpp``) from sweep ``first`` on
    (0: all of them) and its last step.

    Sweep 0 runs :func:`first_sweep_obstacle` per obstacle; later sweeps, while two or more dampers bind,
    project v and the previous linear twist s onto every damper's half-space until nothing changes; then, if
    the dampers could not all hold, the nearest obstacle's damper is enforced last. The batch kernels run
    sweep 0 lane-wise themselves and start here at ``first`` = 1 with ``lanes`` > 0: ``spheres`` then holds
    sweep 0's geometry of every sphere for ``lanes`` poses side by side (:data:`SPHERE_ROWS` rows of
    ``lanes`` values per obstacle: row r of obstacle i, lane j at (i · SPHERE_ROWS + r) · lanes + j), which
    the later sweeps reuse instead of recomputing it; with ``lanes`` = 0 ``spheres`` is not read. One call
    site of the (inlined, large) exact signed distance per kernel keeps the compile time down. Returns
    (v, s, active, active_previous, clearance, nearest, m).
    """
    influence = params[INFLUENCE_DISTANCE]
    nearest = -1
    for sweep in range(first, _SWEEPS):
        if sweep > 0 and active < 2 and active_previous < 2:
            break
        changed = False
        for i in range(aux.shape[0]):
            if sweep > 0 and lanes > 0 and aux[i, 7] != 0.0:
                at = i * SPHERE_ROWS * lanes + lane
                d, allowed = spheres[at + DISTANCE_ROW * lanes], spheres[at + ALLOWANCE_ROW * lanes]
                if d >= influence:
                    continue
                nx, ny = spheres[at + NX_ROW * lanes], spheres[at + NY_ROW * lanes]
                nz = spheres[at + NZ_ROW * lanes]
            else:
                bound, dx, dy, dz, norm = _lower_bound(aux, i, p)
                if bound >= influence and (sweep > 0 or bound >= clearance):
                    continue
                d, nx, ny, nz = _signed_distance(packed, aux, i, p, bound, dx, dy, dz, norm)
                if sweep == 0:
                    vx, vy, vz, sx, sy, sz, active, active_previous, clearance, nearest, mx, my, mz = \
                        first_sweep_obstacle(vx, vy, vz, sx, sy, sz, active, active_previous, clearance, nearest,
                                             mx, my, mz, d, nx, ny, nz, i, params, aux)
                    continue
                if d >= influence:
                    continue
                allowed = damper_allowance(d, params)
            sx, sy, sz, moved = project_damper(sx, sy, sz, nx, ny, nz, allowed)
            vx, vy, vz, hit = project_damper(vx, vy, vz, nx, ny, nz, allowed)
            changed = changed or hit or moved
        if sweep > 0 and not changed:
            break
    if active + active_previous >= 2 and clearance < influence:
        # Dampers that cannot all hold (a gap narrower than 2 d_s): the nearest obstacle's wins.
        allowed = damper_allowance(clearance, params)
        vx, vy, vz, _ = project_damper(vx, vy, vz, mx, my, mz, allowed)
        sx, sy, sz, _ = project_damper(sx, sy, sz, mx, my, mz, allowed)
    return vx, vy, vz, sx, sy, sz, active, active_previous, clearance, nearest, mx, my, mz


@njit(cache=True, inline="always")
def attraction_twist(p: np.ndarray, goal: np.ndarray, params: np.ndarray) -> tuple[float, float, float]:
    """v = soft-saturated attraction toward the goal (m/s), before obstacles."""
    vx, vy, vz = attraction(goal[0] - p[0], goal[1] - p[1], goal[2] - p[2],
                            params[ATTRACTIVE_GAIN], params[ATTRACTIVE_THRESHOLD])
    return soft_saturate(vx, vy, vz, params[MAX_LINEAR_VELOCITY])


@njit(cache=True, inline="always")
def goal_rotation(
    qx: float, qy: float, qz: float, qw: float, goal: np.ndarray, params: np.ndarray,
) -> tuple[float, float, float]:
    """ω = soft-saturated k_rot · log(q_g ⊗ q⁻¹) (rad/s)."""
    rx, ry, rz = rotation_error(qx, qy, qz, qw, goal[3], goal[4], goal[5], goal[6])
    k = params[ROTATIONAL_GAIN]
    return soft_saturate(k * rx, k * ry, k * rz, params[MAX_ANGULAR_VELOCITY])


@njit(cache=True, inline="always")
def cap_speed(vx: float, vy: float, vz: float, vmax: float) -> tuple[float, float, float]:
    """v scaled to ‖v‖ ≤ v_max: a projection that pushes away from an obstacle can add speed."""
    speed = math.sqrt(vx * vx + vy * vy + vz * vz)
    if speed > vmax:
        return vx * vmax / speed, vy * vmax / speed, vz * vmax / speed
    return vx, vy, vz


