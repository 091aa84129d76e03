"""Covering points by capsules, compiled: the greedy set cover of :func:`pfield.robot._fit.fit_primitives`, the
union depth its measures need, the inside test of a convex hull and the Bădoiu–Clarkson circle.

A capsule (segment a–b, radius r) contains a point p when ``|p − (a + t·d)|² ≤ r²`` with ``d = b − a`` and
``t = clamp((p − a)·d / |d|², 0, 1)`` (t = 0 for a sphere). Every containment test here evaluates that
expression in the same order (:func:`_contains`), so a point on the boundary is decided the same way by the
greedy cover and by the dense :func:`coverage`.

The cover is Chvátal's greedy (1979): repeatedly pick the candidate containing the most points not yet
covered, ties to the lowest index. Gains only shrink as points get covered, so a stale gain is an upper bound,
and lazy evaluation (Minoux 1978) picks exactly the same candidates: keep the candidates in a max-heap of
(key, −index) where every key bounds the candidate's gain, count the top one, and take it when its count still
comes before the runner-up's key; else its count becomes its key. The first keys are the points in each
capsule's bounding box. Points are bucketed in a uniform grid of cubes (:func:`cell_side`); a count visits the
cells of the capsule's bounding box that still hold uncovered points, takes a cell lying inside the capsule
whole, skips one outside and tests the points of the others. No (candidates × points) matrix is built
(30 000 × 25 000 for the UR5's 20 000-vertex force-torque sensor mesh, which the numpy greedy loop re-reduced
at every pick: 46 of the UR5's 61 s of fitting).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["coverage", "enclosing_circle", "greedy_cover", "inside_hull", "min_depth"]

_GRID_CELLS = 64  # at most this many cells along the longest axis of the points' bounding box
_PAD = 1e-9  # m added to a capsule's bounding box, so that rounding never leaves out a point it contains


@njit(cache=True, inline="always")
def _axis(a, b):  # type: ignore[no-untyped-def]
    """(d, |d|²) of the segment a–b, d = b − a: the per-capsule part of :func:`_contains`."""
    dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    return dx, dy, dz, dx * dx + dy * dy + dz * dz


@njit(cache=True, inline="always")
def _contains(ax, ay, az, dx, dy, dz, length2, r2, points, n):  # type: ignore[no-untyped-def]
    """Whether the capsule from (ax, ay, az) along (dx, dy, dz) with squared radius r2 contains ``points[n]``
    (module docstring)."""
    px, py, pz = points[n, 0] - ax, points[n, 1] - ay, points[n, 2] - az
    t = 0.0 if length2 == 0.0 else min(max((px * dx + py * dy + pz * dz) / length2, 0.0), 1.0)
    ex, ey, ez = px - t * dx, py - t * dy, pz - t * dz
    return ex * ex + ey * ey + ez * ez <= r2


@njit(cache=True)
def coverage(a, b, radii, points):  # type: ignore[no-untyped-def]
    """(K, N) booleans: capsule k (segment a_k–b_k, radius r_k) contains point n."""
    covered = np.zeros((a.shape[0], points.shape[0]), dtype=np.bool_)
    for k in range(a.shape[0]):
        dx, dy, dz, length2 = _axis(a[k], b[k])
        r2 = radii[k] * radii[k]
        for n in range(points.shape[0]):
            covered[k, n] = _contains(a[k, 0], a[k, 1], a[k, 2], dx, dy, dz, length2, r2, points, n)
    return covered


@njit(cache=True)
def _grid(points, cell):  # type: ignore[no-untyped-def]
    """Points bucketed by cube cells of side ``cell``: (lower corner (3,), cells per axis (3,), the start of each
    cell's run (C + 1,) in the points sorted by cell (N, 3))."""
    lower = np.empty(3)
    dims = np.empty(3, dtype=np.int64)
    for axis in range(3):
        lower[axis] = points[:, axis].min()
        dims[axis] = int((points[:, axis].max() - lower[axis]) / cell) + 1
    cells = np.empty(points.shape[0], dtype=np.int64)
    for n in range(points.shape[0]):
        ix = min(int((points[n, 0] - lower[0]) / cell), dims[0] - 1)
        iy = min(int((points[n, 1] - lower[1]) / cell), dims[1] - 1)
        iz = min(int((points[n, 2] - lower[2]) / cell), dims[2] - 1)
        cells[n] = ix + dims[0] * (iy + dims[1] * iz)
    starts = np.zeros(dims[0] * dims[1] * dims[2] + 1, dtype=np.int64)
    for n in range(points.shape[0]):
        starts[cells[n] + 1] += 1
    for c in range(1, starts.shape[0]):
        starts[c] += starts[c - 1]
    ordered = np.empty_like(points)
    fill = starts[:-1].copy()
    for n in range(points.shape[0]):
        ordered[fill[cells[n]]] = points[n]
        fill[cells[n]] += 1
    return lower, dims, starts, ordered


@njit(cache=True)
def _cell_box(a, b, radius, lower, cell, dims):  # type: ignore[no-untyped-def]
    """The range of cells (lo_x, lo_y, lo_z, hi_x, hi_y, hi_z, inclusive) of the capsule's bounding box."""
    reach = radius + _PAD
    lx = max(math.floor((min(a[0], b[0]) - reach - lower[0]) / cell), 0)
    ly = max(math.floor((min(a[1], b[1]) - reach - lower[1]) / cell), 0)
    lz = max(math.floor((min(a[2], b[2]) - reach - lower[2]) / cell), 0)
    hx = min(math.floor((max(a[0], b[0]) + reach - lower[0]) / cell), dims[0] - 1)
    hy = min(math.floor((max(a[1], b[1]) + reach - lower[1]) / cell), dims[1] - 1)
    hz = min(math.floor((max(a[2], b[2]) + reach - lower[2]) / cell), dims[2] - 1)
    return lx, ly, lz, hx, hy, hz


@njit(cache=True)
def _box_sums(starts, dims):  # type: ignore[no-untyped-def]
    """Summed-volume table (X + 1, Y + 1, Z + 1) of the points per cell: any box's count in O(1)."""
    table = np.zeros((dims[0] + 1, dims[1] + 1, dims[2] + 1), dtype=np.int64)
    for iz in range(dims[2]):
        for iy in range(dims[1]):
            for ix in range(dims[0]):
                c = ix + dims[0] * (iy + dims[1] * iz)
                table[ix + 1, iy + 1, iz + 1] = (
                    starts[c + 1] - starts[c] + table[ix, iy + 1, iz + 1] + table[ix + 1, iy, iz + 1]
                    + table[ix + 1, iy + 1, iz] - table[ix, iy, iz + 1] - table[ix, iy + 1, iz]
                    - table[ix + 1, iy, iz] + table[ix, iy, iz])
    return table


@njit(cache=True)
def _box_count(table, lx, ly, lz, hx, hy, hz):  # type: ignore[no-untyped-def]
    if lx > hx or ly > hy or lz > hz:
        return 0
    return (table[hx + 1, hy + 1, hz + 1] - table[lx, hy + 1, hz + 1] - table[hx + 1, ly, hz + 1]
            - table[hx + 1, hy + 1, lz] + table[lx, ly, hz + 1] + table[lx, hy + 1, lz] + table[hx + 1, ly, lz]
            - table[lx, ly, lz])


@njit(cache=True, inline="always")
def _cell_side(ax, ay, az, dx, dy, dz, length2, radius, lower, cell, ix, iy, iz):  # type: ignore[no-untyped-def]
    """Where cell (ix, iy, iz) lies for the capsule: 1 inside, −1 outside (both by more than :data:`_PAD`, so
    that :func:`_contains` would say the same of every point in it), 0 across its surface."""
    px = lower[0] + (ix + 0.5) * cell - ax
    py = lower[1] + (iy + 0.5) * cell - ay
    pz = lower[2] + (iz + 0.5) * cell - az
    t = 0.0 if length2 == 0.0 else min(max((px * dx + py * dy + pz * dz) / length2, 0.0), 1.0)
    ex, ey, ez = px - t * dx, py - t * dy, pz - t * dz
    centre = math.sqrt(ex * ex + ey * ey + ez * ez)
    half = 0.8660254037844387 * cell  # half the cell's diagonal: its points are this close to its centre
    if centre + half <= radius - _PAD:
        return 1
    if centre - half > radius + _PAD:
        return -1
    return 0


_BOUND, _COUNT, _CLAIM = 0, 1, 2  # what _scan does


@njit(cache=True)
def _scan(a, b, radius, box, points, uncovered, left, row_left, starts, lower, cell, dims,  # type: ignore[no-untyped-def]
          mode):
    """Over the cells of the capsule's bounding ``box`` that still hold uncovered points (``left``, and
    ``row_left`` per row of cells along x):
    ``_BOUND`` sums those points in the cells not outside the capsule (an upper bound of its gain);
    ``_COUNT`` counts the uncovered points (cell-sorted) it contains; ``_CLAIM`` also marks them covered.
    Cells inside the capsule count whole; only the cells across its surface test their points."""
    lx, ly, lz, hx, hy, hz = box
    dx, dy, dz, length2 = _axis(a, b)
    ax, ay, az, r2 = a[0], a[1], a[2], radius * radius
    count = 0
    for iz in range(lz, hz + 1):
        for iy in range(ly, hy + 1):
            if row_left[iy + dims[1] * iz] == 0:
                continue
            row = dims[0] * (iy + dims[1] * iz)
            for ix in range(lx, hx + 1):
                c = row + ix
                if left[c] == 0:
                    continue
                side = _cell_side(ax, ay, az, dx, dy, dz, length2, radius, lower, cell, ix, iy, iz)
                if side < 0:
                    continue
                if mode == _BOUND or (side > 0 and mode == _COUNT):
                    count += left[c]
                    continue
                if side > 0:
                    uncovered[starts[c]:starts[c + 1]] = False
                    count += left[c]
                    row_left[iy + dims[1] * iz] -= left[c]
                    left[c] = 0
                    continue
                for m in range(starts[c], starts[c + 1]):
                    if uncovered[m] and _contains(ax, ay, az, dx, dy, dz, length2, r2, points, m):
                        count += 1
                        if mode == _CLAIM:
                            uncovered[m] = False
                            left[c] -= 1
                            row_left[iy + dims[1] * iz] -= 1
    return count


@njit(cache=True, inline="always")
def _above(gains, i, j):  # type: ignore[no-untyped-def]
    """Heap order: candidate i before j when it gains more, or as much with a lower index."""
    return gains[i] > gains[j] or (gains[i] == gains[j] and i < j)


@njit(cache=True, inline="always")
def _above_with(value, k, gains, j):  # type: ignore[no-untyped-def]
    """Heap order with a new key: candidate k gaining ``value`` comes before candidate j."""
    return value > gains[j] or (value == gains[j] and k < j)


@njit(cache=True, inline="always")  # one specialisation: compiled into greedy_cover, not for each call's types
def _sift_down(heap, size, slot, gains):  # type: ignore[no-untyped-def]
    while True:
        top, left, right = slot, 2 * slot + 1, 2 * slot + 2
        if left < size and _above(gains, heap[left], heap[top]):
            top = left
        if right < size and _above(gains, heap[right], heap[top]):
            top = right
        if top == slot:
            return
        heap[slot], heap[top] = heap[top], heap[slot]
        slot = top


@njit(cache=True)
def greedy_cover(a, b, radii, points, cell):  # type: ignore[no-untyped-def]
    """Indices of the capsules Chvátal's greedy set cover picks to contain every point, in picking order (the
    module docstring); ``cell`` is the grid's cell side (m). Every point must lie in some capsule.

    The first keys are the point counts of each capsule's bounding box (upper bounds, O(1) each from a
    summed-volume table). The top candidate is counted against the runner-up's key: counted out, it is the
    argmax (every key bounds its candidate's gain); once it cannot win, its key becomes the bound reached."""
    lower, dims, starts, ordered = _grid(points, cell)
    left = starts[1:] - starts[:-1]  # uncovered points per cell
    row_left = left.reshape(-1, dims[0]).sum(axis=1)  # and per row of cells along x
    table = _box_sums(starts, dims)
    boxes = np.empty((a.shape[0], 6), dtype=np.int64)
    gains = np.empty(a.shape[0], dtype=np.int64)
    for k in range(a.shape[0]):
        lx, ly, lz, hx, hy, hz = _cell_box(a[k], b[k], radii[k], lower, cell, dims)
        boxes[k, 0], boxes[k, 1], boxes[k, 2], boxes[k, 3], boxes[k, 4], boxes[k, 5] = lx, ly, lz, hx, hy, hz
        gains[k] = _box_count(table, lx, ly, lz, hx, hy, hz)
    uncovered = np.ones(points.shape[0], dtype=np.bool_)
    heap = np.arange(a.shape[0])
    size = heap.shape[0]
    for slot in range(size // 2 - 1, -1, -1):
        _sift_down(heap, size, slot, gains)
    remaining = points.shape[0]
    chosen = []
    while remaining > 0 and size > 0:
        k = heap[0]
        rival = -1  # the runner-up: the root's larger child
        if size > 1:
            rival = heap[1] if size == 2 or _above(gains, heap[1], heap[2]) else heap[2]
        box = (boxes[k, 0], boxes[k, 1], boxes[k, 2], boxes[k, 3], boxes[k, 4], boxes[k, 5])
        grid = (ordered, uncovered, left, row_left, starts, lower, cell, dims)
        value = _scan(a[k], b[k], radii[k], box, *grid, _BOUND)
        if rival < 0 or _above_with(value, k, gains, rival):  # it may still win: count it
            value = _scan(a[k], b[k], radii[k], box, *grid, _COUNT)
            if rival < 0 or _above_with(value, k, gains, rival):  # the argmax: every key bounds its gain
                if value == 0:  # no candidate contains the points left (only a caller's error)
                    break
                remaining -= _scan(a[k], b[k], radii[k], box, *grid, _CLAIM)
                chosen.append(k)
                size -= 1
                heap[0] = heap[size]
                _sift_down(heap, size, 0, gains)
                continue
        gains[k] = min(value, gains[k])
        _sift_down(heap, size, 0, gains)
    return np.array(chosen, dtype=np.int64)


@njit(cache=True)
def min_depth(a, b, radii, points, skip):  # type: ignore[no-untyped-def]
    """(N,): min over capsules k ≠ ``skip`` of dist(point, segment a_k–b_k) − r_k (≤ 0: inside the union; +inf
    when there is no other capsule)."""
    depth = np.full(points.shape[0], np.inf)
    for k in range(a.shape[0]):
        if k == skip:
            continue
        dx, dy, dz = b[k, 0] - a[k, 0], b[k, 1] - a[k, 1], b[k, 2] - a[k, 2]
        length2 = dx * dx + dy * dy + dz * dz
        for n in range(points.shape[0]):
            t = 0.0
            if length2 != 0.0:
                t = min(max(((points[n, 0] - a[k, 0]) * dx + (points[n, 1] - a[k, 1]) * dy
                             + (points[n, 2] - a[k, 2]) * dz) / length2, 0.0), 1.0)
            ex = points[n, 0] - (a[k, 0] + t * dx)
            ey = points[n, 1] - (a[k, 1] + t * dy)
            ez = points[n, 2] - (a[k, 2] + t * dz)
            depth[n] = min(depth[n], math.sqrt(ex * ex + ey * ey + ez * ez) - radii[k])
    return depth


@njit(cache=True, inline="always")
def _within(equations, points, n, tolerance):  # type: ignore[no-untyped-def]
    """Whether ``points[n]`` satisfies every facet inequality n·x + c ≤ ``tolerance``."""
    for f in range(equations.shape[0]):
        if (equations[f, 0] * points[n, 0] + equations[f, 1] * points[n, 1] + equations[f, 2] * points[n, 2]
                + equations[f, 3] > tolerance):
            return False
    return True


@njit(cache=True)
def inside_hull(equations, inner, points, tolerance):  # type: ignore[no-untyped-def]
    """(N,) booleans: the point satisfies every facet inequality n·x + c ≤ ``tolerance`` of a convex hull
    (``scipy.spatial.ConvexHull.equations``, outward unit normals).

    ``inner``: the facets of the hull of some of its vertices, a polytope inside it with fewer facets (the
    UR5's force-torque sensor: 8184 facets, 500 inside). A point inside that one (tolerance 0) is inside the
    hull; only the others are tested against every facet."""
    inside = np.ones(points.shape[0], dtype=np.bool_)
    for n in range(points.shape[0]):
        if not _within(inner, points, n, 0.0):
            inside[n] = _within(equations, points, n, tolerance)
    return inside


@njit(cache=True)
def enclosing_circle(points, iterations):  # type: ignore[no-untyped-def]
    """Approximate centre of the smallest ball (any dimension) enclosing ``points`` (N, D): Bădoiu–Clarkson,
    ``c ← c + (p_far − c)/(k + 1)`` for k = 1 … ``iterations`` from the bounding box's centre."""
    dimension = points.shape[1]
    centre = np.empty(dimension)
    for axis in range(dimension):
        centre[axis] = 0.5 * (points[:, axis].min() + points[:, axis].max())
    for k in range(1, iterations + 1):
        far, farthest = 0, -1.0
        for n in range(points.shape[0]):
            distance2 = 0.0
            for axis in range(dimension):
                offset = points[n, axis] - centre[axis]
                distance2 += offset * offset
            if math.sqrt(distance2) > farthest:  # the first farthest point, as numpy's argmax of the norms
                far, farthest = n, math.sqrt(distance2)
        for axis in range(dimension):
            centre[axis] = centre[axis] + (points[far, axis] - centre[axis]) / (k + 1)
    return centre


def cell_side(points: NDArray[np.float64], smallest: float) -> float:
    """The grid cell side (m) for :func:`greedy_cover`: half ``smallest`` (the least candidate radius; the
    fastest on the UR5's gripper meshes) unless the points' extent would then need more than 64 cells along
    an axis."""
    extent = float(np.max(points.max(axis=0) - points.min(axis=0))) if len(points) else 0.0
    return max(smallest / 2, extent / _GRID_CELLS, 1e-6)
