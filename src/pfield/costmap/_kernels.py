"""Compiled kernels of :mod:`pfield.costmap`: exact polygon rasterisation and the FindValidPose search.

Everything here works in **cell coordinates**: a world point ``(wx, wy)`` has cell coordinates
``u = (wx - origin_x) / resolution``, ``v = (wy - origin_y) / resolution`` and lies in cell
``(floor(u), floor(v))`` — costmap_2d's ``worldToMap``. Cell ``(m, n)`` is the half-open square
``[m, m + 1) × [n, n + 1)``. Cost arrays are indexed ``costs[n, m]`` (row = y, row 0 at the bottom).

Rasterisation rule: a cell is covered by a closed polygon ``P`` when ``P ∩ cell ≠ ∅``. That holds
exactly when some edge of ``P`` (a closed segment) meets the half-open cell, or when the cell's lower-left
corner ``(m, n)`` — which belongs to the cell — lies inside ``P``: if no edge meets the cell, the cell
is either entirely inside or entirely outside ``P``. Segment/cell tests use Liang–Barsky clipping
(Liang & Barsky 1984) with strict bounds on the open sides, so axis-aligned edges on cell boundaries and
vertices on grid lines are classified exactly; crossing parameters of oblique edges are rounded floats.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

FREE_SPACE = 0
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255

STATE_FREE, STATE_INSCRIBED, STATE_LETHAL, STATE_UNKNOWN, STATE_OUTSIDE = 0, 1, 2, 3, 4
STATE_REJECTED = 5
"""Trace value: neither FREE nor INSCRIBED, not examined further because a better fallback was known."""
NOT_EVALUATED = 255
EVAL_STATE, EVAL_FULL, EVAL_FREE_ONLY = 0, 1, 2


@njit(cache=True)
def _segment_meets_cell(ax: float, ay: float, bx: float, by: float, m: int, n: int) -> bool:
    """True when the closed segment A→B meets the half-open cell [m, m+1) × [n, n+1)."""
    lo, hi = 0.0, 1.0
    lo_strict, hi_strict = False, False
    dx, dy = bx - ax, by - ay
    for axis in range(4):
        a = ax if axis < 2 else ay
        d = dx if axis < 2 else dy
        c = float(m if axis == 0 else (m + 1 if axis == 1 else (n if axis == 2 else n + 1)))
        closed_lower = axis == 0 or axis == 2  # a + t d >= c ; else a + t d < c
        if d == 0.0:
            if (closed_lower and a < c) or (not closed_lower and a >= c):
                return False
            continue
        t = (c - a) / d
        is_lower = closed_lower == (d > 0.0)
        strict = not closed_lower
        if is_lower:
            if t > lo:
                lo, lo_strict = t, strict
            elif t == lo:
                lo_strict = lo_strict or strict
        else:
            if t < hi:
                hi, hi_strict = t, strict
            elif t == hi:
                hi_strict = hi_strict or strict
    return lo < hi or (lo == hi and not lo_strict and not hi_strict)


@njit(cache=True)
def _mark_edge(mask: np.ndarray, m0: int, n0: int, ax: float, ay: float, bx: float, by: float) -> None:
    """Mark every cell the closed segment A→B meets, testing only cells near the segment row by row."""
    nlo = math.floor(min(ay, by))
    nhi = math.floor(max(ay, by))
    for n in range(nlo, nhi + 1):
        # x-range of the segment inside the closed strip n <= y <= n + 1
        if ay == by:
            xa, xb = ax, bx
        else:
            t0 = (n - ay) / (by - ay)
            t1 = (n + 1 - ay) / (by - ay)
            ta = min(max(min(t0, t1), 0.0), 1.0)
            tb = min(max(max(t0, t1), 0.0), 1.0)
            xa, xb = ax + ta * (bx - ax), ax + tb * (bx - ax)
        mlo = math.floor(min(xa, xb)) - 1
        mhi = math.floor(max(xa, xb)) + 1
        for m in range(mlo, mhi + 1):
            r, c = n - n0, m - m0
            if 0 <= r < mask.shape[0] and 0 <= c < mask.shape[1] and not mask[r, c]:
                if _segment_meets_cell(ax, ay, bx, by, m, n):
                    mask[r, c] = True


@njit(cache=True)
def _fill_interior(mask: np.ndarray, m0: int, n0: int, us: np.ndarray, vs: np.ndarray) -> None:
    """Mark cells whose lower-left corner lies inside the polygon (even-odd rule on each row line y = n)."""
    count = us.shape[0]
    crossings = np.empty(count)
    for r in range(mask.shape[0]):
        n = n0 + r
        k = 0
        for e in range(count):
            ax, ay = us[e], vs[e]
            bx, by = us[(e + 1) % count], vs[(e + 1) % count]
            if (ay <= n < by) or (by <= n < ay):
                crossings[k] = ax + (n - ay) * (bx - ax) / (by - ay)
                k += 1
        xs = np.sort(crossings[:k])
        for i in range(0, k - 1, 2):
            lo = max(math.ceil(xs[i]), m0)
            hi = min(math.floor(xs[i + 1]), m0 + mask.shape[1] - 1)
            for m in range(lo, hi + 1):
                mask[r, m - m0] = True


@njit(cache=True)
def rasterize_polygon(us: np.ndarray, vs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cells ``(m, n)`` covered by the closed polygon with vertices ``(us, vs)`` in cell coordinates."""
    m0 = math.floor(us.min())
    n0 = math.floor(vs.min())
    width = math.floor(us.max()) - m0 + 1
    height = math.floor(vs.max()) - n0 + 1
    mask = np.zeros((height, width), dtype=np.bool_)
    count = us.shape[0]
    for e in range(count):
        _mark_edge(mask, m0, n0, us[e], vs[e], us[(e + 1) % count], vs[(e + 1) % count])
    _fill_interior(mask, m0, n0, us, vs)
    rows, cols = np.nonzero(mask)
    return cols.astype(np.int64) + m0, rows.astype(np.int64) + n0


@njit(cache=True)
def build_kernels(
    px: np.ndarray, py: np.ndarray, frac_u: float, frac_v: float, yaws: np.ndarray, inv_resolution: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rasterised footprint per yaw, relative to the base cell of the requested pose.

    The footprint (vertices ``px, py`` in the robot frame, m) is rotated by each yaw and placed at the
    sub-cell offset ``(frac_u, frac_v)`` ∈ [0, 1)² of the requested position. Returns CSR arrays
    ``ptr`` (A+1,), ``dm``, ``dn`` (cell offsets) and ``box`` (A, 4) = (min dm, max dm, min dn, max dn).
    """
    count = yaws.shape[0]
    ptr = np.zeros(count + 1, dtype=np.int64)
    box = np.zeros((count, 4), dtype=np.int64)
    parts_m = []
    parts_n = []
    for a in range(count):
        c, s = math.cos(yaws[a]), math.sin(yaws[a])
        us = frac_u + (c * px - s * py) * inv_resolution
        vs = frac_v + (s * px + c * py) * inv_resolution
        cm, cn = rasterize_polygon(us, vs)
        parts_m.append(cm)
        parts_n.append(cn)
        ptr[a + 1] = ptr[a] + cm.shape[0]
        box[a, 0], box[a, 1] = cm.min(), cm.max()
        box[a, 2], box[a, 3] = cn.min(), cn.max()
    dm = np.empty(ptr[count], dtype=np.int64)
    dn = np.empty(ptr[count], dtype=np.int64)
    for a in range(count):
        dm[ptr[a]:ptr[a + 1]] = parts_m[a]
        dn[ptr[a]:ptr[a + 1]] = parts_n[a]
    return ptr, dm, dn, box


@njit(cache=True)
def evaluate_cells(costs: np.ndarray, m: int, n: int, dm: np.ndarray, dn: np.ndarray,
                   box: np.ndarray, mode: int) -> tuple[int, int]:
    """State and cost (sum of the covered in-map cells' costs) of one footprint placement.

    State precedence: OUTSIDE > LETHAL > UNKNOWN > INSCRIBED > FREE. ``mode`` EVAL_FULL sums every cell;
    EVAL_STATE stops once the state is settled (partial cost); EVAL_FREE_ONLY only asks "FREE or
    INSCRIBED?" and returns STATE_REJECTED at the first outside, lethal or unknown cell.
    """
    height, width = costs.shape
    inside = m + box[0] >= 0 and m + box[1] < width and n + box[2] >= 0 and n + box[3] < height
    outside = lethal = unknown = inscribed = False
    total = 0
    for k in range(dm.shape[0]):
        cm, cn = m + dm[k], n + dn[k]
        if not inside and (cm < 0 or cm >= width or cn < 0 or cn >= height):
            if mode == EVAL_FREE_ONLY:
                return STATE_REJECTED, total
            outside = True
            if mode == EVAL_STATE:
                break
            continue
        value = costs[cn, cm]
        total += value
        if value >= LETHAL_OBSTACLE and mode == EVAL_FREE_ONLY:
            return STATE_REJECTED, total
        if value == LETHAL_OBSTACLE:
            lethal = True
            if inside and mode == EVAL_STATE:
                break
        elif value == NO_INFORMATION:
            unknown = True
        elif value == INSCRIBED_INFLATED_OBSTACLE:
            inscribed = True
    if outside:
        return STATE_OUTSIDE, total
    if lethal:
        return STATE_LETHAL, total
    if unknown:
        return STATE_UNKNOWN, total
    if inscribed:
        return STATE_INSCRIBED, total
    return STATE_FREE, total


@njit(cache=True)
def search_rings(
    costs: np.ndarray, base_m: int, base_n: int,
    ring_ptr: np.ndarray, pos_i: np.ndarray, pos_j: np.ndarray,
    k_ptr: np.ndarray, k_dm: np.ndarray, k_dn: np.ndarray, k_box: np.ndarray,
    lethal_distance: np.ndarray, prefilter_limit: float, states: np.ndarray,
) -> np.ndarray:
    """Evaluate candidates ring by ring in answer order and stop at the first ring holding an answer.

    Candidates are (position p, yaw a); positions are grouped in rings of equal distance (``ring_ptr``)
    and sorted inside a ring by the tie-break; yaws are sorted by |Δyaw|. Inside a ring the loop order
    (a outer, p inner) is the answer order, so the first FREE candidate met is the answer and the first
    UNKNOWN / OUTSIDE met overall are the fallbacks. Prefilter: when the whole footprint is inside the
    map for every yaw and the nearest lethal cell centre is within ``prefilter_limit`` cells of the base
    cell centre, that cell meets the footprint's inscribed disc: LETHAL for every yaw.

    Once an UNKNOWN fallback is known, later candidates are only asked "FREE or INSCRIBED?" (an OUTSIDE
    one can no longer win) and may be recorded as STATE_REJECTED.
    ``states[p, a]`` receives each evaluated candidate's state. Returns int64[7]:
    (best p, best a, best state or −1, unknown p, unknown a, outside p, outside a), −1 when none.
    """
    height, width = costs.shape
    n_angles = k_ptr.shape[0] - 1
    u_lo, u_hi = k_box[:, 0].min(), k_box[:, 1].max()
    v_lo, v_hi = k_box[:, 2].min(), k_box[:, 3].max()
    result = np.full(7, -1, dtype=np.int64)
    for r in range(ring_ptr.shape[0] - 1):
        for a in range(n_angles):
            dm = k_dm[k_ptr[a]:k_ptr[a + 1]]
            dn = k_dn[k_ptr[a]:k_ptr[a + 1]]
            for p in range(ring_ptr[r], ring_ptr[r + 1]):
                m, n = base_m + pos_i[p], base_n + pos_j[p]
                if (m + u_lo >= 0 and m + u_hi < width and n + v_lo >= 0 and n + v_hi < height
                        and lethal_distance[n, m] <= prefilter_limit):
                    states[p, a] = STATE_LETHAL
                    continue
                mode = EVAL_FREE_ONLY if result[3] >= 0 else EVAL_STATE
                state, _ = evaluate_cells(costs, m, n, dm, dn, k_box[a], mode)
                states[p, a] = state
                if state == STATE_FREE:
                    result[0], result[1], result[2] = p, a, STATE_FREE
                    return result
                if state == STATE_INSCRIBED and result[2] < 0:
                    result[0], result[1], result[2] = p, a, STATE_INSCRIBED
                elif state == STATE_UNKNOWN and result[3] < 0:
                    result[3], result[4] = p, a
                elif state == STATE_OUTSIDE and result[5] < 0:
                    result[5], result[6] = p, a
        if result[2] >= 0:
            return result
    return result


@njit(cache=True)
def resample_occupancy(data: np.ndarray, origin_u: float, origin_v: float, scale: float,
                       size_x: int, size_y: int) -> np.ndarray:
    """Window of an occupancy grid on another grid, each new cell taking the worst cell it overlaps.

    The new grid's cell (i, j) spans source cell coordinates [origin_u + i·scale, origin_u + (i+1)·scale)
    (same in v). Worst: occupied (≥ 100 after ranking) > unknown (−1) > highest free value. Cells not
    overlapping the source are unknown (−1).
    """
    height, width = data.shape
    out = np.full((size_y, size_x), -1, dtype=np.int8)
    for j in range(size_y):
        v0 = origin_v + j * scale
        n_lo = max(math.floor(v0), 0)
        n_hi = min(math.ceil(v0 + scale) - 1, height - 1)
        for i in range(size_x):
            u0 = origin_u + i * scale
            m_lo = max(math.floor(u0), 0)
            m_hi = min(math.ceil(u0 + scale) - 1, width - 1)
            if n_lo > n_hi or m_lo > m_hi:
                continue
            worst = -2
            for n in range(n_lo, n_hi + 1):
                for m in range(m_lo, m_hi + 1):
                    value = data[n, m]
                    rank = 1000 if value < 0 else value
                    if value >= 100:
                        rank = 2000
                    if rank > worst:
                        worst = rank
            out[j, i] = -1 if worst == 1000 else (100 if worst == 2000 else worst)
    return out
