"""The planner's certificate (pfield.planning.certify) on the real UR5 + Robotiq meshes and the Panda (issue 34).

The bound is checked against coal's distances, the certificate against every grid configuration checked exactly
(no false "clear"), and the planner reports a start or goal in contact at once, naming the pair.
"""

from __future__ import annotations

import itertools

import coal
import numpy as np
import pytest

from core_scenes import (
    UR5_FOREARM_WRIST_2,
    needs_ur5,
    random_configuration,
    random_three_waypoints,
    ur5_at_tool0,
    ur5_problem,
)
from pfield import Box, FieldConfig, Obstacle, Pose, PotentialField, RobotModel
from pfield.errors import InvalidInput
from pfield.planning import PlanStatus
from pfield.planning.certify import certify_path
from pfield.robot.collision import CollisionChecker


@pytest.fixture(scope="module")
def ur5() -> RobotModel:
    return ur5_at_tool0()


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel.builtin("panda")


def _box_near(robot: RobotModel, q: np.ndarray, size: float = 0.12) -> Obstacle:
    """A box centred on the end effector at ``q``: the gripper is inside it."""
    return Obstacle("block", Box(size, size, size), Pose(robot.forward_kinematics(q).position))


def _past_a_box(robot: RobotModel, rng: np.random.Generator, spread: float, distance: float
                ) -> tuple[np.ndarray, Obstacle]:
    """Three random waypoints (:func:`random_three_waypoints`) and a 10 cm box ``distance`` (m) from the end effector
    at the middle one, in a random direction."""
    qs = random_three_waypoints(robot, rng, spread)
    direction = rng.normal(size=3)
    offset = direction / np.linalg.norm(direction) * distance
    return qs, Obstacle("block", Box(0.1, 0.1, 0.1), Pose(robot.forward_kinematics(qs[1]).position + offset))


@needs_ur5
@pytest.mark.parametrize("which", ["ur5", "panda"])
def test_motion_bound_holds_against_coal(which: str, request: pytest.FixtureRequest) -> None:
    """d_p(q + Δq) ≥ d_p(q) − Σ_j w_pj |Δq_j| for every pair (the advancement's bound) on the meshes' distances,
    on random motions of up to ~0.15 rad per joint; and the hulls' distance is never above the meshes'."""
    robot = request.getfixturevalue(which)
    rng = np.random.default_rng(3)
    q0 = random_configuration(robot, rng)
    checker = CollisionChecker(robot, [Obstacle("ball", Box(0.2, 0.2, 0.2), Pose((0.4, 0.2, 0.4)))])
    pairs = np.arange(len(checker.pair_names))
    weights = checker.motion_weights
    assert weights.shape == (len(pairs), robot.n_joints) and np.all(weights >= 0.0)
    for _ in range(12):
        q = random_configuration(robot, rng)
        dq = rng.normal(size=robot.n_joints) * 0.05
        moved = np.clip(q + dq, robot.lower_limits, robot.upper_limits)
        before = checker.pair_distances(q, pairs, np.inf)  # the meshes' own distances, which the bound is about
        after = checker.pair_distances(moved, pairs, np.inf)
        bound = weights @ np.abs(moved - q)
        clear = (before > 0.0) & (after > 0.0)  # penetration depths are not distances
        assert np.all(after[clear] >= before[clear] - bound[clear] - 1e-6)
        hulls = checker.pair_distances(q, pairs)
        assert np.all(hulls[before > 0.0] <= before[before > 0.0] + 1e-6)
    assert q0.shape == (robot.n_joints,)


def _meshes_apart(checker: CollisionChecker, q: np.ndarray, pair: int) -> tuple[float, bool]:
    """The reference for one pair, coal on the meshes themselves (no hulls): their distance and whether they collide."""
    a, b, obstacle = checker._records[pair]
    placed = checker._placements(q, {a} if obstacle else {a, b})
    other, pose = (checker._obstacles[b][1], checker._obstacles[b][2]) if obstacle else (checker._meshes[b], placed[b])
    distance = coal.distance(checker._meshes[a], placed[a], other, pose, coal.DistanceRequest(), coal.DistanceResult())
    hit = coal.CollisionResult()
    coal.collide(checker._meshes[a], placed[a], other, pose, coal.CollisionRequest(), hit)
    return float(distance), bool(hit.isCollision())


@needs_ur5
@pytest.mark.parametrize("which", ["ur5", "panda"])
def test_pair_distances_bound_the_meshes_and_agree_on_contact(which: str, request: pytest.FixtureRequest) -> None:
    """At the mid configuration (where the UR5's base and upper arm overlap as hulls while their meshes keep 1.5 cm)
    and random ones, every pair's distance is at most coal's distance between the meshes themselves where those do
    not collide, and is ≤ 0 exactly where coal's collision test finds them in contact."""
    robot = request.getfixturevalue(which)
    rng = np.random.default_rng(17)
    checker = CollisionChecker(robot, [Obstacle("ball", Box(0.2, 0.2, 0.2), Pose((0.4, 0.2, 0.4)))])
    pairs = np.arange(len(checker.pair_names))
    contacts = apart = 0
    for q in [robot.mid_configuration, *(random_configuration(robot, rng) for _ in range(8))]:
        values = checker.pair_distances(q, pairs)
        for pair, value in zip(pairs.tolist(), values, strict=True):
            distance, hit = _meshes_apart(checker, q, pair)
            assert (value <= 0.0) == hit, (checker.pair_names[pair], value, distance)
            assert hit or value <= distance + 1e-6, (checker.pair_names[pair], value, distance)
            contacts, apart = contacts + hit, apart + (not hit)
    assert contacts > 0 and apart > 0


def _grid_verdict(checker: CollisionChecker, qs: np.ndarray, resolution: float) -> int | None:
    """The first grid configuration (index) in contact when every one is checked exactly, else None."""
    index = 0
    if checker.check(qs[0]).in_collision:
        return 0
    for a, b in itertools.pairwise(qs):
        steps = max(1, int(np.ceil(np.max(np.abs(b - a)) / resolution - 1e-12)))
        for i in range(1, steps + 1):
            index += 1
            if checker.check(a + (i / steps) * (b - a)).in_collision:
                return index
    return None


@needs_ur5
@pytest.mark.parametrize("which", ["ur5", "panda"])
def test_certificate_agrees_with_checking_every_grid_configuration(which: str, request: pytest.FixtureRequest) -> None:
    """Random paths past a box: the certificate says clear exactly when no grid configuration (every waypoint
    and every 0.01 rad) is in contact, and names the first contact's place."""
    robot = request.getfixturevalue(which)
    rng = np.random.default_rng(7)
    verdicts = []
    for trial in range(10):
        qs, box = _past_a_box(robot, rng, 0.3, 0.04 * trial)  # from inside the gripper to well clear
        checker = CollisionChecker(robot, [box])
        certificate = certify_path(robot, [box], qs, 0.01, checker)
        first = _grid_verdict(checker, qs, 0.01)
        assert certificate.clear == (first is None), trial
        if first is not None:
            assert certificate.grid_points == first + 1 and certificate.distance <= 0.0 and certificate.pair
        verdicts.append(certificate.clear)
    assert any(verdicts) and not all(verdicts)  # both outcomes were exercised


@needs_ur5
def test_looking_ahead_answers_as_the_plain_walk_with_fewer_placements(ur5: RobotModel,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """The certificate's look-ahead (a distance at a later grid point clears the stretch back to the pair's due point
    too) against the plain forward walk (``_AHEAD = 0``: never ahead): the same verdict, first contact, pair and
    distance on long UR5 paths past a box that is clear of them, grazed or hit, and fewer placements where a pair's
    distance holds (the base and the upper arm keep about 15 mm along a shoulder motion)."""
    from pfield.planning import certify

    rng = np.random.default_rng(11)
    cases = [_past_a_box(ur5, rng, 0.8, 0.05 * trial) for trial in range(8)]
    shoulder = np.array([[0.0, -1.2, 1.6, -1.97, -1.57, 0.0], [3.0, -0.4, 1.6, -1.97, -1.57, 0.0]])
    cases.append((shoulder, Obstacle("far", Box(0.1, 0.1, 0.1), Pose((3.0, 0.0, 0.0)))))
    counts = {}
    for ahead in (0.0, certify._AHEAD):
        monkeypatch.setattr(certify, "_AHEAD", ahead)
        results = [certify_path(ur5, [box], qs, 0.01, CollisionChecker(ur5, [box])) for qs, box in cases]
        counts[ahead] = [(c.clear, c.pair, c.distance, c.waypoint, c.fraction, c.grid_points) for c in results], \
            [c.placements for c in results]
    (plain, plain_placements), (looked, looked_placements) = counts.values()
    assert looked == plain
    assert {verdict[0] for verdict in plain} == {True, False}  # both outcomes were exercised
    assert looked_placements[-1] <= 0.7 * plain_placements[-1] and plain_placements[-1] >= 25
    assert sum(looked_placements) < sum(plain_placements)


@needs_ur5
def test_certificate_names_the_contact_and_refuses_bad_input(ur5: RobotModel) -> None:
    q = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    box = _box_near(ur5, q)
    away = q + np.array([0.8, 0.0, 0.0, 0.0, 0.0, 0.0])
    certificate = certify_path(ur5, [box], np.array([away, q]))
    assert not certificate.clear and certificate.waypoint == 0 and 0.0 < certificate.fraction <= 1.0
    assert certificate.pair.endswith("/block") and not certificate.self_collision
    assert "block" in certificate.describe()
    assert certify_path(ur5, [box], away[None]).clear
    with pytest.raises(InvalidInput, match="joint_positions"):
        certify_path(ur5, [box], np.zeros((2, 5)))
    with pytest.raises(InvalidInput, match="resolution"):
        certify_path(ur5, [box], away[None], resolution=0.0)
    with pytest.raises(InvalidInput, match=r"joint_positions\[1\]"):
        certify_path(ur5, [box], np.array([away, away + 100.0]))


@needs_ur5
def test_forearm_against_wrist_2_is_a_checked_self_pair(ur5: RobotModel) -> None:
    """The SRDF does not disable forearm_link/wrist_2_link: the exact check covers it (issue 34)."""
    names = CollisionChecker(ur5).pair_names
    assert "forearm_link_0/wrist_2_link_0" in names
    assert "wrist_2_link_0/wrist_3_link_0" not in names  # adjacent links are not checked


@needs_ur5
def test_goal_in_collision_is_reported_at_once(ur5: RobotModel) -> None:
    q0 = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    goal_q = np.array([0.6, -1.2, 1.6, -1.97, -1.57, 0.0])
    box = _box_near(ur5, goal_q)
    field = PotentialField(FieldConfig(), ur5.forward_kinematics(goal_q), [box])
    path = field.plan_whole_body(ur5, q0, dt=0.02, goal_tolerance=0.01, goal_configuration=goal_q)
    assert path.status == PlanStatus.GOAL_INVALID and not path.success
    assert len(path.joint_positions) == 1 and path.iterations == 0
    assert "goal configuration collides" in path.failure_reason and "/block" in path.failure_reason


@needs_ur5
def test_start_in_collision_is_reported_at_once(ur5: RobotModel) -> None:
    q0 = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    box = _box_near(ur5, q0)
    field = PotentialField(FieldConfig(), Pose((0.3, 0.3, 0.5)), [box])
    path = field.plan_whole_body(ur5, q0, dt=0.02, goal_tolerance=0.01)
    assert path.status == PlanStatus.START_INVALID and "start configuration collides" in path.failure_reason
    assert "/block" in path.failure_reason


@needs_ur5
def test_a_reached_ur5_plan_passes_the_certificate(ur5: RobotModel) -> None:
    """The issue's example around one box: whatever it reports, a reached plan is clear on the exact meshes."""
    q0 = np.array([0.0, -1.2, 1.6, -1.97, -1.57, 0.0])
    goal = Pose((0.35, 0.55, 1.165), ur5.forward_kinematics(q0).orientation)
    box = Obstacle("box", Box(0.08, 0.4, 0.2), Pose((0.12, 0.6, 0.95)))
    path = PotentialField(FieldConfig(), goal, [box]).plan_whole_body(ur5, q0, dt=0.02, goal_tolerance=0.01,
                                                                        max_iterations=25000)
    if path.success:
        assert certify_path(ur5, [box], path.joint_positions, 0.005).clear
    else:
        assert path.status != PlanStatus.REACHED


# ---- the reproduced MotionBenchMaker UR5 cases (issue 34) --------------------------------------------------------



@needs_ur5
def test_forearm_against_wrist_2_contact_is_seen(ur5: RobotModel) -> None:
    """table_under_pick_ur5 #9: the fallback's tracked path passed through this configuration, where the meshes of
    forearm_link and wrist_2_link intersect; the old check's "hulls" (coal's buildConvexRepresentation of the
    concave meshes) put them 198 mm apart, and the link model (capsules 35 mm deep already at the start) allowed it."""
    q = UR5_FOREARM_WRIST_2.copy()
    report = CollisionChecker(ur5).check(q)
    assert report.in_collision and report.pair == "forearm_link_0/wrist_2_link_0"


@needs_ur5
def test_table_under_pick_9_never_comes_back_reached_in_collision(ur5: RobotModel) -> None:
    from pfield.scene import MBM_CONFIG, MBM_OPTIONS

    obstacles, start, goal = ur5_problem("table_under_pick_ur5", 9)
    field = PotentialField(MBM_CONFIG, ur5.forward_kinematics(goal), obstacles)
    path = field.plan_whole_body(ur5, start, options=MBM_OPTIONS, goal_configuration=goal)
    assert path.joint_positions is not None
    if path.success:
        assert certify_path(ur5, obstacles, path.joint_positions).clear
    else:
        assert path.status in (PlanStatus.COLLISION, PlanStatus.SELF_COLLISION, PlanStatus.GLOBAL_TIME_LIMIT,
                               PlanStatus.GLOBAL_NO_PATH)


@needs_ur5
def test_table_pick_goal_touching_the_object_is_refused_at_once(ur5: RobotModel) -> None:
    """table_pick_ur5 #6 with the object to pick moved onto the gripper at the goal: the Robotiq meshes touch it,
    so the joint goal is reported invalid at once, naming the pair; and a pose goal never comes back reached with
    a motion in contact."""
    from pfield.scene import MBM_CONFIG, MBM_OPTIONS

    obstacles, start, goal = ur5_problem("table_pick_ur5", 6)
    checker = CollisionChecker(ur5, obstacles)
    _, pair, _, _ = checker.distances(goal)
    target = pair.split("/")[1]
    tool = ur5.forward_kinematics(goal).position
    moved: list[Obstacle] = []
    for step in np.linspace(0.0, 1.0, 41):  # slide the object toward the tool until the exact meshes touch it
        moved = [Obstacle(o.id, o.shape, Pose(o.pose.position + step * (tool - o.pose.position), o.pose.orientation))
                 if o.id == target else o for o in obstacles]
        if CollisionChecker(ur5, moved).check(goal).in_collision:
            break
    report = CollisionChecker(ur5, moved).check(goal)
    assert report.in_collision and report.pair.endswith(f"/{target}")
    assert report.pair.startswith(("robotiq", "fts", "wrist", "ee_link"))
    field = PotentialField(MBM_CONFIG, ur5.forward_kinematics(goal), moved)
    path = field.plan_whole_body(ur5, start, options=MBM_OPTIONS, goal_configuration=goal)
    assert path.status == PlanStatus.GOAL_INVALID and path.iterations == 0 and report.pair in path.failure_reason
    by_pose = field.plan_whole_body(ur5, start, options=MBM_OPTIONS, global_fallback=False)
    assert by_pose.joint_positions is not None
    assert not by_pose.success or certify_path(ur5, moved, by_pose.joint_positions).clear


@needs_ur5
def test_the_fields_own_reached_motion_is_certified(ur5: RobotModel) -> None:
    """A pose goal whose nearest IK branch puts forearm_link into wrist_2_link: the field's loop gets there (its
    link model overlaps that pair already at the start, so it may not approach further, but may stay), the
    certificate refuses it, and the path ends before the contact; with the fallback, never reached in contact."""
    contact = UR5_FOREARM_WRIST_2.copy()
    start = contact + np.array([0.0, 0.0, 0.0, 0.0, 0.6, 0.0])
    config = FieldConfig(max_linear_velocity=0.25, max_angular_velocity=1.0)
    field = PotentialField(config, ur5.forward_kinematics(contact), [])
    path = field.plan_whole_body(ur5, start, dt=0.02, goal_tolerance=0.01, global_fallback=False)
    assert path.status == PlanStatus.SELF_COLLISION and "forearm_link_0/wrist_2_link_0" in path.failure_reason
    assert path.joint_positions is not None and len(path.times) == len(path.joint_positions) == path.iterations + 1
    assert certify_path(ur5, [], path.joint_positions).clear  # what is returned stops before the contact
    repaired = field.plan_whole_body(ur5, start, dt=0.02, goal_tolerance=0.01, global_fallback=True)
    assert repaired.joint_positions is not None
    assert not repaired.success or certify_path(ur5, [], repaired.joint_positions).clear


def test_packed_obstacles_without_their_objects_are_refused(panda: RobotModel) -> None:
    from pfield.geometry import pack_obstacles
    from pfield.planning.whole_body import plan_whole_body_packed

    box = Obstacle("block", Box(0.1, 0.1, 0.1), Pose((0.5, 0.0, 0.3)))
    with pytest.raises(InvalidInput, match="obstacles"):
        plan_whole_body_packed(FieldConfig(), Pose((0.4, 0.2, 0.4)), pack_obstacles([box]), panda,
                               panda.mid_configuration)
