"""The compiled core's link distances and numba's give the same bits.

Until the whole-body step, the assistance and the RRT move to the core, pfield carries two implementations of the
link distances: the numba kernels those consumers inline (:mod:`pfield.robot._distance`, :mod:`._clearance`) and
the core's port (``src/core/robot/distance``, ``clearance``), which the clearances Python asks for now run
(:func:`pfield.robot.collision.capsule_clearances`, the planners' start offsets). A clearance printed by Python and
the one a plan stopped at must not disagree in the last digit, so every value (distance, parameter, point, normal,
exactness) is held equal bit for bit, signed zeros included: both keep the same operand order, Python's min/max
tie rule, and neither fuses multiply-adds.

The segments aim at where the two could part: random ones, degenerate ones (a == b, shorter than the 1e-7 m
threshold and just above it), ones through the obstacle's centre and along its axis (the normal's tie rules),
ones parallel to a box face or a capsule's axis (flat minima, the parallel branch of the segment–segment closest
points), ends on the surface; against every kind, the meshes watertight, non-convex and open, in exact poses
(identity, half-turns: local coordinates exact) and random ones. The robot level: the Panda's two-level link model
in random configurations among random obstacles, with the obstacles' real bounding spheres (culling) and infinite
ones (every pair exact), at the cutoffs its three callers use.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
import trimesh

from pfield._core import robot_distance as core
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
)
from pfield.geometry._packed import PackedObstacles
from pfield.geometry._sdf import mesh_addresses, obstacle_signed_distance
from pfield.planning.whole_body import obstacle_bounds
from pfield.robot import RobotModel
from pfield.robot import _clearance as nb_clearance
from pfield.robot import _distance as nb_distance
from pfield.robot import _kinematics as nb_kinematics
from pfield.spatial import Pose, quaternion_exp

MESHES = Path(__file__).resolve().parents[1] / "data" / "meshes"
RESOLVER = ResourceResolver(allowed_roots=[MESHES])
EXACT_QUATERNIONS = [(0.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0)]


def _bits(values: object) -> np.ndarray:
    return np.asarray(values, dtype=np.float64).view(np.uint64)


def _same(a: object, b: object) -> bool:
    return bool(np.array_equal(_bits(a), _bits(b)))


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


def _core_obstacles(packed: PackedObstacles, centres: np.ndarray, bounds: np.ndarray) -> core.Obstacles:
    return core.Obstacles(*packed, np.ascontiguousarray(centres), np.ascontiguousarray(bounds))


@pytest.mark.parametrize("exact", [True, False])
def test_segment_obstacle_distance_is_numba_bit_for_bit(exact: bool) -> None:
    rng = np.random.default_rng(11 if exact else 12)
    obstacles = _scene(rng, exact)
    packed = pack_obstacles(obstacles)
    a, b = _world_segments(rng, obstacles)
    centres, bounds = obstacle_bounds(packed)
    distances, ts, normals = core.segment_obstacle_distances(_core_obstacles(packed, centres, bounds), a, b)
    scratch = np.empty((2, 3))
    expected = np.empty((len(a), len(obstacles), 5))
    for k in range(len(a)):
        for i in range(len(obstacles)):
            expected[k, i] = nb_distance.segment_obstacle_distance(packed, i, a[k], b[k], scratch)
    assert np.isfinite(distances).all()
    for name, got, want in (("distance", distances, expected[..., 0]), ("t", ts, expected[..., 1]),
                            ("normal", normals, expected[..., 2:])):
        differ = np.argwhere(_bits(got) != _bits(want))
        assert len(differ) == 0, f"{name} differs at {differ[:5].tolist()}: {got[tuple(differ[0])]} vs " \
                                 f"{want[tuple(differ[0])]}"
    # the single call is the batch's
    obstacle_set = _core_obstacles(packed, centres, bounds)
    for k in range(0, len(a), 7):
        for i in range(len(obstacles)):
            one = core.segment_obstacle_distance(obstacle_set, i, a[k], b[k])
            assert _same((one.distance, one.t, *one.normal), expected[k, i])


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


def _segment_segment_reference(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> float:
    """The numba kernel's segment–segment distance (retired: no kernel called it), its operations in their order
    in float64, on the numba twin's closest points."""
    s, t = nb_distance.closest_segment_points(p1, q1, p2, q2)
    total = 0.0
    for k in range(3):
        diff = (p1[k] + s * (q1[k] - p1[k])) - (p2[k] + t * (q2[k] - p2[k]))
        total += diff * diff
    return math.sqrt(total)


def test_closest_points_of_segments_and_points_are_numba_bit_for_bit() -> None:
    rng = np.random.default_rng(5)
    for p1, q1, p2, q2 in _segment_pairs(rng):
        args = [np.ascontiguousarray(v, dtype=np.float64) for v in (p1, q1, p2, q2)]
        st = core.closest_segment_points(*args)
        assert _same((st.s, st.t), nb_distance.closest_segment_points(*args))
        assert _same(core.segment_segment_distance(*args), _segment_segment_reference(*args))
        assert _same(core.point_segment_distance(args[2], args[0], args[1]),
                     nb_distance.point_segment_distance_xyz(*args[2], *args[0], *args[1]))


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


def _link_model(robot: RobotModel) -> core.LinkModel:
    g = robot.geometry
    return core.LinkModel(g.joints, g.a, g.b, g.radii, g.self_radii, g.self_pairs, g.link_start, g.prim_joint,
                          g.prim_a, g.prim_b, g.prim_r)


def _result(d: core.LinkObstacleDistance) -> tuple[object, ...]:
    """The numba tuple (d, exact, px, py, pz, nx, ny, nz) of a core result."""
    return (d.distance, d.exact, *d.point, *d.normal)


def _same_pair(got: core.LinkObstacleDistance, want: tuple[object, ...]) -> bool:
    return bool(got.exact == want[1]) and _same(_result(got)[:1] + _result(got)[2:], want[:1] + want[2:])


@pytest.fixture(scope="module")
def panda_cases(panda: RobotModel) -> list[tuple[np.ndarray, list[Obstacle]]]:
    rng = np.random.default_rng(21)
    shapes = _shapes()
    cases = []
    for q in _configurations(panda, rng, 10):
        chosen = [shapes[int(k)] for k in rng.choice(len(shapes), size=8, replace=False)]
        cases.append((q, _robot_scene(rng, tuple(chosen))))
    return cases


@pytest.mark.parametrize("culled", [True, False], ids=["bounding-spheres", "no-culling"])
def test_link_obstacle_levels_are_numba_bit_for_bit(panda: RobotModel, panda_cases: list, culled: bool) -> None:
    """World segments, near segments, both levels and their composition at the cutoffs of every caller."""
    model, g = _link_model(panda), panda.geometry
    seen = {level: 0 for level in (core.ClearanceLevel.Culled, core.ClearanceLevel.Capsule,
                                   core.ClearanceLevel.Primitives)}
    exact_pairs = 0
    for q, obstacles in panda_cases:
        packed = pack_obstacles(obstacles)
        kinds, rows, meshes = packed.kinds, packed.rows, mesh_addresses(packed)
        centres, bounds = obstacle_bounds(packed)
        if not culled:
            bounds = np.full(len(bounds), np.inf)
        obstacle_set = _core_obstacles(packed, centres, bounds)
        rotations, origins = panda.joint_frames(q)
        rotations, origins = np.ascontiguousarray(rotations), np.ascontiguousarray(origins)
        world = model.world_segments(rotations, origins)
        cap_a, cap_b = np.empty_like(g.a), np.empty_like(g.b)
        prim_a, prim_b = np.empty_like(g.prim_a), np.empty_like(g.prim_b)
        nb_clearance.world_segments(rotations, origins, g.joints, g.a, g.b, cap_a, cap_b)
        nb_clearance.world_segments(rotations, origins, g.prim_joint, g.prim_a, g.prim_b, prim_a, prim_b)
        assert _same(world.cap_a, cap_a) and _same(world.cap_b, cap_b)
        assert _same(world.prim_a, prim_a) and _same(world.prim_b, prim_b)
        # near segments: the same rows transformed (the others stay NaN in both)
        near = model.near_segments(rotations, origins, obstacle_set)
        near_a, near_b = np.full_like(g.prim_a, np.nan), np.full_like(g.prim_b, np.nan)
        nb_clearance.near_segments(rotations, origins, cap_a, cap_b, g.radii, g.link_start, g.prim_joint, g.prim_a,
                                   g.prim_b, centres, bounds, near_a, near_b)
        assert _same(near.prim_a, near_a) and _same(near.prim_b, near_b)
        assert _same(near.cap_a, cap_a)
        scratch = np.empty((2, 3))
        for c in range(len(g.radii)):
            start, stop = int(g.link_start[c]), int(g.link_start[c + 1])
            for i in range(len(obstacles)):
                coarse = nb_clearance.capsule_level_distance(kinds, rows, meshes, i, *cap_a[c], *cap_b[c],
                                                             g.radii[c], scratch)
                got = core.capsule_level_distance(obstacle_set, i, cap_a[c], cap_b[c], g.radii[c])
                assert _same_pair(got, coarse) and got.level == core.ClearanceLevel.Capsule
                for fine_cutoff in (math.inf, 0.05, 0.0):
                    fine = nb_clearance.fitted_distance_below(kinds, rows, meshes, i, *centres[i], bounds[i], start,
                                                              stop, prim_a, prim_b, g.prim_r, scratch, fine_cutoff)
                    got = model.fitted_distance_below(world, obstacle_set, c, i, fine_cutoff)
                    assert _same_pair(got, fine), (c, i, fine_cutoff)
                # the clearances' (inf), the whole body's influence distance, a tight one, the assistance's best
                for cutoff, fine_cutoff in ((math.inf, math.inf), (0.3, 0.3), (0.05, 0.05), (math.inf, 0.05),
                                            (0.02, 0.02)):
                    want = nb_clearance.link_obstacle_distance_below(
                        c, i, kinds, rows, meshes, centres, bounds, cap_a, cap_b, g.radii, g.link_start, prim_a,
                        prim_b, g.prim_r, scratch, cutoff, fine_cutoff)
                    got = model.link_obstacle_distance(world, obstacle_set, c, i, cutoff, fine_cutoff)
                    assert _same_pair(got, want), (c, i, cutoff, fine_cutoff)
                    assert (got.link, got.obstacle) == (c, i)
                    seen[got.level] += 1
                    exact_pairs += got.exact
                    if got.level == core.ClearanceLevel.Primitives and got.exact and stop > start:
                        # the deciding primitive's own distance is the pair's
                        p = got.primitive
                        assert start <= p < stop
                        own = nb_distance.segment_obstacle_distance(packed, i, prim_a[p], prim_b[p], scratch)
                        assert _same(own[0] - g.prim_r[p], got.distance)
        for k, (l1, l2) in enumerate(g.self_pairs):
            want = nb_clearance.link_pair_distance(l1, l2, cap_a, cap_b, g.self_radii)
            got = model.link_pair_distance(world, int(l1), int(l2))
            assert _same((got.distance, *got.first, *got.second), want), k
    counts = dict(seen)
    if culled:
        assert min(counts.values()) > 0, counts
    else:
        assert counts[core.ClearanceLevel.Culled] == 0 and counts[core.ClearanceLevel.Primitives] > 0, counts
    assert exact_pairs > 0


def _fill_reference(robot: RobotModel, segments: tuple[np.ndarray, ...], packed: PackedObstacles,
                    centres: np.ndarray, bounds: np.ndarray, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
    """What numba's fill_clearances computed (retired with clearances_at when their callers moved to the core):
    its loops over the numba twins of the pair distances."""
    g, (cap_a, cap_b, prim_a, prim_b) = robot.geometry, segments
    kinds, rows, meshes, scratch = packed.kinds, packed.rows, mesh_addresses(packed), np.empty((2, 3))
    obstacle, own = np.empty((len(g.radii), len(packed.kinds))), np.empty(len(g.self_pairs))
    for c in range(len(g.radii)):
        for i in range(len(packed.kinds)):
            obstacle[c, i] = nb_clearance.link_obstacle_distance_below(
                c, i, kinds, rows, meshes, centres, bounds, cap_a, cap_b, g.radii, g.link_start, prim_a, prim_b,
                g.prim_r, scratch, cutoff, cutoff)[0]
    for k, (l1, l2) in enumerate(g.self_pairs):
        own[k] = nb_clearance.link_pair_distance(l1, l2, cap_a, cap_b, g.self_radii)[0]
    return obstacle, own


def _clearances_reference(robot: RobotModel, q: np.ndarray, packed: PackedObstacles, centres: np.ndarray,
                          bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What numba's clearances_at computed: its joint frames, world segments and fill, by the numba twins."""
    k, g = robot.kinematics, robot.geometry
    rotations, origins = np.empty((len(q), 3, 3)), np.empty((len(q), 3))
    nb_kinematics.joint_transforms(q, k.parents, k.place_rot, k.place_pos, k.axes, k.kinds, rotations, origins)
    segments = (np.empty_like(g.a), np.empty_like(g.b), np.empty_like(g.prim_a), np.empty_like(g.prim_b))
    nb_clearance.world_segments(rotations, origins, g.joints, g.a, g.b, segments[0], segments[1])
    nb_clearance.world_segments(rotations, origins, g.prim_joint, g.prim_a, g.prim_b, segments[2], segments[3])
    return _fill_reference(robot, segments, packed, centres, bounds, math.inf)


def test_clearances_are_numba_bit_for_bit(panda: RobotModel, panda_cases: list) -> None:
    """fill_clearances at every cutoff and clearances_at (forward kinematics included) on the Panda."""
    model, k = _link_model(panda), panda.kinematics
    for q, obstacles in panda_cases:
        packed = pack_obstacles(obstacles)
        centres, bounds = obstacle_bounds(packed)
        for bound in (bounds, np.full(len(bounds), np.inf)):
            obstacle_set = _core_obstacles(packed, centres, bound)
            rotations, origins = panda.joint_frames(q)
            for world in (model.world_segments(np.ascontiguousarray(rotations), np.ascontiguousarray(origins)),
                          model.near_segments(np.ascontiguousarray(rotations), np.ascontiguousarray(origins),
                                              obstacle_set)):
                for cutoff in (math.inf, 0.3, 0.05):  # near segments too: the stale (NaN) rows are never read
                    obstacle, own = _fill_reference(panda, (world.cap_a, world.cap_b, world.prim_a, world.prim_b),
                                                    packed, centres, bound, cutoff)
                    got = model.fill_clearances(world, obstacle_set, cutoff)
                    assert _same(got.obstacle, obstacle) and _same(got.own, own)
                    assert not np.isnan(got.obstacle).any()
            want_obstacle, want_own = _clearances_reference(panda, q, packed, centres, bound)
            got = model.clearances_at(q, k.parents, k.place_rot, k.place_pos, k.axes, k.kinds, obstacle_set)
            assert _same(got.obstacle, want_obstacle) and _same(got.own, want_own)
            at_frames = model.clearances(np.ascontiguousarray(rotations), np.ascontiguousarray(origins), obstacle_set)
            assert _same(at_frames.obstacle, want_obstacle) and _same(at_frames.own, want_own)


def test_the_one_link_obstacle_distance_serves_the_assistance_and_the_whole_body(
        panda: RobotModel, panda_cases: list) -> None:
    """The callers' loops over link_obstacle_distance_below, as its header documents them, reproduce the
    assistance's nearest pair (the core's nearest_link, src/core/shared_control/assist) and the whole-body step's
    clearance and nearest pair (_obstacle_rows' two levels, written out here as that kernel has them) to the bit."""
    from pfield.field import FieldConfig
    from pfield.shared_control import AssistanceScene
    from pfield.shared_control.assistance import _MODES, _workspace

    model, g = _link_model(panda), panda.geometry
    for q, obstacles in panda_cases:
        packed = pack_obstacles(obstacles)
        kinds, rows, meshes = packed.kinds, packed.rows, mesh_addresses(packed)
        centres, bounds = obstacle_bounds(packed)
        obstacle_set = _core_obstacles(packed, centres, bounds)
        rotations, origins = (np.ascontiguousarray(v) for v in panda.joint_frames(q))
        world = model.near_segments(rotations, origins, obstacle_set)
        # the assistance: cutoff = fine_cutoff = the best so far, a pair replaces it when exact and nearer
        nearest = _workspace(AssistanceScene(config=FieldConfig(), obstacles=obstacles), panda).assist(
            q, np.zeros(6), _MODES["safety_only"], 0.0)
        want = (nearest.nearest_link, nearest.nearest, nearest.distance, *nearest.normal, *nearest.robot_point)
        best = None
        for c in range(len(g.radii)):
            for i in range(len(obstacles)):
                limit = math.inf if best is None else best.distance
                pair = model.link_obstacle_distance(world, obstacle_set, c, i, limit, limit)
                if pair.exact and pair.distance < limit:
                    best = pair
        assert best is not None
        assert (best.link, best.obstacle) == (want[0], want[1]) and _same(best.distance, want[2])
        assert _same(best.normal, want[3:6])
        # its witness point on the link's surface, from the pair's axis point
        axis_point = np.array(best.point)
        radius = obstacle_signed_distance(packed, best.obstacle, axis_point)[0] - best.distance
        assert _same(axis_point - radius * np.array(best.normal), want[6:9])
        # the whole body: cutoff = fine_cutoff = Q; a Culled pair only lowers the clearance
        influence, scratch = 0.3, np.empty((2, 3))
        cap_a, cap_b, prim_a, prim_b = world.cap_a, world.cap_b, world.prim_a, world.prim_b
        for_core = [math.inf, math.inf, -1, -1]
        for_numba = [math.inf, math.inf, -1, -1]
        for c in range(len(g.radii)):
            for i in range(len(obstacles)):
                pair = model.link_obstacle_distance(world, obstacle_set, c, i, influence, influence)
                for_core[0] = min(for_core[0], pair.distance)
                if pair.level != core.ClearanceLevel.Culled and pair.distance < for_core[1]:
                    for_core[1:] = [pair.distance, c, i]
                lower = nb_clearance.capsule_lower_bound(centres, bounds, i, cap_a, cap_b, g.radii, c)
                if lower >= influence:
                    for_numba[0] = min(for_numba[0], lower)
                    continue
                d, exact, *_ = nb_clearance.capsule_level_distance(kinds, rows, meshes, i, *cap_a[c], *cap_b[c],
                                                                   g.radii[c], scratch)
                if not exact and d < influence:
                    d, exact, *_ = nb_clearance.fitted_distance_below(
                        kinds, rows, meshes, i, *centres[i], bounds[i], g.link_start[c], g.link_start[c + 1],
                        prim_a, prim_b, g.prim_r, scratch, influence)
                for_numba[0] = min(for_numba[0], d)
                if d < for_numba[1]:
                    for_numba[1:] = [d, c, i]
        assert _same(for_core[:2], for_numba[:2]) and for_core[2:] == for_numba[2:]


def test_capsule_clearances_runs_the_core(panda: RobotModel) -> None:
    """The public clearances are the core's, which equal numba's (above); and refuse malformed arrays."""
    from pfield.robot.collision import capsule_clearances

    rng = np.random.default_rng(8)
    obstacles = _robot_scene(rng, _shapes())
    q = _configurations(panda, rng, 1)[0]
    report = capsule_clearances(panda, q, obstacles)
    k, g = panda.kinematics, panda.geometry
    packed = pack_obstacles(obstacles)
    want_obstacle, want_own = _clearances_reference(panda, q, packed, np.ascontiguousarray(packed.rows[:, 0:3]),
                                                    np.full(len(obstacles), np.inf))
    assert _same(report.obstacle, want_obstacle) and _same(report.self_pairs, want_own)
    with pytest.raises(ValueError, match="link_start"):
        core.LinkModel(g.joints, g.a, g.b, g.radii, g.self_radii, g.self_pairs, g.link_start[:-1], g.prim_joint,
                       g.prim_a, g.prim_b, g.prim_r)
    with pytest.raises(ValueError, match="self pair"):
        core.LinkModel(g.joints, g.a, g.b, g.radii, g.self_radii, g.self_pairs + len(g.radii), g.link_start,
                       g.prim_joint, g.prim_a, g.prim_b, g.prim_r)
    model = _link_model(panda)
    with pytest.raises(ValueError, match="joint"):
        model.world_segments(np.zeros((2, 3, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="parents"):
        model.clearances_at(q, k.parents[::-1].copy(), k.place_rot, k.place_pos, k.axes, k.kinds,
                            _core_obstacles(packed, packed.rows[:, 0:3], np.full(len(obstacles), np.inf)))
