"""The compiled core's link distances (``src/core/robot/distance``, ``clearance``): oracles, and numba's bits.

Every clearance pfield computes — the planners' dampers and start offsets, the global search's state checks, the
assistance's nearest pair, :func:`pfield.robot.collision.capsule_clearances` — runs this core. It replaced numba
kernels (``pfield.robot._distance``, ``._clearance``, issue 32) to the bit; those are gone. Their values stay here as
digests (the first 16 hex digits of the sha256 of every output — distance, parameter, point, normal, exactness — on
the seeded cases), computed from the core's outputs after checking, case by case, that numba's kernels gave the same
bytes on the same inputs: they are numba's results. Beside them, oracles that need no numba: a segment's distance
is the obstacle's signed distance at its parameter and, by the distance's 1-Lipschitz bound, within half a sample
step of a dense sampling's minimum (and no more than it: the minimiser's bisection tolerance aside, for the convex
kinds); closest points no farther than any on a grid; world segments are the joint frames times the local ends; each
level of a link–obstacle pair the composition of the levels below it; the clearances the composition of the pairs.

The segments aim at where an implementation could go wrong: random ones, degenerate ones (a == b, shorter than the
1e-7 m threshold and just above it), ones through the obstacle's centre and along its axis (the normal's tie
rules), ones parallel to a box face or a capsule's axis (flat minima, the parallel branch of the segment–segment
closest points), ends on the surface; against every kind, the meshes watertight, non-convex and open, in exact
poses (identity, half-turns: local coordinates exact) and random ones. The robot level: the Panda's two-level link
model in random configurations among random obstacles, with the obstacles' real bounding spheres (culling) and
infinite ones (every pair exact), at the cutoffs its three callers use.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from digests import digest
from pfield._core import robot as bound
from pfield._core import robot_distance as core
from pfield.field import FieldConfig
from pfield.geometry import (
    Box,
    Capsule,
    Cylinder,
    Ellipsoid,
    Mesh,
    Obstacle,
    ResourceResolver,
    Sphere,
    pack_obstacles,
    signed_distances,
)
from pfield.geometry.packed import PackedObstacles
from pfield.planning import _whole_body_layout as wb
from pfield.planning._whole_body_core import core_robot, planner
from pfield.planning.options import PlanOptions
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters, make_scene, obstacle_bounds, pack_robot
from pfield.robot import RobotModel
from pfield.spatial import Pose, quaternion_exp

MESHES = Path(__file__).resolve().parents[1] / "data" / "meshes"
RESOLVER = ResourceResolver(allowed_roots=[MESHES])
EXACT_QUATERNIONS = [(0.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0)]


def _bits(values: object) -> np.ndarray:
    return np.asarray(values, dtype=np.float64).view(np.uint64)


def _same(a: object, b: object) -> bool:
    return bool(np.array_equal(_bits(a), _bits(b)))


def _digest(values: Iterator[Any]) -> str:
    """The first 16 hex digits of :func:`digests.digest`."""
    return digest(values)[:16]


@functools.cache
def _shapes() -> tuple[object, ...]:
    """One of every kind: dyadic sizes (exact ties), meshes watertight (convex and not) and open."""
    cube = trimesh.load(MESHES / "unit_cube.obj", force="mesh")
    icosphere = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    torus = trimesh.creation.torus(major_radius=0.3, minor_radius=0.1, major_sections=24, minor_sections=12)
    meshes = (
        Mesh(str(MESHES / "unit_cube.stl"), 0.4, 0.3, 0.2, resolver=RESOLVER),
        Mesh(str(MESHES / "cylinder_448.stl"), resolver=RESOLVER),
        Mesh.from_arrays(torus.vertices, torus.faces, name="torus"),
        Mesh.from_arrays(cube.vertices, cube.faces[1:], name="open-cube"),
        Mesh.from_arrays(icosphere.vertices, icosphere.faces[: len(icosphere.faces) // 2], name="open-cap"),
    )
    assert [mesh.watertight for mesh in meshes] == [True, True, True, False, False]
    return (Sphere(0.25), Sphere(0.13), Box(0.5, 0.25, 0.125), Box(0.31, 0.52, 0.2), Cylinder(0.125, 0.25),
            Cylinder(0.11, 0.43), Ellipsoid(0.25, 0.125, 0.0625), Ellipsoid(0.2, 0.2, 0.3), Ellipsoid(0.1, 0.3, 0.17),
            Capsule(0.125, 0.5), Capsule(0.07, 0.31), *meshes)


def _scene(rng: np.random.Generator, exact: bool) -> list[Obstacle]:
    """Every shape once, at a dyadic position; exact poses (identity or a half-turn) or random ones."""
    obstacles = []
    for k, shape in enumerate(_shapes()):
        if exact:
            orientation = EXACT_QUATERNIONS[k % 4]
            position = tuple(float(v) for v in rng.integers(-4, 5, 3) / 8.0)
        else:
            orientation = Pose(orientation=quaternion_exp(rng.uniform(-2.0, 2.0, 3))).orientation
            position = tuple(float(v) for v in rng.uniform(-0.5, 0.5, 3))
        obstacles.append(Obstacle(f"o{k}", shape, Pose(position, orientation)))
    return obstacles


def _local_segments(rng: np.random.Generator, shape: object) -> list[tuple[np.ndarray, np.ndarray]]:
    """Segments in the obstacle's frame, built from its own numbers where ties are exact."""
    extent = shape.bounding_radius()  # type: ignore[attr-defined]
    sizes = [value for value in shape.packed_sizes() if value > 0.0]  # type: ignore[attr-defined]
    out: list[tuple[np.ndarray, np.ndarray]] = []
    for _ in range(12):  # random, crossing, inside, outside
        out.append((rng.uniform(-1.5 * extent, 1.5 * extent, 3), rng.uniform(-1.5 * extent, 1.5 * extent, 3)))
    for _ in range(3):
        v = rng.normal(size=3)
        v *= 1.3 * extent / np.linalg.norm(v)
        out.append((-v, v))  # through the centre
        out.append((-v, -v))  # a point: a == b
        out.append((v, v + 1e-8 * rng.normal(size=3)))  # below the degenerate length
        out.append((v, v + 1e-6 * rng.normal(size=3)))  # just above it
    zero = np.zeros(3)
    out.append((zero, zero))  # the centre itself
    for axis in range(3):
        e = np.zeros(3)
        e[axis] = 2.0 * extent
        out.append((-e, e))  # along a local axis through the centre (an axis of symmetry for round kinds)
        out.append((zero, e))  # from the centre out
        for s in sizes:
            for offset in (s, s + 0.0625, 0.5 * s, 2.0 * s):
                side = np.zeros(3)
                side[(axis + 1) % 3] = offset
                out.append((side - e, side + e))  # parallel to an axis: flat minima, face ties
                out.append((side - 0.25 * e, side + 0.125 * e))
    return out


def _world_segments(rng: np.random.Generator, obstacles: list[Obstacle]) -> tuple[np.ndarray, np.ndarray]:
    a, b = [], []
    for obstacle in obstacles:
        for la, lb in _local_segments(rng, obstacle.shape):
            a.append(obstacle.pose.transform_points(la[None, :])[0])
            b.append(obstacle.pose.transform_points(lb[None, :])[0])
    return np.ascontiguousarray(a), np.ascontiguousarray(b)


def _obstacle_set(packed: PackedObstacles, centres: np.ndarray, bounds: np.ndarray) -> Any:
    return bound.Obstacles(*packed, np.ascontiguousarray(centres), np.ascontiguousarray(bounds))


def _segment_case(exact: bool) -> tuple[list[Obstacle], np.ndarray, np.ndarray, Any, list[np.ndarray]]:
    """(obstacles, a, b, the core's obstacle set, [distances (N, M), t (N, M), normals (N, M, 3)])."""
    rng = np.random.default_rng(11 if exact else 12)
    obstacles = _scene(rng, exact)
    packed = pack_obstacles(obstacles)
    a, b = _world_segments(rng, obstacles)
    obstacle_set = _obstacle_set(packed, *obstacle_bounds(packed))
    return obstacles, a, b, obstacle_set, list(core.segment_obstacle_distances(obstacle_set, a, b))


# numba's segment_obstacle_distance (pfield.robot._distance) on every segment of _segment_case and every obstacle
# (distances, t, normals), digested after the core was checked equal to it to the byte
SEGMENT_DIGESTS = {True: "d699860022dda109", False: "f7273ad8539512bd"}
SAMPLES = 257


@pytest.mark.parametrize("exact", [True, False])
def test_segment_obstacle_distances_are_the_minimum_along_the_segment_and_numbas(exact: bool) -> None:
    """d = d_O(a + t (b − a)); d ≥ the dense minimum less half a sample step (d_O is 1-Lipschitz); d ≤ the dense
    minimum for the kinds minimised in closed form or by bisection (convex: within its 1e-7 tolerance), and no more
    than the best of the nine samples a mesh's golden-section search starts from (a mesh may be non-convex: a local
    minimum); a segment shorter than 1e-7 m counts as its first end."""
    obstacles, a, b, obstacle_set, (distances, ts, normals) = _segment_case(exact)
    packed = pack_obstacles(obstacles)
    assert np.isfinite(distances).all() and np.all((ts >= 0.0) & (ts <= 1.0))
    np.testing.assert_allclose(np.linalg.norm(normals, axis=2), 1.0, atol=1e-9)
    convex_meshes = _shapes()[11:13]  # the cube and the cylinder; then the torus and the open meshes
    convex = np.array([not isinstance(o.shape, Mesh) or o.shape in convex_meshes for o in obstacles])
    samples, nine = np.linspace(0.0, 1.0, SAMPLES), np.linspace(0.0, 1.0, 9)
    for k in range(len(a)):
        length = float(np.linalg.norm(b[k] - a[k]))
        dense = signed_distances(packed, a[k] + samples[:, None] * (b[k] - a[k]))[0].min(axis=0)
        assert np.all(distances[k] >= dense - 0.5 * length / (SAMPLES - 1) - 1e-12), k
        at_t = signed_distances(packed, a[k] + ts[k][:, None] * (b[k] - a[k]))[0].diagonal()
        np.testing.assert_allclose(distances[k], at_t, rtol=0, atol=1e-12)
        if length * length <= 1e-14:  # a point: within its length of the distance at its start
            start = signed_distances(packed, a[k])[0][0]
            assert np.all(np.abs(distances[k] - start) <= length + 1e-12), k
            continue
        assert np.all(distances[k][convex] <= dense[convex] + 1e-7), k
        started = signed_distances(packed, a[k] + nine[:, None] * (b[k] - a[k]))[0].min(axis=0)
        assert np.all(distances[k][~convex] <= started[~convex] + 1e-12), k
    for k in range(0, len(a), 7):  # the single call is the batch's
        for i in range(len(obstacles)):
            one = core.segment_obstacle_distance(obstacle_set, i, a[k], b[k])
            assert _same((one.distance, one.t, *one.normal), (distances[k, i], ts[k, i], *normals[k, i]))
    assert _digest(iter([distances, ts, normals])) == SEGMENT_DIGESTS[exact]


def _segment_pairs(rng: np.random.Generator) -> list[tuple[np.ndarray, ...]]:
    """Random, parallel, collinear, crossing, degenerate and nearly degenerate segment pairs."""
    pairs = []
    for _ in range(300):
        p1, q1, p2, q2 = rng.uniform(-1.0, 1.0, (4, 3))
        d = q1 - p1
        pairs.append((p1, q1, p2, q2))
        pairs.append((p1, q1, p2, p2 + rng.uniform(-2.0, 2.0) * d))  # parallel
        pairs.append((p1, q1, p1 + 0.5 * d, p1 + 1.5 * d))  # collinear, overlapping
        pairs.append((p1, q1, p1 + 2.0 * d, p1 + 3.0 * d))  # collinear, apart
        pairs.append((p1, q1, 0.5 * (p1 + q1) - 0.5 * (q2 - p2), 0.5 * (p1 + q1) + 0.5 * (q2 - p2)))  # crossing
        pairs.append((p1, p1, p2, q2))  # first a point
        pairs.append((p1, q1, p2, p2))  # second a point
        pairs.append((p1, p1, p2, p2))  # both points
        pairs.append((p1, p1 + 1e-8 * d, p2, q2))  # below the degenerate length
        pairs.append((p1, q1, p2, p2 + 2e-7 * d))  # just above it, nearly parallel
    exact = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.5, 0.0], [1.0, 0.5, 0.0], [0.5, -1.0, 0.25],
                      [0.5, 1.0, 0.25]])
    for i in range(len(exact)):
        for j in range(len(exact)):
            pairs.append((exact[0], exact[1], exact[i], exact[j]))
    return pairs


def _closest_points(pairs: list[tuple[np.ndarray, ...]]) -> list[np.ndarray]:
    """[(s, t) (P, 2), segment–segment distances (P,), distances of the second segment's start to the first (P,)]."""
    st, between, point = np.empty((len(pairs), 2)), np.empty(len(pairs)), np.empty(len(pairs))
    for k, (p1, q1, p2, q2) in enumerate(pairs):
        args = [np.ascontiguousarray(v, dtype=np.float64) for v in (p1, q1, p2, q2)]
        closest = core.closest_segment_points(*args)
        st[k] = closest.s, closest.t
        between[k] = core.segment_segment_distance(*args)
        point[k] = core.point_segment_distance(args[2], args[0], args[1])
    return [st, between, point]


# numba's closest_segment_points, its segment–segment distance and point_segment_distance_xyz (pfield.robot._distance)
# on _segment_pairs(default_rng(5)), digested after the core was checked equal to them to the byte
CLOSEST_DIGEST = "f08b38d9cd24d253"


def test_closest_points_of_segments_and_points() -> None:
    """(s, t) in [0, 1] no farther apart than any pair of points on a 201 × 201 grid of the two segments; the
    distance is |p1 + s (q1 − p1) − (p2 + t (q2 − p2))| summed in that order; a point's distance is to its
    projection clamped onto the segment (a segment shorter than 1e-7 m counts as its start)."""
    pairs = _segment_pairs(np.random.default_rng(5))
    st, between, point = _closest_points(pairs)
    grid = np.linspace(0.0, 1.0, 201)
    assert np.all((st >= 0.0) & (st <= 1.0))
    for k, (p1, q1, p2, q2) in enumerate(pairs):
        s, t = st[k]
        total = 0.0
        for j in range(3):
            diff = (p1[j] + s * (q1[j] - p1[j])) - (p2[j] + t * (q2[j] - p2[j]))
            total += diff * diff
        assert between[k] == math.sqrt(total)
        first = p1 + grid[:, None] * (q1 - p1)
        second = p2 + grid[:, None] * (q2 - p2)
        sampled = np.sqrt(((first[:, None, :] - second[None, :, :]) ** 2).sum(axis=2)).min()
        points = sum(float(np.linalg.norm(q - p)) for p, q in ((p1, q1), (p2, q2)) if (q - p) @ (q - p) <= 1e-14)
        assert between[k] <= sampled + points + 1e-12, k  # a segment shorter than 1e-7 m counts as its start
        e = q1 - p1
        along = 0.0 if e @ e <= 1e-14 else min(max(float((p2 - p1) @ e / (e @ e)), 0.0), 1.0)
        assert point[k] == pytest.approx(np.linalg.norm(p2 - (p1 + along * e)), abs=1e-12)
    assert _digest(iter([st, between, point])) == CLOSEST_DIGEST


# ---- the robot level ----------------------------------------------------------------------------------------


def _robot_scene(rng: np.random.Generator, shapes: tuple[object, ...]) -> list[Obstacle]:
    """Obstacles of every kind in the Panda's reach, some touching or inside its links."""
    obstacles = []
    for k, shape in enumerate(shapes):
        position = (rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(0.0, 1.0))
        orientation = Pose(orientation=quaternion_exp(rng.uniform(-2.0, 2.0, 3))).orientation
        obstacles.append(Obstacle(f"o{k}", shape, Pose(position, orientation)))
    return obstacles


def _configurations(robot: RobotModel, rng: np.random.Generator, count: int) -> np.ndarray:
    lower, upper = np.maximum(robot.lower_limits, -2.8), np.minimum(robot.upper_limits, 2.8)
    return rng.uniform(lower, upper, size=(count, robot.n_joints))


def _configurations(robot: RobotModel, rng: np.random.Generator, count: int) -> np.ndarray:
    lower, upper = np.maximum(robot.lower_limits, -2.8), np.minimum(robot.upper_limits, 2.8)
    return rng.uniform(lower, upper, size=(count, robot.n_joints))


@functools.cache
def _panda_robot() -> tuple[RobotModel, Any]:
    """The Panda and the core's robot with its link model (RobotArrays: the planners' binding)."""
    panda = RobotModel.builtin("panda")
    return panda, core_robot(pack_robot(panda, FieldConfig(), WholeBodyOptions()))


@functools.cache
def _panda_cases() -> tuple[tuple[np.ndarray, tuple[Obstacle, ...]], ...]:
    """Ten random configurations, each among eight random obstacles of the fifteen shapes."""
    panda, _ = _panda_robot()
    rng = np.random.default_rng(21)
    shapes = _shapes()
    cases = []
    for q in _configurations(panda, rng, 10):
        chosen = [shapes[int(k)] for k in rng.choice(len(shapes), size=8, replace=False)]
        cases.append((q, tuple(_robot_scene(rng, tuple(chosen)))))
    return tuple(cases)


def _frames(panda: RobotModel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return tuple(np.ascontiguousarray(v) for v in panda.joint_frames(q))  # type: ignore[return-value]


def _row(d: Any) -> list[float]:
    """(d, exact, point, normal) of a LinkObstacleDistance, as numba's kernels returned it."""
    return [d.distance, float(d.exact), *d.point, *d.normal]


CUTOFFS = ((math.inf, math.inf), (0.3, 0.3), (0.05, 0.05), (math.inf, 0.05), (0.02, 0.02))
"""(cutoff, fine cutoff) of the callers: the clearances (inf), the whole body's influence distance, a tight one,
the assistance's best so far."""
FINE_CUTOFFS = (math.inf, 0.05, 0.0)


class LinkLevels:
    """Every level of every link–obstacle pair and every self pair of one case: world and near segments, the
    capsule level, the fitted level at FINE_CUTOFFS, the composition at CUTOFFS, the self pairs."""

    def __init__(self, q: np.ndarray, obstacles: tuple[Obstacle, ...], culled: bool) -> None:
        panda, robot = _panda_robot()
        self.packed = pack_obstacles(list(obstacles))
        centres, bounds = obstacle_bounds(self.packed)
        self.bounds = bounds if culled else np.full(len(bounds), np.inf)
        self.obstacles = _obstacle_set(self.packed, centres, self.bounds)
        rotations, origins = self.frames = _frames(panda, q)
        self.world = core.world_segments(robot, rotations, origins)
        self.near = core.near_segments(robot, rotations, origins, self.obstacles)
        g = panda.geometry
        self.capsule, self.fitted, self.pairs = {}, {}, {}
        for c in range(len(g.radii)):
            for i in range(len(obstacles)):
                self.capsule[c, i] = core.capsule_level_distance(self.obstacles, i, self.world.cap_a[c],
                                                                 self.world.cap_b[c], g.radii[c])
                for fine in FINE_CUTOFFS:
                    self.fitted[c, i, fine] = core.fitted_distance_below(robot, self.world, self.obstacles, c, i, fine)
                for cutoff, fine in CUTOFFS:
                    self.pairs[c, i, cutoff, fine] = core.link_obstacle_distance(robot, self.world, self.obstacles, c,
                                                                                 i, cutoff, fine)
        self.own = [core.link_pair_distance(robot, self.world, int(l1), int(l2)) for l1, l2 in g.self_pairs]

    def outputs(self) -> list[np.ndarray]:
        """[world cap_a, cap_b, prim_a, prim_b, near prim_a, prim_b, capsule rows, fitted rows, pair rows, self
        rows] in numba's tuple layouts, the pairs in (link, obstacle, cutoff) order."""
        world, near = self.world, self.near
        return [world.cap_a, world.cap_b, world.prim_a, world.prim_b, near.prim_a, near.prim_b,
                np.array([_row(d) for d in self.capsule.values()]), np.array([_row(d) for d in self.fitted.values()]),
                np.array([_row(d) for d in self.pairs.values()]),
                np.array([[d.distance, *d.first, *d.second] for d in self.own])]


FINE_RANGE = 0.1
"""(m) From here on a link's bounding capsule stands for its fitted primitives (src/core/robot/clearance.hpp)."""


def _check_fitted(pair: Any, own: list[float], start: int, fine: float) -> None:
    """The fine level: exactly the least of the link's primitives' own distances below ``fine``; at or beyond it a
    value that says only so (the deciding primitive's own distance, when exact)."""
    best = min(own, default=math.inf)
    if best < fine:
        assert pair.exact and pair.distance == best
    else:
        assert fine <= pair.distance and (pair.exact or pair.distance <= best + 1e-12)
    if pair.exact:
        assert pair.distance == own[pair.primitive - start]


# numba's world_segments, near_segments, capsule_level_distance, fitted_distance_below, link_obstacle_distance_below
# and link_pair_distance (pfield.robot._clearance) on every LinkLevels of _panda_cases, digested per culling after
# the core was checked equal to them to the byte
LEVEL_DIGESTS = {True: "58def54d1bffe200", False: "14378637b86616ee"}


@pytest.mark.parametrize("culled", [True, False], ids=["bounding-spheres", "no-culling"])
def test_link_obstacle_levels_compose_and_are_numbas(culled: bool) -> None:
    """World segments are the joint frames times the local ends; near segments those of the links within reach
    (NaN elsewhere); the capsule level is the axis's distance less the radius, a lower bound of the primitives', exact
    from FINE_RANGE; the fitted level the least of the link's primitives' below its cutoff; the composition the
    culling bound, the capsule level or the fitted level as documented; a self pair the axes' distance less both
    radii."""
    panda, _ = _panda_robot()
    g = panda.geometry
    seen = {level: 0 for level in (core.ClearanceLevel.Culled, core.ClearanceLevel.Capsule,
                                   core.ClearanceLevel.Primitives)}
    outputs, exact_pairs = [], 0
    for q, obstacles in _panda_cases():
        levels = LinkLevels(q, obstacles, culled)
        world, rotations, origins = levels.world, *levels.frames
        for ends, local, joints in ((world.cap_a, g.a, g.joints), (world.cap_b, g.b, g.joints),
                                    (world.prim_a, g.prim_a, g.prim_joint), (world.prim_b, g.prim_b, g.prim_joint)):
            for row, (point, j) in enumerate(zip(local, joints, strict=True)):
                expected = point if j < 0 else rotations[j] @ point + origins[j]
                np.testing.assert_allclose(ends[row], expected, rtol=0, atol=1e-15 * (1 + np.abs(expected).max()))
        assert _same(levels.near.cap_a, world.cap_a) and _same(levels.near.cap_b, world.cap_b)
        kept = ~np.isnan(levels.near.prim_a[:, 0])
        assert _same(levels.near.prim_a[kept], world.prim_a[kept]) and np.isnan(levels.near.prim_b[~kept]).all()
        for (c, i), coarse in levels.capsule.items():
            axis = core.segment_obstacle_distance(levels.obstacles, i, world.cap_a[c], world.cap_b[c])
            assert coarse.distance == axis.distance - g.radii[c] and coarse.level == core.ClearanceLevel.Capsule
            assert coarse.exact == (coarse.distance >= FINE_RANGE)
            start, stop = int(g.link_start[c]), int(g.link_start[c + 1])
            own = [core.segment_obstacle_distance(levels.obstacles, i, world.prim_a[p], world.prim_b[p]).distance
                   - g.prim_r[p] for p in range(start, stop)]
            best = min(own, default=math.inf)
            assert coarse.distance <= best + 1e-12  # the covering capsule's distance bounds its primitives'
            for fine in FINE_CUTOFFS:
                _check_fitted(levels.fitted[c, i, fine], own, start, fine)
            for cutoff, fine in CUTOFFS:
                pair = levels.pairs[c, i, cutoff, fine]
                assert (pair.link, pair.obstacle) == (c, i)
                seen[pair.level] += 1
                exact_pairs += pair.exact
                if pair.level == core.ClearanceLevel.Culled:  # the bounding sphere's bound, at or beyond the cutoff
                    assert not pair.exact and cutoff <= pair.distance <= best + 1e-12
                elif pair.level == core.ClearanceLevel.Capsule:  # exact from FINE_RANGE, else a bound beyond fine
                    assert pair.distance == coarse.distance and pair.exact == coarse.exact
                    assert pair.exact or fine <= pair.distance <= best + 1e-12
                else:
                    _check_fitted(pair, own, start, fine)
        for (l1, l2), pair in zip(g.self_pairs, levels.own, strict=True):
            axes = core.segment_segment_distance(world.cap_a[l1], world.cap_b[l1], world.cap_a[l2], world.cap_b[l2])
            assert pair.distance == pytest.approx(axes - g.self_radii[l1] - g.self_radii[l2], abs=1e-15)
            assert np.linalg.norm(np.subtract(pair.first, pair.second)) == pytest.approx(axes, abs=1e-12)
        outputs += levels.outputs()
    counts = dict(seen)
    if culled:
        assert min(counts.values()) > 0, counts
    else:
        assert counts[core.ClearanceLevel.Culled] == 0 and counts[core.ClearanceLevel.Primitives] > 0, counts
    assert exact_pairs > 0
    assert _digest(iter(outputs)) == LEVEL_DIGESTS[culled]


def _clearance_outputs(q: np.ndarray, obstacles: tuple[Obstacle, ...]) -> Iterator[tuple[str, Any, Any]]:
    """("fill", bounds, cutoff, segments, clearances) from the world and near segments at three cutoffs, with the
    obstacles' bounding spheres and infinite ones; ("at", bounds, clearances_at), ("frames", bounds, clearances)."""
    panda, robot = _panda_robot()
    packed = pack_obstacles(list(obstacles))
    centres, bounds = obstacle_bounds(packed)
    for spheres in (bounds, np.full(len(bounds), np.inf)):
        obstacle_set = _obstacle_set(packed, centres, spheres)
        rotations, origins = _frames(panda, q)
        for world in (core.world_segments(robot, rotations, origins),
                      core.near_segments(robot, rotations, origins, obstacle_set)):
            for cutoff in (math.inf, 0.3, 0.05):  # near segments too: the stale (NaN) rows are never read
                yield "fill", (obstacle_set, world, cutoff), core.fill_clearances(robot, world, obstacle_set, cutoff)
        yield "at", obstacle_set, core.clearances_at(robot, q, obstacle_set)
        yield "frames", obstacle_set, core.clearances(robot, rotations, origins, obstacle_set)


# numba's fill_clearances and clearances_at (the loops of pfield.robot._clearance) on every _clearance_outputs of
# _panda_cases (obstacle then own clearances), digested after the core was checked equal to them to the byte
CLEARANCES_DIGEST = "5267556c15191f49"


def test_clearances_compose_the_pairs_and_are_numbas() -> None:
    """fill_clearances is link_obstacle_distance at (cutoff, cutoff) for every pair and link_pair_distance for every
    self pair; clearances_at (forward kinematics included) is clearances at the joint frames is the exact fill of
    the world segments."""
    panda, robot = _panda_robot()
    g = panda.geometry
    outputs = []
    for q, obstacles in _panda_cases():
        exact = None
        for kind, given, clearances in _clearance_outputs(q, obstacles):
            outputs += [clearances.obstacle, clearances.own]
            assert not np.isnan(clearances.obstacle).any()
            if kind == "fill":
                obstacle_set, world, cutoff = given
                for c in range(len(g.radii)):
                    for i in range(len(obstacles)):
                        pair = core.link_obstacle_distance(robot, world, obstacle_set, c, i, cutoff, cutoff)
                        assert _same(clearances.obstacle[c, i], pair.distance)
                assert _same(clearances.own, [core.link_pair_distance(robot, world, int(l1), int(l2)).distance
                                              for l1, l2 in g.self_pairs])
                if cutoff == math.inf:
                    assert exact is None or (_same(clearances.obstacle, exact.obstacle)
                                             and _same(clearances.own, exact.own))
                    exact = clearances
            else:
                assert exact is not None
                assert _same(clearances.obstacle, exact.obstacle) and _same(clearances.own, exact.own)
                if kind == "frames":
                    exact = None  # the next bounds
    assert _digest(iter(outputs)) == CLEARANCES_DIGEST


def test_the_one_link_obstacle_distance_serves_the_assistance_and_the_whole_body() -> None:
    """The callers' loops over link_obstacle_distance, as its header documents them, are the assistance's nearest
    pair (src/core/shared_control/assist's nearest_link) and the whole-body step's clearance and nearest pair
    (src/core/planning/whole_body's damper rows, at the influence distance Q) to the bit."""
    from pfield.shared_control import AssistanceScene
    from pfield.shared_control.assistance import _MODES, _workspace

    panda, robot = _panda_robot()
    g = panda.geometry
    influence = 0.3
    config = FieldConfig(influence_distance=influence)
    arrays = pack_robot(panda, config, WholeBodyOptions())
    params = kernel_parameters(config, PlanOptions().resolved(config), WholeBodyOptions())
    for q, obstacles in _panda_cases():
        packed = pack_obstacles(list(obstacles))
        obstacle_set = _obstacle_set(packed, *obstacle_bounds(packed))
        world = core.near_segments(robot, *_frames(panda, q), obstacle_set)
        # the assistance: cutoff = fine_cutoff = the best so far, a pair replaces it when exact and nearer
        nearest = _workspace(AssistanceScene(config=FieldConfig(), obstacles=list(obstacles)), panda).assist(
            q, np.zeros(6), _MODES["safety_only"], 0.0)
        want = (nearest.nearest_link, nearest.nearest, nearest.distance, *nearest.normal, *nearest.robot_point)
        best = None
        for c in range(len(g.radii)):
            for i in range(len(obstacles)):
                limit = math.inf if best is None else best.distance
                pair = core.link_obstacle_distance(robot, world, obstacle_set, c, i, limit, limit)
                if pair.exact and pair.distance < limit:
                    best = pair
        assert best is not None
        assert (best.link, best.obstacle) == (want[0], want[1]) and _same(best.distance, want[2])
        assert _same(best.normal, want[3:6])
        # its witness point on the link's surface, from the pair's axis point
        axis_point = np.array(best.point)
        radius = signed_distances(packed, axis_point)[0][0, best.obstacle] - best.distance
        assert _same(axis_point - radius * np.array(best.normal), want[6:9])
        # the whole body: cutoff = fine_cutoff = Q; a Culled pair only lowers the clearance
        clearance, nearest = math.inf, (math.inf, -1, -1)
        for c in range(len(g.radii)):
            for i in range(len(obstacles)):
                pair = core.link_obstacle_distance(robot, world, obstacle_set, c, i, influence, influence)
                clearance = min(clearance, pair.distance)
                if pair.level != core.ClearanceLevel.Culled and pair.distance < nearest[0]:
                    nearest = (pair.distance, c, i)
        row, _ = planner(arrays, make_scene(packed, arrays), np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]),
                         params).joint_velocity_step(q, None)
        step = wb.StepResult.of(row)
        assert _same(step.clearance, clearance)
        assert _same(step.nearest_distance, nearest[0])
        assert (step.nearest_capsule, step.nearest_obstacle) == nearest[1:]


# numba's clearances_at with infinite bounding spheres, the public clearances' engine, on one scene of every shape
PUBLIC_DIGEST = "a33e6fb1052ec17f"


def test_capsule_clearances_runs_the_core() -> None:
    """The public clearances are the core's exact ones (infinite bounding spheres); the bindings refuse malformed
    arrays."""
    from pfield.robot.collision import capsule_clearances

    panda, robot = _panda_robot()
    rng = np.random.default_rng(8)
    obstacles = _robot_scene(rng, _shapes())
    q = _configurations(panda, rng, 1)[0]
    report = capsule_clearances(panda, q, obstacles)
    packed = pack_obstacles(obstacles)
    exact = core.clearances_at(robot, q, _obstacle_set(packed, packed.rows[:, 0:3], np.full(len(obstacles), np.inf)))
    assert _same(report.obstacle, exact.obstacle) and _same(report.self_pairs, exact.own)
    assert _digest(iter([report.obstacle, report.self_pairs])) == PUBLIC_DIGEST
    k, g = panda.kinematics, panda.geometry
    limits = (panda.lower_limits, panda.upper_limits, panda.velocity_limits, panda.acceleration_limits)
    with pytest.raises(ValueError, match="link_start"):
        bound.Robot(*k, g.joints, g.a, g.b, g.radii, g.self_pairs, *limits, g.link_start[:-1], g.prim_joint,
                    g.prim_a, g.prim_b, g.prim_r, g.self_radii)
    with pytest.raises(ValueError, match="self pair"):
        bound.Robot(*k, g.joints, g.a, g.b, g.radii, g.self_pairs + len(g.radii), *limits, g.link_start,
                    g.prim_joint, g.prim_a, g.prim_b, g.prim_r, g.self_radii)
    with pytest.raises(ValueError, match="joint"):
        core.world_segments(robot, np.zeros((2, 3, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="q"):
        core.clearances_at(robot, q[:-1], _obstacle_set(packed, packed.rows[:, 0:3], np.full(len(obstacles),
                                                                                                np.inf)))
