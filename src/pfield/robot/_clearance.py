"""Compiled clearances of the two-level link model: link–obstacle and link–link (self) distances.

Each link l has a bounding capsule (``cap_a[l]``–``cap_b[l]``, ``cap_r[l]``, containing everything below)
and its fitted primitives ``link_start[l]:link_start[l + 1]`` (:mod:`pfield.robot.geometry`). A distance
is the minimum over the link's primitives (over primitive pairs for two links), and the bounding capsules
cull: a pair whose bound is ≥ ``cutoff`` gets that bound instead (no closer than it, never exact).
Segment ends are in the world frame (:func:`world_segments`). The closest point returned is on the
primitive's segment (its axis), where the kernels take the point Jacobian; ``n`` points from the obstacle
(or from the second link) towards the link.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pfield.geometry._packed import CAPSULE, SPHERE
from pfield.geometry._sdf import obstacle_signed_distance
from pfield.robot._distance import (
    closest_segment_points,
    point_segment_distance,
    round_segment_distance,
    segment_obstacle_distance,
    segment_segment_distance,
)
from pfield.robot._kinematics import joint_transforms, transform_point_into


@njit(cache=True, inline="always")
def world_segments(rotations, origins, joints, a, b, out_a, out_b):  # type: ignore[no-untyped-def]
    """World ends of every segment (local ends ``a``, ``b`` carried by ``joints``) into ``out_a``, ``out_b``."""
    for c in range(joints.shape[0]):
        transform_point_into(rotations, origins, joints[c], a[c], out_a[c])
        transform_point_into(rotations, origins, joints[c], b[c], out_b[c])


@njit(cache=True, inline="always")
def link_obstacle_distance(  # type: ignore[no-untyped-def]
        link, i, packed, centres, bounds, cap_a, cap_b, cap_r, link_start, prim_a, prim_b, prim_r, scratch, cutoff):
    """Signed clearance (m) of ``link`` to obstacle ``i``: ``(d, exact, px, py, pz, nx, ny, nz)``.

    ``exact`` is False when the bounding capsule's bound (returned as ``d``) is ≥ ``cutoff``.
    """
    rows, kinds = packed.rows, packed.kinds
    centre, reach = centres[i], bounds[i]
    lower = point_segment_distance(centre, cap_a[link], cap_b[link]) - reach - cap_r[link]
    if lower >= cutoff:
        return lower, False, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
    best, px, py, pz, bx, by, bz = math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
    round_obstacle = kinds[i] == SPHERE or kinds[i] == CAPSULE
    mid = scratch[1]
    # nothing whose lower bound exceeds ``limit`` can be the minimum: the best exact value so far, or (before
    # any) an upper bound: a segment's midpoint is one of its points, so min_p d(mid_p) − r_p ≥ the minimum
    limit = math.inf
    if not round_obstacle:
        for p in range(link_start[link], link_start[link + 1]):
            for k in range(3):
                mid[k] = 0.5 * (prim_a[p, k] + prim_b[p, k])
            limit = min(limit, obstacle_signed_distance(packed, i, mid)[0] - prim_r[p])
    for p in range(link_start[link], link_start[link + 1]):
        a, b = prim_a[p], prim_b[p]
        if point_segment_distance(centre, a, b) - reach - prim_r[p] > limit:
            continue
        if round_obstacle:
            d, t, nx, ny, nz = round_segment_distance(rows, kinds, i, a, b, scratch)
        else:
            # a signed distance is 1-Lipschitz: d(s(t)) ≥ d(midpoint) − half the segment's length
            half2 = 0.0
            for k in range(3):
                mid[k] = 0.5 * (a[k] + b[k])
                half2 += (b[k] - a[k]) * (b[k] - a[k])
            if obstacle_signed_distance(packed, i, mid)[0] - 0.5 * math.sqrt(half2) - prim_r[p] > limit:
                continue
            d, t, nx, ny, nz = segment_obstacle_distance(packed, i, a, b, scratch)
        d -= prim_r[p]
        if d < best:
            best, bx, by, bz = d, nx, ny, nz
            px, py, pz = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])
            limit = min(limit, best)
    return best, True, px, py, pz, bx, by, bz


@njit(cache=True, inline="always")
def link_pair_distance(  # type: ignore[no-untyped-def]
        l1, l2, cap_a, cap_b, cap_r, link_start, prim_a, prim_b, prim_r, cutoff):
    """Clearance (m) between links ``l1`` and ``l2``: ``(d, exact, p1 (3), p2 (3))``, p1/p2 the closest
    points on the two primitives' segments (``exact`` False: the bounding capsules' bound ≥ ``cutoff``)."""
    lower = segment_segment_distance(cap_a[l1], cap_b[l1], cap_a[l2], cap_b[l2]) - cap_r[l1] - cap_r[l2]
    if lower >= cutoff:
        return lower, False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    best = math.inf
    p1x, p1y, p1z, p2x, p2y, p2z = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for p in range(link_start[l1], link_start[l1 + 1]):
        a1, b1, r1 = prim_a[p], prim_b[p], prim_r[p]
        # link l2 lies inside its bounding capsule: a primitive that cannot beat the best against it is skipped
        if segment_segment_distance(a1, b1, cap_a[l2], cap_b[l2]) - r1 - cap_r[l2] >= best:
            continue
        for q in range(link_start[l2], link_start[l2 + 1]):
            a2, b2 = prim_a[q], prim_b[q]
            s, t = closest_segment_points(a1, b1, a2, b2)
            x1, y1, z1 = a1[0] + s * (b1[0] - a1[0]), a1[1] + s * (b1[1] - a1[1]), a1[2] + s * (b1[2] - a1[2])
            x2, y2, z2 = a2[0] + t * (b2[0] - a2[0]), a2[1] + t * (b2[1] - a2[1]), a2[2] + t * (b2[2] - a2[2])
            dx, dy, dz = x1 - x2, y1 - y2, z1 - z2
            d = math.sqrt(dx * dx + dy * dy + dz * dz) - r1 - prim_r[q]
            if d < best:
                best, p1x, p1y, p1z, p2x, p2y, p2z = d, x1, y1, z1, x2, y2, z2
    return best, True, p1x, p1y, p1z, p2x, p2y, p2z


@njit(cache=True)
def fill_clearances(  # type: ignore[no-untyped-def]
        cap_a, cap_b, cap_r, link_start, prim_a, prim_b, prim_r, self_pairs, packed, centres, bounds, scratch,
        obstacle, own, cutoff):
    """Link–obstacle clearances into ``obstacle`` (L, M) and self-pair clearances into ``own`` (P,), from
    world segments; pairs whose bound is ≥ ``cutoff`` get the bound."""
    for link in range(obstacle.shape[0]):
        for i in range(obstacle.shape[1]):
            obstacle[link, i] = link_obstacle_distance(link, i, packed, centres, bounds, cap_a, cap_b, cap_r,
                                                       link_start, prim_a, prim_b, prim_r, scratch, cutoff)[0]
    for k in range(self_pairs.shape[0]):
        own[k] = link_pair_distance(self_pairs[k, 0], self_pairs[k, 1], cap_a, cap_b, cap_r, link_start, prim_a,
                                    prim_b, prim_r, math.inf)[0]


@njit(cache=True)
def clearances_at(  # type: ignore[no-untyped-def]
        q, parents, place_rot, place_pos, axes, kinds, joints, cap_a, cap_b, cap_r, link_start, prim_joint,
        prim_a, prim_b, prim_r, self_pairs, packed, centres, bounds):
    """Exact clearances (m) at ``q``: link × obstacle (L, M) and self pairs (P,) of the fitted model."""
    n, links, prims = q.shape[0], joints.shape[0], prim_joint.shape[0]
    rotations, origins = np.empty((n, 3, 3)), np.empty((n, 3))
    joint_transforms(q, parents, place_rot, place_pos, axes, kinds, rotations, origins)
    seg_a, seg_b = np.empty((links, 3)), np.empty((links, 3))
    pa, pb = np.empty((prims, 3)), np.empty((prims, 3))
    world_segments(rotations, origins, joints, cap_a, cap_b, seg_a, seg_b)
    world_segments(rotations, origins, prim_joint, prim_a, prim_b, pa, pb)
    obstacle, own = np.empty((links, bounds.shape[0])), np.empty(self_pairs.shape[0])
    fill_clearances(seg_a, seg_b, cap_r, link_start, pa, pb, prim_r, self_pairs, packed, centres, bounds,
                    np.empty((2, 3)), obstacle, own, math.inf)
    return obstacle, own

