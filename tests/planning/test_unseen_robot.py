"""A robot pfield has never seen, described only by the files its package ships, plans around obstacles.

The robot is Kinova's Jaco 2 (``j2s6s200``: 6 joints, three of them continuous, a two-finger hand) from
example-robot-data (``robots/kinova_description``), which is not one of pfield's built-ins (``catalog``). It is loaded
with :meth:`RobotModel.from_urdf` from its URDF, meshes and SRDF as shipped. The SRDF disables no collision pair; its
group state ``arm_up`` puts joint 3 at −1.5707 rad, outside the URDF's limits [0.3316, 5.9516]: ``from_urdf`` skips
that state with a warning (as MoveIt loads such a file) and keeps the others.

Every trajectory is verified by the benchmarks' independent exact check (:class:`benchmarks._common.ExactRobot`:
pinocchio + coal on the link meshes, none of pfield's collision code), at every waypoint and at most
0.01 rad between them; the same check counts the colliding claims of ``benchmarks/bench_fallback.py``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from benchmarks._common import ExactRobot  # the repository root is on pytest's pythonpath (pyproject.toml)

from pfield.field import PotentialField
from pfield.geometry import Box, Cylinder, Obstacle
from pfield.planning.status import PlanStatus
from pfield.robot import RobotModel
from pfield.robot.catalog import BUILTIN_ROBOTS, example_robot_data_root
from pfield.robot.collision import CollisionChecker
from pfield.scene import MBM_CONFIG, MBM_OPTIONS
from pfield.spatial import Pose

KINOVA = Path("robots/kinova_description")
END_EFFECTOR = "j2s6s200_end_effector"
# Kinova's documented home position of the Jaco 2 6-DoF (degrees: 275, 175, 78, 243, 83, 75), the hand in front
HOME = np.radians([275.0, 175.0, 78.0, 243.0, 83.0, 75.0])
GOAL = HOME - np.array([1.6, 0.0, 0.0, 0.0, 0.0, 0.0])  # the base turned 1.6 rad: the hand from y < 0 to y > 0
# a wall across the hand's way at y = 0, a table below it, a post behind the robot
OBSTACLES = (Obstacle("wall", Box(0.25, 0.04, 0.4), Pose((0.45, 0.0, 0.5))),
             Obstacle("table", Box(0.6, 0.9, 0.04), Pose((0.35, 0.0, 0.2))),
             Obstacle("post", Cylinder(0.04, 0.8), Pose((-0.35, 0.1, 0.4))))
RESOLUTION = 0.01  # rad


def _files() -> tuple[Path, Path, Path]:
    root = example_robot_data_root()
    return root, root / KINOVA / "robots" / "kinova.urdf", root / KINOVA / "srdf" / "kinova.srdf"


@pytest.fixture(scope="module")
def kinova() -> RobotModel:
    root, urdf, srdf = _files()
    return RobotModel.from_urdf(urdf, end_effector=END_EFFECTOR, package_paths={"example-robot-data": root},
                                srdf=srdf)


@pytest.fixture(scope="module")
def exact(kinova: RobotModel) -> ExactRobot:
    root, urdf, srdf = _files()
    return ExactRobot(urdf, [root.parent], kinova.joint_names, srdf)


def test_the_shipped_srdf_loads_and_its_state_beyond_the_limits_is_skipped(kinova: RobotModel) -> None:
    _, _, srdf = _files()
    shipped = {state.get("name") for state in ET.parse(srdf).getroot().iter("group_state")}
    assert "arm_up" in shipped
    assert "arm_up" not in kinova.named_configurations()
    for q in kinova.named_configurations().values():
        assert np.all(q >= kinova.lower_limits - 1e-9) and np.all(q <= kinova.upper_limits + 1e-9)


def test_the_robot_is_not_built_in(kinova: RobotModel) -> None:
    assert "kinova" not in BUILTIN_ROBOTS and not any("j2s6s200" in name for name in BUILTIN_ROBOTS)
    assert kinova.n_joints == 6
    assert np.count_nonzero(np.isinf(kinova.upper_limits)) == 3  # joints 1, 4 and 6 are continuous


def test_the_independent_check_agrees_with_pfields_checker(kinova: RobotModel, exact: ExactRobot) -> None:
    """Two implementations (the bench's, pfield's CollisionChecker) give the same verdict on random
    configurations, except within 1 mm of contact (coal's tolerances)."""
    rng = np.random.default_rng(7)
    scene, checker = exact.scene(OBSTACLES), CollisionChecker(kinova, list(OBSTACLES))
    lower, upper = np.maximum(kinova.lower_limits, -np.pi), np.minimum(kinova.upper_limits, np.pi)
    verdicts = {True: 0, False: 0}
    for q in rng.uniform(lower, upper, (150, 6)):
        report = checker.check(q)
        if min(abs(report.distance), abs(report.self_distance)) < 1e-3:
            continue
        ours = bool(scene.contact(q))
        assert ours == report.in_collision, (q, scene.contact(q), report)
        verdicts[ours] += 1
    assert verdicts[True] >= 10 and verdicts[False] >= 10  # both verdicts were exercised


def test_the_check_finds_a_contact_between_clear_waypoints(exact: ExactRobot) -> None:
    """The straight joint-space motion from HOME to GOAL sweeps the hand through the wall: both ends are clear,
    the interpolation at ≤ 0.01 rad is what finds it (which also shows the obstacles are in the way)."""
    scene = exact.scene(OBSTACLES)
    assert scene.contact(HOME) == "" and scene.contact(GOAL) == ""
    found = scene.path_contact(np.array([HOME, GOAL]), RESOLUTION)
    assert found is not None
    waypoint, fraction, pair = found
    assert waypoint == 0 and 0.0 < fraction < 1.0 and pair.endswith("/wall")
    assert exact.scene([]).path_contact(np.array([HOME, GOAL]), RESOLUTION) is None  # the wall, not the arm


def test_whole_body_plan_around_obstacles_is_exactly_clear(kinova: RobotModel, exact: ExactRobot) -> None:
    goal_pose = kinova.forward_kinematics(GOAL)
    field = PotentialField(MBM_CONFIG, goal_pose, list(OBSTACLES))
    path = field.plan_whole_body(kinova, HOME, options=MBM_OPTIONS, goal_configuration=GOAL)
    assert path.success and path.status is PlanStatus.REACHED, path.failure_reason
    assert path.joint_positions is not None and path.trajectory is not None
    waypoints = np.asarray(path.joint_positions)
    np.testing.assert_array_equal(waypoints[0], HOME)
    reached = kinova.forward_kinematics(waypoints[-1])
    assert np.linalg.norm(np.asarray(reached.position) - np.asarray(goal_pose.position)) <= MBM_OPTIONS.goal_tolerance
    finite = np.isfinite(kinova.upper_limits)
    assert np.all(waypoints[:, finite] >= kinova.lower_limits[finite] - 1e-9)
    assert np.all(waypoints[:, finite] <= kinova.upper_limits[finite] + 1e-9)
    scene = exact.scene(OBSTACLES)
    assert scene.path_contact(waypoints, RESOLUTION) is None
    executed = np.asarray(path.trajectory.positions)
    np.testing.assert_allclose(executed[-1], waypoints[-1], atol=1e-6)
    assert scene.path_contact(executed, RESOLUTION) is None
    # the hand crossed the wall's plane y = 0, and the checks above say it never touched the wall
    hand = np.array([kinova.forward_kinematics(q).position for q in executed])
    assert hand[0, 1] < 0.0 < hand[-1, 1]


def test_a_continuous_joints_goal_is_turned_to_the_short_way(kinova: RobotModel, exact: ExactRobot) -> None:
    """A joint goal whose continuous joints (1, 4 and 6) are given a full turn away from the plan's goal: the same
    rotations, so the same goal; the plan turns them the short way, as MoveIt compares continuous joints, and ends
    within JOINT_GOAL_TOLERANCE of the goal's equivalent angles. A bounded joint turned by 2π is another goal (off
    the limits here: refused, naming it)."""
    from pfield.errors import InvalidInput
    from pfield.planning.whole_body import JOINT_GOAL_TOLERANCE

    continuous = np.isinf(kinova.upper_limits)
    turned = GOAL + np.where(continuous, 2.0 * np.pi, 0.0) * np.array([1, 1, 1, -1, 1, 1])[:len(GOAL)]
    field = PotentialField(MBM_CONFIG, kinova.forward_kinematics(GOAL), list(OBSTACLES))
    path = field.plan_whole_body(kinova, HOME, options=MBM_OPTIONS, goal_configuration=turned)
    assert path.success, path.failure_reason
    waypoints = np.asarray(path.joint_positions)
    assert np.max(np.abs(waypoints[-1] - GOAL)) <= JOINT_GOAL_TOLERANCE  # not GOAL ± 2π on the continuous joints
    assert np.all(np.abs(waypoints[:, continuous] - HOME[continuous]) < np.pi + np.abs(GOAL - HOME)[continuous])
    assert exact.scene(OBSTACLES).path_contact(waypoints, RESOLUTION) is None
    bounded = int(np.flatnonzero(~continuous)[0])
    with pytest.raises(InvalidInput) as info:
        field.plan_whole_body(kinova, HOME, options=MBM_OPTIONS,
                              goal_configuration=GOAL + 2.0 * np.pi * (np.arange(len(GOAL)) == bounded))
    assert info.value.field == f"goal_configuration[{bounded}]"
