"""Link capsules, continuous link–obstacle closest points, and the collision checks."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pfield import errors
from pfield._core import robot_distance as _distance
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
)
from pfield.geometry.packed import PackedObstacles
from pfield.planning._whole_body_core import core_obstacles, core_robot
from pfield.planning.whole_body import WholeBodyOptions, make_scene, pack_robot
from pfield.robot import RobotModel
from pfield.robot.collision import CollisionChecker, capsule_clearances
from pfield.robot.geometry import fit_capsule
from pfield.spatial import Pose, quaternion_exp

DATA = Path(__file__).resolve().parents[1] / "data"
FINE_RANGE = 0.1
"""(m) From here on a link's bounding capsule stands for its fitted primitives (src/core/robot/clearance.hpp)."""


def _obstacle_set(packed: PackedObstacles) -> Any:
    """The core's obstacles with their bounding spheres (as the planners bind them)."""
    return core_obstacles(make_scene(packed))


def segment_obstacle_distance(obstacles: Any, i: int, a: np.ndarray, b: np.ndarray) -> tuple[float, ...]:
    """(d, t, normal) of the core's segment–obstacle distance to obstacle i of ``obstacles`` (:func:`_obstacle_set`)."""
    found = _distance.segment_obstacle_distance(obstacles, i, np.asarray(a, dtype=np.float64),
                                                np.asarray(b, dtype=np.float64))
    return (found.distance, found.t, *found.normal)


def _segment_distance_to_points(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    t = np.clip((points - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * d), axis=1)


@pytest.mark.parametrize("name", ["xarm7", "panda"])
def test_capsules_cover_every_collision_vertex(name: str, xarm: RobotModel, panda: RobotModel) -> None:
    robot = xarm if name == "xarm7" else panda
    model = robot.pinocchio_model
    capsules = {c.link: c for c in robot.geometry.capsules}
    for obj in robot.collision_model.geometryObjects:
        capsule = capsules[model.frames[obj.parentFrame].name]
        if hasattr(obj.geometry, "vertices"):
            local = np.asarray(obj.geometry.vertices()).reshape(-1, 3)
        else:  # panda finger boxes
            half = np.asarray(obj.geometry.halfSide)
            local = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
        points = local @ obj.placement.rotation.T + obj.placement.translation
        assert _segment_distance_to_points(points, capsule.a, capsule.b).max() <= capsule.radius + 1e-9
        assert capsule.volume_ratio >= 1.0
        assert 0.0 <= capsule.mean_gap < capsule.radius


def test_fit_capsule_of_a_cylinder_is_tight() -> None:
    angles = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    ring = np.stack([0.05 * np.cos(angles), 0.05 * np.sin(angles), np.zeros(64)], axis=1)
    lift = np.array([0.0, 0.0, 0.2])
    points = np.concatenate([ring + lift, ring - lift])
    capsule = fit_capsule(points)
    assert capsule.radius == pytest.approx(0.05, abs=1e-3)
    # the shortest covering segment stops where the cap sphere still reaches the rim: |t| = 0.2
    assert np.linalg.norm(capsule.b - capsule.a) == pytest.approx(0.4, abs=2e-3)


def test_self_pairs_honour_the_srdf(xarm: RobotModel, panda: RobotModel) -> None:
    for robot in (xarm, panda):
        names = robot.geometry.link_names
        assert robot.disabled_pairs is not None
        for i, j in robot.geometry.self_pairs:
            assert frozenset((names[i], names[j])) not in robot.disabled_pairs
            assert robot.geometry.capsules[i].joint != robot.geometry.capsules[j].joint
    xarm_pairs = {frozenset((xarm.geometry.link_names[i], xarm.geometry.link_names[j]))
                  for i, j in xarm.geometry.self_pairs}
    assert frozenset(("link2", "link6")) in xarm_pairs


def _obstacles() -> list[Obstacle]:
    turn = Pose(orientation=quaternion_exp([0.3, -0.2, 0.5])).orientation
    cube = Mesh(str(DATA / "meshes" / "unit_cube.stl"), 0.2, 0.1, 0.15,
                resolver=ResourceResolver(allowed_roots=[DATA / "meshes"]))
    return [
        Obstacle("sphere", Sphere(0.1), Pose((0.4, 0.1, 0.2))),
        Obstacle("box", Box(0.2, 0.1, 0.3), Pose((0.3, -0.2, 0.4), turn)),
        Obstacle("cylinder", Cylinder(0.08, 0.3), Pose((0.5, 0.2, 0.1), turn)),
        Obstacle("ellipsoid", Ellipsoid(0.1, 0.05, 0.15), Pose((0.2, 0.3, 0.3), turn)),
        Obstacle("capsule", Capsule(0.05, 0.2), Pose((0.6, -0.1, 0.3), turn)),
        Obstacle("mesh", cube, Pose((0.4, 0.0, 0.5), turn)),
    ]


def test_segment_obstacle_distance_is_the_minimum_along_the_segment() -> None:
    shapes = _obstacles()
    obstacles = _obstacle_set(pack_obstacles(shapes))
    rng = np.random.default_rng(3)
    samples = np.linspace(0.0, 1.0, 2001)
    for _ in range(40):
        a, b = rng.uniform(-0.1, 0.8, 3), rng.uniform(-0.1, 0.8, 3)
        points = a + samples[:, None] * (b - a)
        for i, obstacle in enumerate(shapes):
            d, t, *normal = segment_obstacle_distance(obstacles, i, a, b)
            dense, _ = obstacle.signed_distance(points)
            # never above the true minimum by more than the sampling error, never below it
            assert d <= dense.min() + 1e-6
            assert d >= dense.min() - np.linalg.norm(b - a) / 2000 - 1e-9
            at_t, grad = obstacle.signed_distance(a + t * (b - a))
            assert d == pytest.approx(float(at_t[0]), abs=1e-12)
            np.testing.assert_allclose(normal, grad[0], atol=1e-9)


def test_box_segment_distance_in_closed_form() -> None:
    """Boxes are minimised in closed form: exact values where geometry gives them, and over random segments,
    penetrating ones included, never above a dense sampling's minimum nor below it by more than half a step (the
    signed distance is 1-Lipschitz)."""
    turn = Pose(orientation=quaternion_exp([0.3, -0.2, 0.5])).orientation
    box = Obstacle("box", Box(0.6, 0.4, 0.2), Pose((0.1, -0.2, 0.3), turn))
    obstacles = _obstacle_set(pack_obstacles([box]))
    rotation, centre = box.pose.rotation, np.array(box.pose.position)

    def world(*local: float) -> np.ndarray:
        return centre + rotation @ np.array(local)

    # parallel to the +z face, 0.05 above it (a flat minimum: rounding picks the t)
    d, t, *normal = segment_obstacle_distance(obstacles, 0, world(-0.2, 0.0, 0.15), world(0.2, 0.0, 0.15))
    assert d == pytest.approx(0.05, abs=1e-12) and 0.0 <= t <= 1.0
    np.testing.assert_allclose(normal, rotation[:, 2], atol=1e-12)
    # passing the edge x = 0.3, z = 0.1 diagonally: nearest at t = 0.4, (0.42, 0.16), 0.06/√0.2 from the edge
    d, t, *_ = segment_obstacle_distance(obstacles, 0, world(0.5, 0.0, 0.0), world(0.3, 0.0, 0.4))
    assert d == pytest.approx(0.06 / np.sqrt(0.2), abs=1e-12) and t == pytest.approx(0.4, abs=1e-12)
    # through the box along x: deepest where it is 0.1 from the ±z faces
    d, _, *_ = segment_obstacle_distance(obstacles, 0, world(-1.0, 0.0, 0.0), world(1.0, 0.0, 0.0))
    assert d == pytest.approx(-0.1, abs=1e-12)
    # a point (a == b) is the point's own distance
    d, t, *_ = segment_obstacle_distance(obstacles, 0, world(0.0, 0.5, 0.0), world(0.0, 0.5, 0.0))
    assert d == pytest.approx(0.3, abs=1e-12) and t == 0.0
    rng = np.random.default_rng(8)
    samples = np.linspace(0.0, 1.0, 2001)
    for _ in range(500):
        a, b = centre + rng.normal(size=3) * 0.4, centre + rng.normal(size=3) * 0.4
        d, t, *_ = segment_obstacle_distance(obstacles, 0, a, b)
        dense = float(box.signed_distance(a + samples[:, None] * (b - a))[0].min())
        assert dense - np.linalg.norm(b - a) / 4000 - 1e-12 <= d <= dense + 1e-12
        assert d == pytest.approx(float(box.signed_distance(a + t * (b - a))[0][0]), abs=1e-12)


def test_segment_segment_distance_matches_sampling() -> None:
    rng = np.random.default_rng(4)
    s = np.linspace(0, 1, 401)
    for _ in range(100):
        p1, q1, p2, q2 = rng.normal(size=(4, 3))
        first = p1 + s[:, None] * (q1 - p1)
        second = p2 + s[:, None] * (q2 - p2)
        dense = np.linalg.norm(first[:, None] - second[None], axis=2).min()
        exact = _distance.segment_segment_distance(p1, q1, p2, q2)
        assert exact <= dense + 1e-12
        assert exact >= dense - 0.01


def _point_segment_reference(c: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """The culling distance as the array form computed it (its operations in their order, in Python floats)."""
    d = [float(b[k] - a[k]) for k in range(3)]
    length2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    t = 0.0 if length2 <= 1e-14 else min(max(((c[0] - a[0]) * d[0] + (c[1] - a[1]) * d[1] + (c[2] - a[2]) * d[2])
                                              / length2, 0.0), 1.0)
    total = 0.0
    for k in range(3):
        diff = float(c[k] - (a[k] + t * (b[k] - a[k])))
        total += diff * diff
    return math.sqrt(total)


def test_point_segment_distance_keeps_the_culling_bit_for_bit() -> None:
    """The core's point–segment distance (the culling's) is the array form's, operation for operation: plans do not
    change by a bit with the form."""
    rng = np.random.default_rng(5)
    for _ in range(300):
        c, a, b = rng.normal(size=(3, 3))
        if rng.random() < 0.2:
            b = a.copy()  # a point segment
        dense = np.linalg.norm(a + np.linspace(0.0, 1.0, 2001)[:, None] * (b - a) - c, axis=1).min()
        scalar = _distance.point_segment_distance(c, a, b)
        assert scalar == _point_segment_reference(c, a, b)
        assert dense - 1e-3 <= scalar <= dense + 1e-12


def test_capsule_clearances_are_conservative_against_coal(xarm: RobotModel) -> None:
    obstacles = _obstacles()[:5]
    checker = CollisionChecker(xarm, obstacles)
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = rng.uniform(np.maximum(xarm.lower_limits, -3), np.minimum(xarm.upper_limits, 3))
        capsule = capsule_clearances(xarm, q, obstacles).obstacle
        exact, _, _, _ = checker.distances(q)
        # the fitted model covers the links (the base link excluded: fixed): no farther than the meshes when
        # apart, and in contact whenever they are (penetration depths of a union and a hull differ)
        if exact >= 0.0:
            assert capsule[1:].min() <= exact + 1e-6
        else:
            assert capsule[1:].min() < 0.0


def test_capsule_clearances_are_named(xarm: RobotModel) -> None:
    obstacles = _obstacles()[:3]
    q = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])
    result = capsule_clearances(xarm, q, obstacles)
    assert result.links == xarm.geometry.link_names
    assert result.obstacle_ids == tuple(o.id for o in obstacles)
    assert result.obstacle.shape == (len(result.links), len(obstacles))
    assert len(result.pair_links) == len(result.self_pairs) == len(xarm.geometry.self_pairs)
    link, obstacle_id, distance = result.nearest()
    assert distance == result.obstacle.min() == result.between(link, obstacle_id)


def test_collision_checker_detects_contact_and_margin(xarm: RobotModel) -> None:
    q0 = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])
    tip = xarm.forward_kinematics(q0).position
    touching = CollisionChecker(xarm, [Obstacle("ball", Sphere(0.03), Pose(tip))])
    report = touching.check(q0)
    assert report.in_collision and "ball" in report.pair
    far = CollisionChecker(xarm, [Obstacle("ball", Sphere(0.03), Pose(tip + np.array([0.0, 0.0, 0.3])))])
    clear = far.check(q0)
    assert not clear.in_collision
    assert far.check(q0, margin=clear.distance + 0.01).in_collision
    with pytest.raises(errors.InvalidInput):
        far.check(q0, margin=-0.1)


def test_without_srdf_only_adjacent_links_are_excluded() -> None:
    from pfield.robot.catalog import example_robot_data_root

    root = example_robot_data_root()
    robot = RobotModel.from_urdf(root / "robots/xarm_description/urdf/xarm7.urdf", end_effector="link_eef",
                                 package_paths={"example-robot-data": root})
    assert robot.disabled_pairs is None
    names = robot.geometry.link_names
    pairs = {frozenset((names[i], names[j])) for i, j in robot.geometry.self_pairs}
    parents = robot.kinematics.parents
    for i, j in robot.geometry.self_pairs:
        ji, jj = robot.geometry.capsules[i].joint, robot.geometry.capsules[j].joint
        assert ji != jj
        assert not (jj >= 0 and parents[jj] == ji) and not (ji >= 0 and parents[ji] == jj)  # never adjacent
    assert frozenset(("link1", "link3")) in pairs  # the SRDF disables it ("Never"); without it, it is checked


def test_the_two_distance_levels_against_each_primitive(xarm: RobotModel) -> None:
    """``capsule_level_distance`` is the bounding capsule's distance, a lower bound of every primitive's and the
    pair's value (exact) from FINE_RANGE on; ``fitted_distance_below`` is the minimum of the link's primitives'
    own distances, bit for bit; ``link_obstacle_distance`` composes the two as documented."""
    packed = pack_obstacles(_obstacles())
    obstacles = _obstacle_set(packed)
    robot = core_robot(pack_robot(xarm, FieldConfig(), WholeBodyOptions()))
    g = xarm.geometry
    seen = {"far": 0, "near": 0, "cut": 0}
    rng = np.random.default_rng(3)
    for q in rng.uniform(np.maximum(xarm.lower_limits, -2.5), np.minimum(xarm.upper_limits, 2.5), size=(6, 7)):
        rotations, origins = xarm.joint_frames(q)
        world = _distance.world_segments(robot, rotations, origins)
        for c in range(1, len(g.radii)):  # the base link is fixed
            start, stop = int(g.link_start[c]), int(g.link_start[c + 1])
            for i in range(len(packed.kinds)):
                own = [segment_obstacle_distance(obstacles, i, world.prim_a[p], world.prim_b[p])[0] - g.prim_r[p]
                       for p in range(start, stop)]
                coarse = _distance.capsule_level_distance(obstacles, i, world.cap_a[c], world.cap_b[c], g.radii[c])
                assert coarse.distance <= min(own) + 1e-12 and coarse.exact == (coarse.distance >= FINE_RANGE)
                fine = _distance.fitted_distance_below(robot, world, obstacles, c, i)
                assert fine.distance == min(own) and fine.exact
                pair = _distance.link_obstacle_distance(robot, world, obstacles, c, i, math.inf, 0.05)
                if coarse.exact:  # far: the bounding capsule stands for the pair
                    seen["far"] += 1
                    assert (pair.distance, pair.exact, pair.point, pair.normal) == \
                        (coarse.distance, coarse.exact, coarse.point, coarse.normal)
                elif min(own) < 0.05:  # near and below the cutoff: the primitives, exactly
                    seen["near"] += 1
                    assert pair.distance == min(own) and pair.exact
                else:  # at or beyond the cutoff: only that it is, never a value below it
                    seen["cut"] += 1
                    assert pair.distance >= 0.05 and pair.distance >= coarse.distance
    assert min(seen.values()) > 0, seen
