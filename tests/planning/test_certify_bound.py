"""The certificate's cheap bound (issue 34): covering capsules decide most pairs, coal the rest, same verdict.

* every vertex of every collision element of every link lies within the link's covering capsule (the claim of
  pfield.robot.geometry the bound rests on), on the built-in robots and the UR5 + Robotiq of the MBM set;
* the per-object capsule bound (:meth:`CollisionChecker.covering_distances`) is never above coal's distances, against
  every kind of obstacle (ellipsoids and meshes through boxes that contain them);
* :func:`certify_path` (bound first, coal where the bound cannot clear) returns exactly the verdict of coal on every
  pair at every grid configuration, on random paths past obstacles of every exact kind, both outcomes exercised.
"""

from __future__ import annotations

from collections.abc import Callable

import coal
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core_scenes import UR5_FOREARM_WRIST_2, needs_ur5, random_configuration, random_three_waypoints, ur5_at_tool0
from pfield import Box, Obstacle, Pose, RobotModel
from pfield.errors import InvalidInput
from pfield.geometry import Capsule, Cylinder, Ellipsoid, Mesh, Sphere
from pfield.planning.certify import certify_path, resolution_grid
from pfield.robot.catalog import BUILTIN_ROBOTS
from pfield.robot.collision import CollisionChecker


def _robot(name: str) -> RobotModel:
    return ur5_at_tool0() if name == "ur5" else RobotModel.builtin(name)


ROBOTS = [*BUILTIN_ROBOTS, pytest.param("ur5", marks=needs_ur5)]


def _element_points(shape: object) -> tuple[np.ndarray, float]:
    """Points of a collision element (its frame) and a radius r: the element is the union of the balls of radius r
    about the points' convex hull (meshes: their vertices, r = 0; boxes: the corners; spheres: the centre)."""
    if isinstance(shape, coal.BVHModelBase):
        return np.asarray(shape.vertices(), dtype=np.float64).reshape(-1, 3), 0.0
    if isinstance(shape, coal.Box):
        half = np.asarray(shape.halfSide)
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half, 0.0
    if isinstance(shape, coal.Sphere):
        return np.zeros((1, 3)), float(shape.radius)
    if isinstance(shape, coal.Capsule):
        return np.array([[0.0, 0.0, -shape.halfLength], [0.0, 0.0, shape.halfLength]]), float(shape.radius)
    raise AssertionError(f"no exact containment test for {type(shape).__name__}")


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    t = np.clip((points - a) @ d / max(float(d @ d), 1e-300), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * d), axis=1)


@pytest.mark.parametrize("name", ROBOTS)
def test_covering_capsule_contains_every_collision_vertex(name: str) -> None:
    """Each link's covering capsule (axis a–b, radius self_radii, its joint's frame) contains every vertex of every
    collision element of the link, placed by the element's placement in that joint frame — so, being convex, their
    hulls and the meshes."""
    robot = _robot(name)
    geometry = robot.geometry
    links = {link: l for l, link in enumerate(geometry.link_names)}
    model, checked = robot.pinocchio_model, set()
    for obj in robot.collision_model.geometryObjects:
        l = links[model.frames[obj.parentFrame].name]
        assert int(geometry.joints[l]) == int(obj.parentJoint) - 1
        points, radius = _element_points(obj.geometry)
        placed = points @ np.asarray(obj.placement.rotation).T + np.asarray(obj.placement.translation)
        reach = _segment_distance(placed, geometry.a[l], geometry.b[l]) + radius
        # within rounding (the fit measured the vertices in the link frame, here they pass through two transforms)
        assert reach.max() <= geometry.self_radii[l] + 1e-12, (name, obj.name, reach.max() - geometry.self_radii[l])
        checked.add(l)
    assert checked == set(range(len(geometry.link_names)))  # every link has its elements checked


def _rock() -> Mesh:
    """A lumpy closed mesh (an icosphere with its vertices pushed in and out), off-centre in its frame."""
    import trimesh

    ball = trimesh.creation.icosphere(subdivisions=1, radius=0.05)
    lumps = 1.0 + 0.3 * np.sin(7.0 * ball.vertices[:, 0] / 0.05 + 3.0 * ball.vertices[:, 2] / 0.05)
    return Mesh.from_arrays(ball.vertices * lumps[:, None] + (0.02, -0.01, 0.03), ball.faces, "rock")


def _obstacles(robot: RobotModel, q: np.ndarray, rng: np.random.Generator, spread: float) -> list[Obstacle]:
    """One obstacle of each kind near the end effector at ``q`` (``spread``: how far off, m)."""
    centre = robot.forward_kinematics(q).position
    shapes = [Box(0.1, 0.08, 0.12), Sphere(0.05), Cylinder(0.04, 0.15), Capsule(0.03, 0.1),
              Ellipsoid(0.06, 0.03, 0.09), _rock()]
    out = []
    for k, shape in enumerate(shapes):
        direction = rng.normal(size=3)
        offset = direction / np.linalg.norm(direction) * spread * rng.uniform(1.0, 1.5)
        orientation = Rotation.from_rotvec(rng.normal(size=3)).as_quat()  # (x, y, z, w), as Pose takes it
        out.append(Obstacle(f"o{k}", shape, Pose(centre + offset, orientation)))
    return out


@pytest.mark.parametrize("name", ["panda", pytest.param("ur5", marks=needs_ur5)])
def test_covering_bound_is_never_above_coal(name: str) -> None:
    """At random configurations near obstacles of every kind, each pair's capsule bound ≤ coal's hull distance
    (itself ≤ the meshes') where that is positive, and where coal finds contact the bound is not positive (a
    penetration depth is not bounded: the certificate and the checks read only the sign there); the ellipsoid's and
    the mesh's bounds (through their boxes) are finite and clear some pairs."""
    robot = _robot(name)
    rng = np.random.default_rng(11)
    below = proxied_cleared = 0
    for _ in range(8):
        q = random_configuration(robot, rng)
        checker = CollisionChecker(robot, _obstacles(robot, q, rng, 0.08))
        bound = checker.covering_distances(q[None])[:, 0]
        exact = checker.pair_distances(q, np.arange(len(checker.pair_names)))
        clear = exact > 0.0
        assert bound.shape == exact.shape and np.all(bound[clear] <= exact[clear] + 1e-9)
        assert np.all(bound[~clear] <= 0.0)
        below += int(np.sum(bound > 0.0))
        proxied = [p for p, pair in enumerate(checker.pair_names) if pair.endswith(("/o4", "/o5"))]
        assert np.all(np.isfinite(bound[proxied]))
        proxied_cleared += int(np.sum(bound[proxied] > 0.0))
    assert below > 0 and proxied_cleared > 0  # the bound clears pairs, it is not −inf everywhere


@pytest.mark.parametrize("name", ["panda", pytest.param("ur5", marks=needs_ur5)])
def test_one_sided_self_distances_are_lower_bounds_with_the_meshes_sign(name: str) -> None:
    """The certificate's self pairs whose hulls touch (``pair_distances(lower=True)``): a positive value never
    above the meshes' distance, and no contact where the meshes have none; where the meshes touch, their own
    answer. At random configurations of the UR5 the one-sided distance answers (positive below the meshes' value)
    for some pairs, its forearm and wrist_2 among them (the Panda's hulls touch at none of these)."""
    robot = _robot(name)
    checker = CollisionChecker(robot)
    own = np.flatnonzero(checker.self_pair)
    rng = np.random.default_rng(3)
    answered = set()
    contacts = 0
    known = [UR5_FOREARM_WRIST_2] if name == "ur5" else []  # a configuration with meshes in contact
    for q in [*known, *(random_configuration(robot, rng) for _ in range(40))]:
        exact = checker.pair_distances(q, own)
        lower = checker.pair_distances(q, own, lower=True)
        clear = exact > 0.0
        assert np.all(lower[clear] > 0.0) and np.all(lower[clear] <= exact[clear] + 1e-9)
        np.testing.assert_array_equal(lower[~clear], exact[~clear])
        contacts += int(np.sum(~clear))
        answered |= {checker.pair_names[p] for p in own[clear & (lower < exact)]}
    if name == "ur5":
        assert contacts > 0  # the contact branch ran
        assert any(pair.startswith("forearm_link") and "wrist_2_link" in pair for pair in answered), answered


def _plain_verdict(checker: CollisionChecker, qs: np.ndarray) -> tuple[int, int, float] | None:
    """Coal on every pair at every grid configuration: (first grid index in contact, its closest pair, distance)."""
    grid, _, _ = resolution_grid(qs, 0.01)
    every = np.arange(len(checker.pair_names))
    for index, q in enumerate(grid):
        distances = checker.pair_distances(q, every)
        worst = int(np.argmin(distances))
        if distances[worst] <= 0.0:
            return index, worst, float(distances[worst])
    return None


@pytest.mark.parametrize("name", ["panda", pytest.param("ur5", marks=needs_ur5)])
def test_fast_certificate_agrees_with_coal_on_every_grid_configuration(name: str) -> None:
    """Random three-waypoint paths past a box, a sphere, a cylinder and a capsule, from touching the gripper to
    well clear: the certificate's verdict, first contact (grid index), pair and distance are those of coal run on
    every pair at every grid configuration; both outcomes occur, and clear paths need fewer coal calls than the
    plain check's."""
    robot = _robot(name)
    rng = np.random.default_rng(5)
    outcomes = []
    for trial in range(10):
        qs = random_three_waypoints(robot, rng, 0.4)
        obstacles = _obstacles(robot, qs[1], rng, 0.05 * trial)
        checker = CollisionChecker(robot, obstacles)
        certificate = certify_path(robot, obstacles, qs, 0.01, checker)
        plain = _plain_verdict(checker, qs)
        assert certificate.clear == (plain is None), trial
        if plain is not None:
            index, pair, distance = plain
            assert certificate.grid_points == index + 1, trial
            assert certificate.pair == checker.pair_names[pair] and certificate.distance == pytest.approx(distance)
            grid, segment, fraction = resolution_grid(qs, 0.01)
            assert certificate.waypoint == segment[index] and certificate.fraction == pytest.approx(fraction[index])
            np.testing.assert_allclose(certificate.configuration, grid[index])
        else:
            assert certificate.distance_calls < certificate.grid_points * len(checker.pair_names)
        outcomes.append(certificate.clear)
    assert any(outcomes) and not all(outcomes)


@pytest.mark.parametrize("name", ["panda", pytest.param("ur5", marks=needs_ur5)])
def test_far_obstacles_need_no_coal_call(name: str) -> None:
    """A path standing still with an obstacle 2 m away: the capsules clear every obstacle pair, so coal runs once
    for each self pair the capsules cannot clear, and its distance carries that pair over the rest of the path."""
    robot = _robot(name)
    far = [Obstacle("far", Box(0.1, 0.1, 0.1), Pose((2.5, 0.0, 0.5)))]
    checker = CollisionChecker(robot, far)
    q = robot.mid_configuration
    bound = checker.covering_distances(q[None])[:, 0]
    obstacle_pairs = ~checker.self_pair
    assert np.all(bound[obstacle_pairs] > 1.0)
    certificate = certify_path(robot, far, np.array([q, q]), 0.01, checker)
    assert certificate.clear
    assert certificate.distance_calls == int(np.sum(bound[checker.self_pair] <= 1e-6))


def _walk(bound: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """The covering stage's walk, written out: (P, N) where neither the bound nor its advancement clears a pair."""
    needed = np.zeros(bound.shape, dtype=bool)
    for p in range(bound.shape[0]):
        k = 0
        while k < bound.shape[1]:
            if not bound[p, k] > 0.0:
                needed[p, k], k = True, k + 1
                continue
            k = max(k + 1, int(np.searchsorted(reach[p], reach[p, k] + bound[p, k], side="left")))
    return needed


@pytest.mark.parametrize("name", ["panda", pytest.param("ur5", marks=needs_ur5)])
def test_covering_needed_is_the_walk_on_the_bound_and_refuses_bad_shapes(name: str) -> None:
    """The compiled walk marks exactly the grid points the written-out walk on :meth:`covering_distances` and the
    motion bound marks (the tolerance taken off the bound), an ellipsoid's pairs among them (bounded through the box
    of its semi-axes, so the walk clears grid points of theirs too); arrays of the wrong shape are refused."""
    robot = _robot(name)
    rng = np.random.default_rng(2)
    q_a = random_configuration(robot, rng)
    qs = np.array([q_a, np.clip(q_a + rng.normal(size=robot.n_joints) * 0.5, robot.lower_limits, robot.upper_limits)])
    egg = Obstacle("egg", Ellipsoid(0.05, 0.04, 0.08), Pose(robot.forward_kinematics(q_a).position + 0.3))
    checker = CollisionChecker(robot, [*_obstacles(robot, q_a, rng, 0.15), egg])
    grid, _, _ = resolution_grid(qs, 0.01)
    travel = np.vstack([np.zeros((1, robot.n_joints)), np.cumsum(np.abs(np.diff(grid, axis=0)), axis=0)])
    reach = travel @ checker.motion_weights.T
    needed = checker.covering_needed(grid, travel, 1e-6)
    expected = _walk(checker.covering_distances(grid) - 1e-6, reach.T)
    assert needed.shape == expected.shape and 0 < needed.sum() < needed.size  # the bound clears some, not all
    assert np.array_equal(needed, expected)
    egg_pairs = [p for p, pair in enumerate(checker.pair_names) if pair.endswith("/egg")]
    assert egg_pairs and not needed[egg_pairs].all()
    with pytest.raises(ValueError, match="travel"):
        checker.covering_needed(grid, travel[:-1], 1e-6)
    with pytest.raises(ValueError, match="qs"):
        checker.covering_needed(grid[:, :-1], travel, 1e-6)


def _counting(pair_distances: Callable[..., np.ndarray], calls: list[int]) -> Callable[..., np.ndarray]:
    """``pair_distances`` that appends the number of pairs of each call to ``calls``."""

    def counted(q: np.ndarray, pairs: np.ndarray, refine: float = 0.0) -> np.ndarray:
        calls.append(len(pairs))
        return pair_distances(q, pairs, refine)

    return counted


@pytest.mark.parametrize("name", ["panda", pytest.param("ur5", marks=needs_ur5)])
def test_distances_are_those_of_coal_on_every_pair(name: str) -> None:
    """:meth:`CollisionChecker.distances` (branch and bound on the covering capsules) answers what coal on every pair
    answers — each class's smallest distance and its first pair — at random configurations near obstacles of every
    kind, in contact and clear, with coal run on a fraction of the pairs where the robot is clear."""
    robot = _robot(name)
    rng = np.random.default_rng(23)
    outcomes, asked, every = [], 0, 0
    for trial in range(12):
        q = random_configuration(robot, rng)
        checker = CollisionChecker(robot, _obstacles(robot, q, rng, 0.03 * trial))
        values = checker.pair_distances(q, np.arange(len(checker.pair_names)))
        expected = []
        for pairs in (np.flatnonzero(~checker.self_pair), np.flatnonzero(checker.self_pair)):
            first = int(pairs[np.argmin(values[pairs])])
            expected += [float(values[first]), checker.pair_names[first]]
        calls: list[int] = []
        checker.pair_distances = _counting(checker.pair_distances, calls)  # type: ignore[method-assign]
        assert list(checker.distances(q)) == expected, trial
        contact = expected[0] <= 0.0 or expected[2] <= 0.0
        outcomes.append(contact)
        assert checker.check(q).in_collision == contact
        if not contact:
            asked, every = asked + sum(calls[:2]), every + len(values)
    assert any(outcomes) and not all(outcomes)
    assert asked < every / 2


@pytest.mark.parametrize("name", ["panda", pytest.param("ur5", marks=needs_ur5)])
def test_contact_is_checks_verdict(name: str) -> None:
    """:meth:`CollisionChecker.contact` is None exactly where :meth:`CollisionChecker.check` finds nothing within
    the margin, and :meth:`check`'s report otherwise, at random configurations near obstacles of every kind and
    margins 0, 1 cm and 5 cm; a bad margin is refused by name."""
    robot = _robot(name)
    rng = np.random.default_rng(29)
    verdicts = []
    for trial in range(12):
        q = random_configuration(robot, rng)
        checker = CollisionChecker(robot, _obstacles(robot, q, rng, 0.03 * trial))
        for margin in (0.0, 0.01, 0.05):
            report, found = checker.check(q, margin), checker.contact(q, margin)
            assert (found is None) == (not report.in_collision), (trial, margin)
            assert found is None or found == report
            verdicts.append(report.in_collision)
    assert any(verdicts) and not all(verdicts)
    with pytest.raises(InvalidInput, match="margin"):
        CollisionChecker(robot, []).contact(robot.mid_configuration, -0.01)


def _farthest_from_axis(points: np.ndarray, origin: np.ndarray, axis: np.ndarray) -> float:
    """The largest distance (m) of ``points`` (world) from the line through ``origin`` along unit ``axis``."""
    offsets = points - origin
    return float(np.sqrt(np.maximum(np.sum(offsets**2, axis=1) - (offsets @ axis) ** 2, 0.0)).max())


@needs_ur5
def test_a_self_pair_turned_about_one_links_axis_is_bounded_by_that_links_distance_from_it() -> None:
    """The UR5's base and upper arm: the shoulder pan and lift move the upper arm (up to 0.51 and 0.48 m from their
    axes) about the base, whose hull is never further than the pair's weights from the pan axis (fixed in its frame:
    exactly its largest distance) nor from the lift axis (which passes through a point of the pan axis); and the
    meshes' distance changes no faster than those weights say, against coal on small shoulder motions."""
    from pfield.robot import collision

    robot = ur5_at_tool0()
    checker = CollisionChecker(robot, [])
    pair = checker.pair_names.index("base_link_0/upper_arm_link_0")
    base = checker._records[pair][0]
    weights = checker.motion_weights[pair]
    assert np.all(weights[2:] == 0.0)
    upper = checker._records[pair][1]
    tables = collision._robot_tables(robot)
    own = tables.bounds[upper]
    assert weights[0] < 0.25 * own[0] and weights[1] < 0.3 * own[1]  # 0.11 and 0.14 m against 0.51 and 0.48
    hull = tables.hulls[base]  # the base is on the root: its joint's frame is the world
    rng = np.random.default_rng(17)
    farthest = np.zeros(2)
    for _ in range(40):
        q = random_configuration(robot, rng)
        rotations, origins = robot.joint_frames(q)
        for j in (0, 1):
            distance = _farthest_from_axis(hull, origins[j], rotations[j] @ robot.kinematics.axes[j])
            assert distance <= weights[j] + 1e-12
            farthest[j] = max(farthest[j], distance)
        step = np.zeros(robot.n_joints)
        step[:2] = rng.uniform(-0.01, 0.01, size=2)
        moved = np.clip(q + step, robot.lower_limits, robot.upper_limits)
        before, after = (checker.pair_distances(c, [pair], np.inf)[0] for c in (q, moved))
        if before > 0.0 and after > 0.0:
            assert abs(after - before) <= weights @ np.abs(moved - q) + 1e-6
    assert farthest[0] == pytest.approx(weights[0], abs=1e-12)  # the pan axis is fixed in the base's frame: exact


@pytest.mark.parametrize("name", ["panda", pytest.param("ur5", marks=needs_ur5)])
def test_every_axis_bound_holds_at_random_configurations(name: str) -> None:
    """Each collision object's hull is never further from a revolute joint's axis than its bound: the one of the
    joints that move it (``bounds``) and the one of the joints that do not (``cross``, where finite), at random
    configurations (the hull's vertices in the world against the axis line)."""
    from pfield.robot import collision

    robot = _robot(name)
    tables = collision._robot_tables(robot)
    objects = robot.collision_model.geometryObjects
    revolute = np.flatnonzero(robot.kinematics.kinds == 0)
    assert np.isfinite(tables.cross).any()  # some bound of a joint that does not move the object was found
    rng = np.random.default_rng(23)
    for _ in range(25):
        rotations, origins = robot.joint_frames(random_configuration(robot, rng))
        for g, hull in enumerate(tables.hulls):
            own = int(tables.object_joint[g])
            world = hull if own < 0 else hull @ rotations[own].T + origins[own]
            for j in revolute:
                farthest = _farthest_from_axis(world, origins[j], rotations[j] @ robot.kinematics.axes[j])
                bound = tables.bounds[g, j] if tables.supports[g, j] else tables.cross[g, j]
                assert farthest <= bound + 1e-9, (name, objects[g].name, int(j))


def test_pair_distances_checks_its_joint_angles() -> None:
    """A list is read as the array it names; a wrong length or a value beyond a limit is refused naming ``q``."""
    robot = _robot("panda")
    checker = CollisionChecker(robot, [Obstacle("ball", Sphere(0.1), Pose((0.6, 0.0, 0.4)))])
    q = robot.mid_configuration
    np.testing.assert_array_equal(checker.pair_distances(q.tolist(), [0, 1]), checker.pair_distances(q, [0, 1]))
    for bad in (q[:3], np.where(np.arange(robot.n_joints) == 0, robot.upper_limits + 0.1, q)):
        with pytest.raises(InvalidInput, match=r"^q"):
            checker.pair_distances(bad, [0])
