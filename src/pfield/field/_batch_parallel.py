"""The field over many poses on every core: :func:`batch_twists` / :func:`batch_wrenches` (numba).

From :data:`PARALLEL_FROM` poses on, the poses are cut into chunks of :data:`CHUNK` that numba's threads
take (``parallel=True``); smaller batches run in a plain loop on the calling thread (waking the thread pool
costs more than it saves). Either way the threaded and the plain loop give the same bits, so a value does
not depend on the thread count or the batch size, and equals ``twist_at`` / ``wrench_at`` to rounding
(LLVM may contract a multiply-add differently in another function).

**Lanes.** The twist kernel takes :data:`LANES` poses at a time and runs the first of the damper sweeps
(``avoid``, ``src/core/field/evaluate.cpp``) obstacle by obstacle across them: a sphere's signed distance,
normal and allowed approach speed are straight-line arithmetic over the lanes, which LLVM turns into SIMD
instructions (``error_model="numpy"``: no Python zero-division check to branch on); the branchy rest
(:func:`~pfield.field._evaluate.first_sweep_obstacle`, then the later sweeps of
:func:`~pfield.field._evaluate.damper_sweeps`) runs per lane
with those values, in the same order as the one-pose kernel (equal values to rounding).
Other shapes take their exact signed distance lane by lane. A pose whose orientation equals the previous
pose's (a grid at one orientation, the default of the goal's) reuses its rotation term.

The per-chunk loops are inlined into both branches of an entry point (two copies to compile): compiled
once and called instead, they compile in 17 s rather than 43 s but run 1.7× slower (measured).

**Validation.** The kernels check and normalise each row themselves (finite position, finite nonzero
quaternion) instead of a numpy pass per check before the call, and return the first invalid row.

The entry points take the eight arrays of PackedObstacles one by one (see :mod:`pfield.field._unowned`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange

from pfield.field._evaluate import (
    ALLOWANCE_ROW,
    CIRCULATION_GAIN,
    DAMPER_GAIN,
    DISTANCE_ROW,
    INFLUENCE_DISTANCE,
    MAX_LINEAR_ACCELERATION,
    MAX_LINEAR_VELOCITY,
    NX_ROW,
    NY_ROW,
    NZ_ROW,
    SAFETY_DISTANCE,
    SPHERE_ROWS,
    _lower_bound,
    _signed_distance,
    attraction_twist,
    cap_speed,
    damper_sweeps,
    field_wrench,
    first_sweep_obstacle,
    goal_rotation,
)
from pfield.field._unowned import unowned, unowned_arrays
from pfield.field.forces import damper_speed, deflect, project_damper
from pfield.spatial import MIN_QUATERNION_NORM

__all__ = ["CHUNK", "LANES", "PARALLEL_FROM", "batch_twists", "batch_wrenches"]

CHUNK = 1024
"""Poses per task: large enough that scheduling is negligible, small enough to balance two to 64 threads."""
PARALLEL_FROM = 8192
LANES = 8
"""Poses evaluated side by side (one AVX-512 register of float64, two of AVX2)."""
_lane_damper_speed = njit(cache=True, inline="always", error_model="numpy")(damper_speed.py_func)
""":func:`~pfield.field.forces.damper_speed` itself, compiled once more for the lane loops with numpy's error
model: the Python model's zero-division check is a branch that keeps LLVM from vectorising the loop."""

# A lane block's scratch is one flat array: row r of lane j at r · LANES + j. One base pointer with constant
# offsets is what lets LLVM prove that the rows do not overlap (row views of a 2-D array need runtime
# checks, too many of them to vectorise). Rows: the damper state, then the sphere geometry.
(_VX, _VY, _VZ, _SX, _SY, _SZ, _CLEAR, _MX, _MY, _MZ, _ACT, _ACTP, _PX, _PY, _PZ,
 _EXCESS) = (LANES * r for r in range(16))
_SCRATCH = 16 * LANES
# Sweep 0's geometry of each sphere (distance, normal, allowance: SPHERE_ROWS rows of LANES) is kept in a
# second flat array for the later sweeps (damper_sweeps), up to this many obstacles (0.3 kB each); beyond, one
# sphere's rows are reused and the later sweeps recompute.
_CACHED_OBSTACLES = 4096
_D, _NX, _NY, _NZ, _ALLOW = (LANES * r for r in (DISTANCE_ROW, NX_ROW, NY_ROW, NZ_ROW, ALLOWANCE_ROW))


@njit(cache=True, inline="always")
def _unit_quaternion(qx: float, qy: float, qz: float, qw: float) -> tuple[bool, float, float, float, float]:
    """(valid, q / ‖q‖): valid when finite with a norm of at least :data:`MIN_QUATERNION_NORM`."""
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not (math.isfinite(norm) and norm >= MIN_QUATERNION_NORM):
        return False, 0.0, 0.0, 0.0, 1.0
    inverse = 1.0 / norm
    return True, qx * inverse, qy * inverse, qz * inverse, qw * inverse


@njit(cache=True, inline="always")
def _unit_row(positions: np.ndarray, orientations: np.ndarray, k: int) -> tuple[bool, float, float, float, float]:
    """(valid, unit quaternion) of row k; one orientation row serves every position."""
    p = positions[k]
    j = k if orientations.shape[0] > 1 else 0
    valid, qx, qy, qz, qw = _unit_quaternion(orientations[j, 0], orientations[j, 1], orientations[j, 2],
                                             orientations[j, 3])
    if not (valid and math.isfinite(p[0]) and math.isfinite(p[1]) and math.isfinite(p[2])):
        return False, 0.0, 0.0, 0.0, 1.0
    return True, qx, qy, qz, qw


@njit(cache=True, inline="always")
def _wrench_range(out: np.ndarray, start: int, stop: int, positions: np.ndarray, orientations: np.ndarray,
                  goal: np.ndarray, params: np.ndarray, aux: np.ndarray, packed: Any) -> int:
    for k in range(start, stop):
        valid, qx, qy, qz, qw = _unit_row(positions, orientations, k)
        if not valid:
            return k
        out[k, 0], out[k, 1], out[k, 2], out[k, 3], out[k, 4], out[k, 5] = field_wrench(
            positions[k], qx, qy, qz, qw, goal, params, packed, aux)
    return -1


@njit(cache=True, inline="always")
def _start_lanes(st: np.ndarray, out: np.ndarray, block: int, width: int, positions: np.ndarray,
                 orientations: np.ndarray, goal: np.ndarray, params: np.ndarray, previous: np.ndarray,
                 last: np.ndarray) -> int:
    """Attraction and rotation of the block's poses (ω into ``out``), the damper state reset; first bad row.

    ``last`` holds the previous pose's quaternion as given (4) and its rotation term (3): a row equal to it
    (bit for bit, so never a NaN) needs neither the check, the normalisation nor the logarithm again.
    """
    several = orientations.shape[0] > 1
    for j in range(width):
        k = block + j
        px, py, pz = positions[k, 0], positions[k, 1], positions[k, 2]
        if not (math.isfinite(px) and math.isfinite(py) and math.isfinite(pz)):
            return k
        o = k if several else 0
        ox, oy, oz, ow = orientations[o, 0], orientations[o, 1], orientations[o, 2], orientations[o, 3]
        if ox != last[0] or oy != last[1] or oz != last[2] or ow != last[3]:
            valid, qx, qy, qz, qw = _unit_quaternion(ox, oy, oz, ow)
            if not valid:
                return k
            last[0], last[1], last[2], last[3] = ox, oy, oz, ow
            last[4], last[5], last[6] = goal_rotation(qx, qy, qz, qw, goal, params)
        out[k, 3], out[k, 4], out[k, 5] = last[4], last[5], last[6]
        st[_PX + j], st[_PY + j], st[_PZ + j] = px, py, pz
        st[_VX + j], st[_VY + j], st[_VZ + j] = attraction_twist(positions[k], goal, params)
        st[_SX + j], st[_SY + j], st[_SZ + j] = previous[0], previous[1], previous[2]
        st[_CLEAR + j], st[_MX + j], st[_MY + j], st[_MZ + j] = math.inf, 0.0, 0.0, 0.0
        st[_ACT + j], st[_ACTP + j] = 0.0, 0.0
    return -1


@njit(cache=True, inline="always")
def _sphere_lanes(st: np.ndarray, geo: np.ndarray, at: int, width: int, aux: np.ndarray, i: int,
                  params: np.ndarray) -> int:
    """Signed distance, normal and allowed approach speed of sphere i at the block's points (SIMD), into
    ``geo`` from ``at``; returns how many points sit at the centre (where the normal is undefined).

    The allowance is +inf beyond the influence distance Q: with it, :func:`_sphere_sweep`'s damper steps
    change nothing, as the one-pose kernel's skip, without a branch. The trip count is a variable: LLVM's loop
    vectoriser takes such a loop, a constant one it unrolls and leaves scalar.
    """
    cx, cy, cz, radius = aux[i, 4], aux[i, 5], aux[i, 6], aux[i, 3]
    vmax = params[MAX_LINEAR_VELOCITY]  # read before the loop: loads in it could alias the stores
    influence, safety, gain = params[INFLUENCE_DISTANCE], params[SAFETY_DISTANCE], params[DAMPER_GAIN] * vmax
    accel = params[MAX_LINEAR_ACCELERATION]
    centres = 0
    for j in range(width):
        dx, dy, dz = st[_PX + j] - cx, st[_PY + j] - cy, st[_PZ + j] - cz
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        d = norm - radius
        geo[at + _D + j] = d
        centres += norm == 0.0
        inverse = 1.0 / norm  # as _signed_distance: one division
        geo[at + _NX + j], geo[at + _NY + j], geo[at + _NZ + j] = dx * inverse, dy * inverse, dz * inverse
        allowed = _lane_damper_speed(d, influence, safety, gain, vmax, accel)  # = damper_allowance(d, params)
        geo[at + _ALLOW + j] = allowed if d < influence else math.inf
    return centres


@njit(cache=True, inline="always")
def _sphere_sweep(st: np.ndarray, geo: np.ndarray, at: int, width: int, i: int, params: np.ndarray,
                  aux: np.ndarray) -> None:
    """Sphere i's part of sweep 0 at every lane, from :func:`_sphere_lanes`'s values.

    The steps of the damper sweeps' loop body: the nearest obstacle so far and the
    projection of the previous twist run over all lanes (SIMD, with selects), with the approach excess of
    the twist; :func:`~pfield.field.forces.deflect` then runs only at the lanes where the excess is positive
    (elsewhere it returns the twist unchanged; on a field sampled in space these are a few per cent, and
    its square roots and divisions would cost more in every lane than in those few).
    """
    kappa = params[CIRCULATION_GAIN]
    cx, cy, cz = aux[i, 0], aux[i, 1], aux[i, 2]
    blocked = 0  # an integer sum: a max of floats (NaN rules) would keep LLVM from vectorising
    for j in range(width):
        d, nx, ny, nz = geo[at + _D + j], geo[at + _NX + j], geo[at + _NY + j], geo[at + _NZ + j]
        allowed = geo[at + _ALLOW + j]
        nearer = d < st[_CLEAR + j]
        st[_CLEAR + j] = d if nearer else st[_CLEAR + j]
        st[_MX + j] = nx if nearer else st[_MX + j]
        st[_MY + j] = ny if nearer else st[_MY + j]
        st[_MZ + j] = nz if nearer else st[_MZ + j]
        sx, sy, sz, moved = project_damper(st[_SX + j], st[_SY + j], st[_SZ + j], nx, ny, nz, allowed)
        st[_SX + j], st[_SY + j], st[_SZ + j] = sx, sy, sz
        st[_ACTP + j] += moved
        excess = -(st[_VX + j] * nx + st[_VY + j] * ny + st[_VZ + j] * nz) - allowed
        st[_EXCESS + j] = excess
        blocked += excess > 0.0
    if blocked == 0:
        return
    for j in range(width):
        if st[_EXCESS + j] > 0.0:
            st[_VX + j], st[_VY + j], st[_VZ + j], hit = deflect(
                st[_VX + j], st[_VY + j], st[_VZ + j], geo[at + _NX + j], geo[at + _NY + j], geo[at + _NZ + j],
                cx, cy, cz, geo[at + _ALLOW + j], kappa)
            st[_ACT + j] += hit


@njit(cache=True, inline="always")
def _exact_lane(st: np.ndarray, j: int, i: int, d: float, nx: float, ny: float, nz: float,
                params: np.ndarray, aux: np.ndarray) -> None:
    """Obstacle i's part of sweep 0 at lane j from its exact signed distance d and normal n (any shape)."""
    (st[_VX + j], st[_VY + j], st[_VZ + j], st[_SX + j], st[_SY + j], st[_SZ + j], active, active_previous,
     st[_CLEAR + j], _, st[_MX + j], st[_MY + j], st[_MZ + j]) = first_sweep_obstacle(
        st[_VX + j], st[_VY + j], st[_VZ + j], st[_SX + j], st[_SY + j], st[_SZ + j], int(st[_ACT + j]),
        int(st[_ACTP + j]), st[_CLEAR + j], -1, st[_MX + j], st[_MY + j], st[_MZ + j], d, nx, ny, nz, i, params,
        aux)
    st[_ACT + j], st[_ACTP + j] = float(active), float(active_previous)


@njit(cache=True, inline="always")
def _twist_range(out: np.ndarray, start: int, stop: int, positions: np.ndarray, orientations: np.ndarray,
                 goal: np.ndarray, params: np.ndarray, aux: np.ndarray, previous: np.ndarray,
                 packed: Any) -> int:
    """Constrained twists of rows [start, stop) without rate limit, :data:`LANES` at a time; first bad row."""
    st = np.zeros(_SCRATCH)
    count = aux.shape[0]
    caching = count <= _CACHED_OBSTACLES
    geo = np.zeros(max(count if caching else 1, 1) * SPHERE_ROWS * LANES)
    last = np.full(7, math.nan)  # the previous quaternion as given and its rotation term
    influence = params[INFLUENCE_DISTANCE]
    for block in range(start, stop, LANES):
        width = min(LANES, stop - block)
        bad = _start_lanes(st, out, block, width, positions, orientations, goal, params, previous, last)
        if bad >= 0:
            return bad
        cached = LANES if caching else 0
        for i in range(count):
            if aux[i, 7] != 0.0:  # a sphere: lane-wise
                at = i * SPHERE_ROWS * LANES if caching else 0
                if _sphere_lanes(st, geo, at, width, aux, i, params) == 0:
                    _sphere_sweep(st, geo, at, width, i, params, aux)
                    continue
                cached = 0  # a point at a sphere's centre: this block's later sweeps recompute
            for j in range(width):  # other shapes, or a point at a sphere's centre: one lane at a time
                p = positions[block + j]
                bound, dx, dy, dz, norm = _lower_bound(aux, i, p)
                if bound >= influence and bound >= st[_CLEAR + j]:
                    continue
                d, nx, ny, nz = _signed_distance(packed, aux, i, p, bound, dx, dy, dz, norm)
                _exact_lane(st, j, i, d, nx, ny, nz, params, aux)
        for j in range(width):
            k = block + j
            vx, vy, vz, _, _, _, _, _, _, _, _, _, _ = damper_sweeps(
                positions[k], st[_VX + j], st[_VY + j], st[_VZ + j], st[_SX + j], st[_SY + j], st[_SZ + j],
                int(st[_ACT + j]), int(st[_ACTP + j]), st[_CLEAR + j], st[_MX + j], st[_MY + j], st[_MZ + j], 1,
                params, packed, aux, geo, j, cached)
            out[k, 0], out[k, 1], out[k, 2] = cap_speed(vx, vy, vz, params[MAX_LINEAR_VELOCITY])
    return -1


@njit(cache=True, parallel=True, error_model="numpy")
def batch_wrenches(
    positions: np.ndarray, orientations: np.ndarray, goal: np.ndarray, params: np.ndarray, aux: np.ndarray,
    kinds: np.ndarray, rows: np.ndarray, triangles: np.ndarray, pseudo_normals: np.ndarray,
    bvh_lower: np.ndarray, bvh_upper: np.ndarray, bvh_nodes: np.ndarray, mesh_table: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Raw wrenches (N, 6) at N poses (C-contiguous positions (N, 3), quaternions (N or 1, 4), normalised
    here) and, per chunk, the first invalid row (−1: none)."""
    n = positions.shape[0]
    out = np.empty((n, 6))
    if n < PARALLEL_FROM:
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        bad = np.full(1, _wrench_range(out, 0, n, unowned(positions), unowned(orientations), unowned(goal),
                                       unowned(params), unowned(aux), packed))
        return out, bad
    bad = np.empty((n + CHUNK - 1) // CHUNK, dtype=np.int64)
    for chunk in prange(bad.shape[0]):
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        bad[chunk] = _wrench_range(out, chunk * CHUNK, min(n, (chunk + 1) * CHUNK), unowned(positions),
                                   unowned(orientations), unowned(goal), unowned(params), unowned(aux), packed)
    return out, bad


@njit(cache=True, parallel=True, error_model="numpy")
def batch_twists(
    positions: np.ndarray, orientations: np.ndarray, goal: np.ndarray, params: np.ndarray, aux: np.ndarray,
    previous: np.ndarray,
    kinds: np.ndarray, rows: np.ndarray, triangles: np.ndarray, pseudo_normals: np.ndarray,
    bvh_lower: np.ndarray, bvh_upper: np.ndarray, bvh_nodes: np.ndarray, mesh_table: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Constrained twists (N, 6) at N poses without rate limit (``previous`` (6,) zeros, read only: shared)
    and, per chunk, the first invalid row (−1: none); inputs as :func:`batch_wrenches`."""
    n = positions.shape[0]
    out = np.empty((n, 6))
    if n < PARALLEL_FROM:
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        bad = np.full(1, _twist_range(out, 0, n, unowned(positions), unowned(orientations), unowned(goal),
                                      unowned(params), unowned(aux), unowned(previous), packed))
        return out, bad
    bad = np.empty((n + CHUNK - 1) // CHUNK, dtype=np.int64)
    for chunk in prange(bad.shape[0]):
        packed = unowned_arrays(kinds, rows, triangles, pseudo_normals, bvh_lower, bvh_upper, bvh_nodes, mesh_table)
        bad[chunk] = _twist_range(out, chunk * CHUNK, min(n, (chunk + 1) * CHUNK), unowned(positions),
                                  unowned(orientations), unowned(goal), unowned(params), unowned(aux),
                                  unowned(previous), packed)
    return out, bad
