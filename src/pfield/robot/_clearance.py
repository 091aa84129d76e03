"""Compiled clearances of the two-level link model: link–obstacle and link–link (self) distances.

Each link l has a bounding capsule (``cap_a[l]``–``cap_b[l]``, ``cap_r[l]``, containing everything below)
and its fitted primitives ``link_start[l]:link_start[l + 1]`` (:mod:`pfield.robot.geometry`); ``self_r[l]``
is the radius of the ungrown covering capsule, used for self-collision (:func:`link_pair_distance`). Near
(bounding capsules closer than ``FINE_RANGE`` = 10 cm) a distance is the minimum over the link's
primitives; farther, the bounding capsules' own distance stands for it
(a lower bound, at most the capsules' over-approximation off, where a few centimetres do not matter and the
cost of the fine model would be wasted). A pair whose cheap bound is ≥ ``cutoff`` gets that bound instead
and is reported as not exact (no closer than it).
Segment ends are in the world frame (:func:`world_segments`). The closest point returned is on the
primitive's segment (its axis), where the kernels take the point Jacobian; ``n`` points from the obstacle
(or from the second link) towards the link.

The compiled core holds the same functions (``src/core/robot/clearance``, bound as
:mod:`pfield._core.robot_distance`), bit for bit (tests/robot/test_core_distance.py), and computes the clearances
Python asks for (:func:`pfield.robot.collision.capsule_clearances`, the planners' start offsets); these numba twins
remain for the numba kernels that still inline them (the whole-body step, the assistance, the RRT's state check).
"""

from __future__ import annotations

import math

from numba import njit

from pfield.geometry._packed import CAPSULE, SPHERE
from pfield.geometry._sdf import row_signed_distance
from pfield.robot._distance import (
    closest_segment_points_xyz,
    point_segment_distance_xyz,
    segment_row_distance_xyz,
)

FINE_RANGE = 0.1  # m: pairs whose bounding capsules are at least this far apart use the capsules' distance


@njit(cache=True, inline="always")
def world_segments(rotations, origins, joints, a, b, out_a, out_b):  # type: ignore[no-untyped-def]
    """World ends of every segment (local ends ``a``, ``b`` carried by ``joints``) into ``out_a``, ``out_b``."""
    world_segment_range(rotations, origins, joints, a, b, out_a, out_b, 0, joints.shape[0])


@njit(cache=True, inline="always")
def world_segment_range(rotations, origins, joints, a, b, out_a, out_b, start, stop):  # type: ignore[no-untyped-def]
    """:func:`world_segments` for the segments ``start:stop`` (joint −1: the base frame, ends copied).

    Scalar indexing only, and no helper call per segment: a compiled call that takes arrays (an array view
    too) updates their reference counts atomically, which cost 12x the transform itself (164 segments:
    10 µs through a per-segment helper, 0.86 µs written out here)."""
    for c in range(start, stop):
        j = joints[c]
        if j < 0:
            for k in range(3):
                out_a[c, k], out_b[c, k] = a[c, k], b[c, k]
            continue
        for k in range(3):
            r0, r1, r2, o = rotations[j, k, 0], rotations[j, k, 1], rotations[j, k, 2], origins[j, k]
            out_a[c, k] = r0 * a[c, 0] + r1 * a[c, 1] + r2 * a[c, 2] + o
            out_b[c, k] = r0 * b[c, 0] + r1 * b[c, 1] + r2 * b[c, 2] + o


@njit(cache=True, inline="always")
def capsule_lower_bound(centres, bounds, i, cap_a, cap_b, cap_r, link):  # type: ignore[no-untyped-def]
    """‖c_i − segment‖ − reach_i − r: the cheap lower bound of link ``link``'s clearance to obstacle ``i``
    (its bounding sphere against the link's bounding capsule), read in scalars (no array views)."""
    return point_segment_distance_xyz(centres[i, 0], centres[i, 1], centres[i, 2], cap_a[link, 0], cap_a[link, 1],
                                      cap_a[link, 2], cap_b[link, 0], cap_b[link, 1], cap_b[link, 2]) \
        - bounds[i] - cap_r[link]


FINE_MARGIN = 1e-6
"""(m) slack of :func:`near_segments`' test against rounding: a link's primitives are moved into the world
frame when its bounding capsule's lower bound is below ``FINE_RANGE + FINE_MARGIN``."""


@njit(cache=True, inline="always")
def near_segments(  # type: ignore[no-untyped-def]
        rotations, origins, cap_a, cap_b, cap_r, link_start, prim_joint, prim_a, prim_b, centres, bounds, out_a, out_b):
    """World ends of the fitted primitives of the links that may reach the fine level, into ``out_a``/``out_b``.

    ``cap_a``/``cap_b`` are the bounding capsules' world ends. A link's primitives are read by
    :func:`link_obstacle_distance` only when its bounding capsule is closer than ``FINE_RANGE`` to an obstacle,
    so only links whose cheap bound ‖c_i − segment‖ − reach_i − r is below it (plus :data:`FINE_MARGIN`) are
    transformed; the others keep stale values that nothing reads. Without obstacles nothing is transformed.
    """
    for link in range(cap_r.shape[0]):
        near = False
        for i in range(bounds.shape[0]):
            if capsule_lower_bound(centres, bounds, i, cap_a, cap_b, cap_r, link) < FINE_RANGE + FINE_MARGIN:
                near = True
                break
        if near:
            world_segment_range(rotations, origins, prim_joint, prim_a, prim_b, out_a, out_b, link_start[link],
                                link_start[link + 1])


@njit(cache=True, inline="always")
def link_obstacle_distance(  # type: ignore[no-untyped-def]
        link, i, kinds, rows, meshes, centres, bounds, cap_a, cap_b, cap_r, link_start, prim_a, prim_b, prim_r,
        scratch, cutoff):
    """Signed clearance (m) of ``link`` to obstacle ``i``: ``(d, exact, px, py, pz, nx, ny, nz)``.

    ``kinds``, ``rows`` and ``meshes`` (:func:`~pfield.geometry._sdf.mesh_addresses`) are the packed
    obstacles' arrays, read once by the caller (each member read of a ``PackedObstacles`` is a reference-count
    update). ``exact`` is False when the bounding capsule's bound (returned as ``d``) is ≥ ``cutoff``; callers
    in loops over many pairs test that bound first themselves (:func:`capsule_lower_bound`, in scalars).
    """
    return link_obstacle_distance_below(link, i, kinds, rows, meshes, centres, bounds, cap_a, cap_b, cap_r,
                                        link_start, prim_a, prim_b, prim_r, scratch, cutoff, math.inf)


@njit(cache=True, inline="always")
def link_obstacle_distance_below(  # type: ignore[no-untyped-def]
        link, i, kinds, rows, meshes, centres, bounds, cap_a, cap_b, cap_r, link_start, prim_a, prim_b, prim_r,
        scratch, cutoff, fine_cutoff):
    """:func:`link_obstacle_distance` for callers that need exact values only below ``fine_cutoff`` (≤ ``cutoff``).

    The fine level is skipped when the bounding capsule (which contains every primitive) is already at least
    ``fine_cutoff`` away: the pair gets the capsule's distance and ``exact`` False. Otherwise it skips every
    primitive whose bound exceeds ``fine_cutoff``; when that leaves none, the pair gets ``fine_cutoff`` (a lower
    bound: every primitive is farther) and ``exact`` False. Values below ``fine_cutoff`` are those of
    :func:`link_obstacle_distance`, bit for bit; a pair at least ``fine_cutoff`` away gets some value at least
    ``fine_cutoff`` (a primitive's own distance, with ``exact`` True, may stand for it): callers read it only as
    "not below the cutoff".

    The two levels are :func:`capsule_level_distance` and :func:`fitted_distance_below`; loops over many pairs
    call those two themselves (see the latter for why).
    """
    lower = capsule_lower_bound(centres, bounds, i, cap_a, cap_b, cap_r, link)
    if lower >= cutoff:
        return lower, False, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
    d, exact, px, py, pz, nx, ny, nz = capsule_level_distance(
        kinds, rows, meshes, i, cap_a[link, 0], cap_a[link, 1], cap_a[link, 2], cap_b[link, 0], cap_b[link, 1],
        cap_b[link, 2], cap_r[link], scratch)
    if exact or d >= fine_cutoff:
        return d, exact, px, py, pz, nx, ny, nz
    return fitted_distance_below(kinds, rows, meshes, i, centres[i, 0], centres[i, 1], centres[i, 2], bounds[i],
                                 link_start[link], link_start[link + 1], prim_a, prim_b, prim_r, scratch, fine_cutoff)


@njit(cache=True, inline="always")
def capsule_level_distance(kinds, rows, meshes, i, cax, cay, caz, cbx, cby, cbz, radius, scratch):  # type: ignore[no-untyped-def]
    """The coarse level of a link–obstacle pair: the link's bounding capsule (axis a–b, ``radius``, in scalars)
    against obstacle ``i``, as ``(d, exact, px, py, pz, nx, ny, nz)``.

    At ``FINE_RANGE`` or farther the capsule's distance stands for the pair (``exact`` True, the closest point
    on the capsule's axis); nearer, ``exact`` is False and ``d`` is a lower bound of the fitted primitives'
    distance, which :func:`fitted_distance_below` gives."""
    d, t, nx, ny, nz = segment_row_distance_xyz(kinds, rows, meshes, i, cax, cay, caz, cbx, cby, cbz, scratch)
    d -= radius
    if d >= FINE_RANGE:  # far: the bounding capsule's distance (a lower bound of the fitted model's)
        return d, True, cax + t * (cbx - cax), cay + t * (cby - cay), caz + t * (cbz - caz), nx, ny, nz
    return d, False, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0


@njit(cache=True, inline="always")
def fitted_distance_below(  # type: ignore[no-untyped-def]
        kinds, rows, meshes, i, cx, cy, cz, reach, start, stop, prim_a, prim_b, prim_r, scratch, fine_cutoff):
    """The fine level of a link–obstacle pair: the minimum over the link's fitted primitives ``start:stop``
    (world ends ``prim_a``/``prim_b``, radii ``prim_r``) of their distance to obstacle ``i`` (bounding sphere:
    centre (cx, cy, cz), radius ``reach``), as in :func:`link_obstacle_distance_below`: exact below
    ``fine_cutoff``, else a value at least ``fine_cutoff``.

    Loops over every pair call :func:`capsule_level_distance` and then this for the near ones, rather than
    :func:`link_obstacle_distance_below`: an inlined call that takes many arrays and branches to several
    returns keeps an atomic reference-count update per array on every call (numba cannot pair them away),
    so calling it for every pair cost more than the distances (xArm7 among 5 spheres with a 1 m influence
    distance: 40 pairs a step, 7.5 of them near; the pairs' distances 6.7 µs a step that way, 2.8 µs so)."""
    best, px, py, pz, bx, by, bz = math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
    round_obstacle = kinds[i] == SPHERE or kinds[i] == CAPSULE
    # nothing whose lower bound exceeds ``limit`` can be the minimum: the best exact value so far, or an upper
    # bound: a segment's midpoint is one of its points, so d(mid_p) − r_p ≥ the minimum
    limit = fine_cutoff
    for p in range(start, stop):
        # cheap bounds first, in scalars (an array view per primitive costs more than the bound)
        ax, ay, az = prim_a[p, 0], prim_a[p, 1], prim_a[p, 2]
        ex, ey, ez = prim_b[p, 0] - ax, prim_b[p, 1] - ay, prim_b[p, 2] - az
        length2 = ex * ex + ey * ey + ez * ez
        ox, oy, oz = cx - ax, cy - ay, cz - az
        u = 0.0 if length2 <= 1e-14 else min(max((ox * ex + oy * ey + oz * ez) / length2, 0.0), 1.0)
        fx, fy, fz = ox - u * ex, oy - u * ey, oz - u * ez
        if math.sqrt(fx * fx + fy * fy + fz * fz) - reach - prim_r[p] > limit:
            continue
        if not round_obstacle:
            # a signed distance is 1-Lipschitz: d(s(t)) ≥ d(midpoint) − half the segment's length; and the
            # midpoint's own value bounds the minimum from above
            middle = row_signed_distance(kinds, rows, meshes, i, ax + 0.5 * ex, ay + 0.5 * ey, az + 0.5 * ez,
                                         math.inf)[0] - prim_r[p]
            limit = min(limit, middle)
            if middle - 0.5 * math.sqrt(length2) > limit:
                continue
        # in scalars: no array view or array-taking call per primitive (closed forms for spheres, capsules, boxes)
        d, t, nx, ny, nz = segment_row_distance_xyz(kinds, rows, meshes, i, ax, ay, az, prim_b[p, 0], prim_b[p, 1],
                                                    prim_b[p, 2], scratch)
        d -= prim_r[p]
        if d < best:
            best, bx, by, bz = d, nx, ny, nz
            px, py, pz = ax + t * ex, ay + t * ey, az + t * ez
            limit = min(limit, best)
    if best == math.inf and fine_cutoff < math.inf:
        return fine_cutoff, False, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
    return best, True, px, py, pz, bx, by, bz


@njit(cache=True, inline="always")
def link_pair_distance(l1, l2, cap_a, cap_b, self_r):  # type: ignore[no-untyped-def]
    """Clearance (m) between links ``l1`` and ``l2`` on their covering capsules (radii ``self_r``):
    ``(d, p1 (3), p2 (3))``, p1/p2 the closest points of the two segments.

    Self-collision uses the single covering capsule of each link (it contains the link's collision surface):
    the SRDF leaves only links that are not close by design, and the fitted primitives would cost about a
    hundred segment pairs per link pair for every step.
    """
    # scalars only (see point_segment_distance_xyz): this runs for every self pair at every step
    a1x, a1y, a1z, b1x, b1y, b1z = cap_a[l1, 0], cap_a[l1, 1], cap_a[l1, 2], cap_b[l1, 0], cap_b[l1, 1], cap_b[l1, 2]
    a2x, a2y, a2z, b2x, b2y, b2z = cap_a[l2, 0], cap_a[l2, 1], cap_a[l2, 2], cap_b[l2, 0], cap_b[l2, 1], cap_b[l2, 2]
    s, t = closest_segment_points_xyz(a1x, a1y, a1z, b1x, b1y, b1z, a2x, a2y, a2z, b2x, b2y, b2z)
    x1, y1, z1 = a1x + s * (b1x - a1x), a1y + s * (b1y - a1y), a1z + s * (b1z - a1z)
    x2, y2, z2 = a2x + t * (b2x - a2x), a2y + t * (b2y - a2y), a2z + t * (b2z - a2z)
    d = math.sqrt((x1 - x2) ** 2 + (y1 - y2) ** 2 + (z1 - z2) ** 2) - self_r[l1] - self_r[l2]
    return d, x1, y1, z1, x2, y2, z2
