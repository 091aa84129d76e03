"""Time parameterisation: strictly increasing times, |q̇| and |q̈| within the limits, positions on the path."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.field.field import PotentialField
from pfield.interfaces import message_from_yaml
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.convert import plan_response
from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.planning.retime import TimedJointTrajectory, retime_joint_path
from pfield.planning.whole_body import WholeBodyOptions, plan_whole_body
from pfield.robot import RobotModel
from pfield.spatial import Pose

NAMES = ("a", "b", "c")
V_MAX = np.array([1.0, 0.5, 2.0])
A_MAX = np.array([0.5, 1.0, 0.2])


@pytest.fixture(scope="module")
def xarm() -> RobotModel:
    return RobotModel.builtin("xarm7")


def _assert_valid(trajectory: TimedJointTrajectory, waypoints: np.ndarray) -> None:
    assert trajectory.times[0] == 0.0
    assert np.all(np.diff(trajectory.times) > 0.0)
    assert np.all(np.abs(trajectory.velocities) <= trajectory.velocity_limits + 1e-6)
    assert np.all(np.abs(trajectory.accelerations) <= trajectory.acceleration_limits + 1e-6)
    # every waypoint is kept, unchanged: the positions are on the geometric path
    np.testing.assert_array_equal(trajectory.positions, waypoints)
    np.testing.assert_array_equal(trajectory.velocities[[0, -1]], 0.0)


def _corner_path() -> np.ndarray:
    """A dense path with a sharp corner, a fast stretch and a wiggle, sampled 10 ms apart at 2 rad/s."""
    first = np.linspace((0.0, 0.0, 0.0), (1.0, 0.2, -0.3), 60)
    second = np.linspace((1.0, 0.2, -0.3), (0.2, 1.0, 0.4), 80)[1:]
    path = np.vstack([first, second])
    path[10:20, 2] += 1e-4 * np.sin(np.arange(10))
    return path


def test_a_dense_path_with_a_corner_is_timed_within_the_limits() -> None:
    path = _corner_path()
    trajectory = retime_joint_path(NAMES, path, V_MAX, A_MAX, dt=0.01)
    _assert_valid(trajectory, path)
    # a limit binds somewhere: the timing is not needlessly slow by orders of magnitude
    ratio = max(np.max(np.abs(trajectory.velocities) / V_MAX), np.max(np.abs(trajectory.accelerations) / A_MAX))
    assert ratio > 0.5


def test_a_straight_rest_to_rest_move_takes_at_least_the_bang_bang_time() -> None:
    # 1 rad at v ≤ 1, a ≤ 0.5 from rest to rest cannot be faster than 2·√(0.5/0.5)·… = 2√(L/a) = 2.83 s
    path = np.linspace((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 101)
    trajectory = retime_joint_path(NAMES, path, V_MAX, A_MAX, dt=0.01)
    _assert_valid(trajectory, path)
    assert trajectory.duration >= 2.0 * np.sqrt(1.0 / 0.5) - 1e-9


def test_repeated_waypoints_still_get_strictly_increasing_times() -> None:
    path = np.repeat(np.linspace((0.0, 0.0, 0.0), (0.3, -0.2, 0.1), 20), 3, axis=0)
    trajectory = retime_joint_path(NAMES, path, V_MAX, A_MAX, dt=0.02)
    _assert_valid(trajectory, path)
    assert len(trajectory.times) == len(path)


def test_a_path_that_does_not_move_stays_at_rest() -> None:
    path = np.zeros((5, 3))
    trajectory = retime_joint_path(NAMES, path, V_MAX, A_MAX, dt=0.02)
    np.testing.assert_allclose(trajectory.times, np.arange(5) * 0.02)
    assert not trajectory.velocities.any() and not trajectory.accelerations.any()


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"waypoints": np.full((3, 3), np.nan)}, "waypoints"),
    ({"waypoints": np.zeros((0, 3))}, "waypoints"),
    ({"joint_names": ("a", "b")}, "joint_names"),
    ({"velocity_limits": [1.0, 1.0]}, "velocity_limits"),
    ({"velocity_limits": [1.0, -1.0, 1.0]}, "velocity_limits[1]"),
    ({"acceleration_limits": [1.0, 1.0, 0.0]}, "acceleration_limits[2]"),
    ({"dt": 0.0}, "dt"),
])
def test_bad_input_is_refused_naming_the_field(kwargs: dict[str, Any], field: str) -> None:
    arguments: dict[str, Any] = {"joint_names": NAMES, "waypoints": _corner_path(), "velocity_limits": V_MAX,
                                 "acceleration_limits": A_MAX, "dt": 0.01} | kwargs
    with pytest.raises(InvalidInput) as info:
        retime_joint_path(**arguments)
    assert info.value.field == field


def test_the_robot_acceleration_limits_default_to_a_pace_real_arms_follow(xarm: RobotModel,
                                                                           tmp_path: Path) -> None:
    """Issue 33: the retiming's default 0.2 rad/s² made a 1.8 s motion last 10 s; the default is now URScript's
    movej acceleration, 1.4 rad/s², and MoveIt's joint_limits.yaml sets it per joint."""
    from pfield.robot.catalog import example_robot_data_root
    from pfield.robot.limits import DEFAULT_JOINT_ACCELERATION

    assert DEFAULT_JOINT_ACCELERATION == 1.4
    np.testing.assert_array_equal(xarm.acceleration_limits, np.full(7, 1.4))
    limits = tmp_path / "joint_limits.yaml"
    limits.write_text("joint_limits:\n  joint2: {has_acceleration_limits: true, max_acceleration: 5.0,\n"
                      "    has_velocity_limits: true, max_velocity: 1.0}\n  joint3: {has_acceleration_limits: false,"
                      " max_acceleration: 9.0}\n  finger: {has_acceleration_limits: true, max_acceleration: 1.0}\n")
    tuned = RobotModel.from_urdf(xarm.urdf_path, xarm.end_effector, {"example-robot-data": example_robot_data_root()},
                                 joint_limits=limits)
    np.testing.assert_array_equal(tuned.acceleration_limits, [1.4, 5.0, 1.4, 1.4, 1.4, 1.4, 1.4])
    assert tuned.velocity_limits[1] == 1.0 and tuned.velocity_limits[2] == xarm.velocity_limits[2]
    limits.write_text("joint_limits:\n  joint2: {has_acceleration_limits: true, max_acceleration: -1}\n")
    with pytest.raises(InvalidInput, match=r"joint2\.max_acceleration"):
        RobotModel.from_urdf(xarm.urdf_path, xarm.end_effector, {"example-robot-data": example_robot_data_root()},
                             joint_limits=limits)


def test_a_joint_without_a_velocity_limit_is_refused_before_planning_with_the_ways_to_give_one(
        xarm: RobotModel, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """URDF exporters write <limit velocity="0"/> as a placeholder: the plan was computed, then its retiming raised
    "velocity_limits[1]=0.0: must be > 0". The robot still loads (its kinematics need no limit), with a warning;
    whole-body plans, steppers and assistance refuse it before any work, naming the joint; a joint_limits.yaml
    that gives the limit, or locking the joint, makes the robot usable."""
    from pfield.planning.stepper import WholeBodyStepper
    from pfield.robot.catalog import example_robot_data_root
    from pfield.shared_control.assistance import AssistanceScene, whole_body_assistance

    text = xarm.urdf_path.read_text()
    start = text.index('<joint name="joint2" type="revolute"')
    limit = text.index('velocity="3.14"', start)
    urdf = tmp_path / "xarm7.urdf"
    urdf.write_text(text[:limit] + 'velocity="0"' + text[limit + len('velocity="3.14"'):])
    packages = {"example-robot-data": example_robot_data_root()}
    with caplog.at_level("WARNING", logger="pfield.robot.model"):
        robot = RobotModel.from_urdf(urdf, xarm.end_effector, packages)
    assert "joint 'joint2' of xarm7.urdf has velocity limit 0" in caplog.text
    np.testing.assert_allclose(robot.forward_kinematics(np.zeros(7)).position,
                               xarm.forward_kinematics(np.zeros(7)).position)
    field = PotentialField(FieldConfig(), Pose((0.4, 0.2, 0.4), (1.0, 0.0, 0.0, 0.0)))
    refusals = [lambda: field.plan_whole_body(robot, np.zeros(7), 0.02, 0.01, 100),
                lambda: WholeBodyStepper(field, robot),
                lambda: whole_body_assistance(AssistanceScene(field), robot, np.zeros(7))]
    for refused in refusals:
        with pytest.raises(InvalidInput, match=r"joint 'joint2' of xarm7.urdf has velocity limit 0; .*"
                                               r"joint_limits.yaml.*--locked-joint joint2=VALUE") as info:
            refused()
        assert info.value.field == "robot"
    limits = tmp_path / "joint_limits.yaml"
    limits.write_text("joint_limits:\n  joint2: {has_velocity_limits: true, max_velocity: 1.5}\n")
    given = RobotModel.from_urdf(urdf, xarm.end_effector, packages, joint_limits=limits)
    assert given.velocity_limits[1] == 1.5 and field.plan_whole_body(given, np.zeros(7), 0.02, 0.01, 10).iterations
    locked = RobotModel.from_urdf(urdf, xarm.end_effector, packages, locked_joints={"joint2": 0.3})
    assert "joint2" not in locked.joint_names and WholeBodyStepper(field, locked) is not None


def test_a_plan_is_retimed_with_the_robot_limits_not_the_field_s(xarm: RobotModel) -> None:
    field = PotentialField(FieldConfig(), Pose((0.4, 0.2, 0.4), (1.0, 0.0, 0.0, 0.0)))
    path = field.plan_whole_body(xarm, [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], 0.02, 0.01, 10000)
    assert path.success and path.trajectory is not None
    np.testing.assert_array_equal(path.trajectory.acceleration_limits, xarm.acceleration_limits)
    slow = retime_joint_path(xarm.joint_names, path.joint_positions, xarm.velocity_limits, np.full(7, 0.2), 0.02)
    assert path.trajectory.times[-1] < 0.5 * slow.times[-1]  # the old 0.2 rad/s² default: over twice as long


def test_whole_body_plans_carry_a_trajectory_within_the_urdf_and_config_limits(xarm: RobotModel) -> None:
    config = FieldConfig(max_angular_acceleration=0.5)
    field = PotentialField(config, Pose((0.4, 0.2, 0.4), (1.0, 0.0, 0.0, 0.0)))
    path = plan_whole_body(field, xarm, [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], 0.02, 0.01, 10000,
                           options=WholeBodyOptions(acceleration_limits=(0.5,) * 7))
    assert path.success, path.failure_reason
    assert path.trajectory is not None and path.joint_positions is not None
    _assert_valid(path.trajectory, path.joint_positions)
    np.testing.assert_array_equal(path.trajectory.velocity_limits, xarm.velocity_limits)
    np.testing.assert_array_equal(path.trajectory.acceleration_limits, np.full(7, 0.5))  # the options' own
    response = plan_response(path, "world")
    points = response.joint_trajectory.points
    assert len(points) == len(path.trajectory.times)
    np.testing.assert_allclose([p.accelerations for p in points], path.trajectory.accelerations, atol=1e-12)
    np.testing.assert_allclose([p.time_from_start.to_seconds() for p in points], path.trajectory.times, atol=1e-8)


def test_the_node_answer_carries_timed_velocities_and_accelerations(xarm: RobotModel) -> None:
    manager = ManagerNode(Bus(), xarm)
    request = message_from_yaml(pfi.PlanPath_Request, "{start: {position: {x: 0.227, y: 0.0, z: 0.294}, "
                                "orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}}, goal: {position: {x: 0.3, y: 0.1, "
                                "z: 0.35}, orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}}, delta_time: 0.02, "
                                "goal_tolerance: 0.01, starting_joint_angles: [0, 0, 0, 0, 0, -1.5708, 0]}")
    response = manager.plan_path(request)
    assert response.success, response.error_message
    points = response.joint_trajectory.points
    times = np.array([p.time_from_start.to_seconds() for p in points])
    assert np.all(np.diff(times) > 0.0)
    accelerations = np.array([p.accelerations for p in points])
    velocities = np.array([p.velocities for p in points])
    assert accelerations.shape == velocities.shape == (len(points), 7)
    limit = xarm.acceleration_limits  # the robot's (the documented default here)
    # the message's float32-free doubles: within the limits up to the Duration's nanosecond rounding
    assert np.all(np.abs(accelerations) <= limit + 1e-6)
    assert np.all(np.abs(velocities) <= xarm.velocity_limits + 1e-6)
