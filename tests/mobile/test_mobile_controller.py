"""The base controller: point following, stuck detection, assisted teleop, timeouts, drives, limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfield.errors import InvalidInput
from pfield.mobile import VectorFieldParams
from pfield.mobile.config import ControllerConfig
from pfield.mobile.controller import BaseController, ControllerState
from pfield.mobile.scan import point_obstacles, scan_ranges_obstacles
from pfield.mobile.sim import integrate_pose
from pfield.mobile.world import World2D

DT = 0.05


def _run(controller, pose, steps, sense=None, teleop=None, stop_on=()):
    pose = np.asarray(pose, dtype=float)
    commands = []
    for k in range(steps):
        now = k * DT
        if sense is not None:
            controller.set_obstacles(sense(pose))
        if teleop is not None:
            controller.set_teleop(*teleop, now=now)
        command = controller.step(pose, now)
        commands.append(command)
        if command.state in stop_on:
            break
        pose = integrate_pose(pose, np.array([command.linear_x, command.linear_y, command.angular_z]), DT)
    return pose, commands


def test_goal_coincident_with_obstacle_stops_ln2_away_and_reports_stuck():
    params = VectorFieldParams(ka=3.0, kr_height=2.0, kr_slope=1.0, kr_dist=0.0, attraction="linear",
                               min_spd_norm=0.1, max_spd_norm=1.0, goal_tolerance=0.1)
    controller = BaseController(params, ControllerConfig(stuck_window=3.0))
    controller.set_goal([0.0, 0.0])
    controller.set_obstacles(point_obstacles([[0.0, 0.0]]))
    pose, commands = _run(controller, (3.0, 0.0, 0.0), 800)
    assert np.hypot(*pose[:2]) == pytest.approx(math.log(2.0), abs=0.01)
    states = {c.state for c in commands}
    assert ControllerState.STUCK in states and ControllerState.REACHED not in states
    assert controller.goal is not None


@pytest.mark.parametrize("drive", ["holonomic", "diff_drive"])
def test_point_following_reaches_goal_and_clears_it(drive):
    params = VectorFieldParams(ka=1.0, attraction="linear", kr_height=0.0, goal_tolerance=0.05)
    controller = BaseController(params, ControllerConfig(drive=drive, max_angular_speed=1.5))
    controller.set_goal([-2.0, 1.0])  # behind the robot
    pose, commands = _run(controller, (1.0, 0.0, 0.0), 600, stop_on=(ControllerState.REACHED,))
    assert commands[-1].state == ControllerState.REACHED
    assert np.hypot(pose[0] + 2.0, pose[1] - 1.0) <= 0.05
    assert controller.goal is None
    assert (commands[-1].linear_x, commands[-1].linear_y, commands[-1].angular_z) == (0.0, 0.0, 0.0)
    assert max(abs(c.angular_z) for c in commands) <= 1.5 + 1e-12
    if drive == "diff_drive":
        assert all(c.linear_y == 0.0 for c in commands)
    # afterwards the controller stays idle-with-result
    assert controller.step(pose, 1000.0).state == ControllerState.REACHED


def test_acceleration_limits_bound_command_changes():
    config = ControllerConfig(max_linear_acceleration=0.5, max_angular_acceleration=1.0, drive="diff_drive")
    controller = BaseController(VectorFieldParams(ka=3.0, kr_height=0.0), config)
    controller.set_goal([0.0, 5.0])
    _, commands = _run(controller, (0.0, 0.0, 0.0), 60)
    v = np.array([[c.linear_x, c.linear_y, c.angular_z] for c in commands])
    assert np.all(np.linalg.norm(np.diff(v[:, :2], axis=0), axis=1) <= 0.5 * DT + 1e-12)
    assert np.all(np.abs(np.diff(v[:, 2])) <= 1.0 * DT + 1e-12)


def _wall_sensor(config):
    world = World2D.build(polygons=[[(2.0, -10.0), (2.2, -10.0), (2.2, 10.0), (2.0, 10.0)]])
    beams = 720
    angles = -math.pi + np.arange(beams) * (2 * math.pi / beams)

    def sense(pose):
        ranges = world.raycast(pose[:2], angles + pose[2], 8.0)
        return scan_ranges_obstacles(ranges, -math.pi, 2 * math.pi / beams, 0.0, 8.0, pose,
                                     config.scan_weighting, config.scan_sector_angle)
    return sense


@pytest.mark.parametrize("drive", ["holonomic", "diff_drive"])
def test_teleop_never_exceeds_operator_speed_and_stops_short_of_a_wall(drive):
    params = VectorFieldParams(ka=3.0, kr_dist=0.4, kr_height=1.0, kr_slope=10.0, max_spd_norm=1.0)
    config = ControllerConfig(drive=drive)
    controller = BaseController(params, config)
    operator = (0.5, 0.0, 0.0)
    pose, commands = _run(controller, (0.0, 0.3, 0.0), 300, sense=_wall_sensor(config), teleop=operator)
    speeds = np.array([c.speed for c in commands])
    assert speeds.max() <= 0.5 + 1e-12
    assert all(c.state == ControllerState.TELEOP for c in commands)
    assert 0.2 < 2.0 - pose[0] < 1.0  # stopped short of the wall face at x = 2
    assert speeds[-1] < 1e-3


@pytest.mark.parametrize("drive", ["holonomic", "diff_drive"])
def test_assisted_teleop_toward_a_close_wall_stops_and_never_backs_away(drive):
    """Issue 33: +0.5 m/s toward a wall 0.6 m ahead gave x = −0.5 (the base backed away at the operator's speed)."""
    controller = BaseController(VectorFieldParams(), ControllerConfig(drive=drive, max_linear_acceleration=0.0))
    wall = [[0.6, y] for y in np.linspace(-1.0, 1.0, 41)]
    controller.set_obstacles(point_obstacles(wall))
    for distance_ahead in (0.6, 0.3, 0.05):
        controller.set_teleop(0.5, 0.0, 0.0, now=0.0)
        command = controller.step((0.6 - distance_ahead, 0.0, 0.0), 0.0)
        assert command.state == ControllerState.TELEOP
        assert 0.0 <= command.linear_x <= 0.5 and command.speed <= 0.5 + 1e-12, (distance_ahead, command)
        controller = BaseController(VectorFieldParams(), ControllerConfig(drive=drive, max_linear_acceleration=0.0))
        controller.set_obstacles(point_obstacles(wall))
    controller.set_teleop(-0.3, 0.0, 0.0, now=0.0)  # backing away from the wall is the operator's to command
    assert controller.step((0.5, 0.0, 0.0), 0.0).linear_x == pytest.approx(-0.3)
    # the seed's pure law stays available: there the repulsion pushes the base back
    seed_law = BaseController(VectorFieldParams(), ControllerConfig(drive=drive, max_linear_acceleration=0.0,
                                                                    teleop_mode="field"))
    seed_law.set_obstacles(point_obstacles(wall))
    seed_law.set_teleop(0.5, 0.0, 0.0, now=0.0)
    assert seed_law.step((0.55, 0.0, 0.0), 0.0).linear_x == pytest.approx(-0.5)


def test_stale_teleop_commands_zero_and_live_teleop_has_priority_over_goal():
    controller = BaseController(VectorFieldParams(kr_height=0.0), ControllerConfig(teleop_timeout=0.5,
                                                                                  max_linear_acceleration=0.0))
    controller.set_teleop(0.3, 0.1, 0.2, now=0.0)
    live = controller.step((0.0, 0.0, 0.0), 0.4)
    assert live.state == ControllerState.TELEOP and live.speed == pytest.approx(math.hypot(0.3, 0.1))
    stale = controller.step((0.0, 0.0, 0.0), 0.6)
    assert (stale.linear_x, stale.linear_y, stale.angular_z) == (0.0, 0.0, 0.0)
    assert stale.state == ControllerState.TIMEOUT
    controller.set_goal([5.0, 0.0])
    controller.set_teleop(0.0, -0.2, 0.0, now=1.0)
    assert controller.step((0.0, 0.0, 0.0), 1.1).linear_y == pytest.approx(-0.2)
    resumed = controller.step((0.0, 0.0, 0.0), 2.0)
    assert resumed.state == ControllerState.FOLLOWING and resumed.linear_x > 0.0


def test_teleop_without_obstacles_passes_operator_velocity_through():
    controller = BaseController(VectorFieldParams(), ControllerConfig(max_linear_acceleration=0.0,
                                                                      max_angular_acceleration=0.0))
    controller.set_teleop(0.2, -0.1, 0.3, now=0.0)
    command = controller.step((1.0, 1.0, 0.7), 0.0)
    assert (command.linear_x, command.linear_y, command.angular_z) == pytest.approx((0.2, -0.1, 0.3))


def test_bad_input_is_rejected_and_state_kept():
    controller = BaseController()
    controller.set_goal([1.0, 1.0])
    with pytest.raises(InvalidInput, match="goal"):
        controller.set_goal([math.nan, 0.0])
    assert controller.goal.tolist() == [1.0, 1.0]
    with pytest.raises(InvalidInput, match=r"linear\.x"):
        controller.set_teleop(math.inf, 0.0, 0.0, now=0.0)
    with pytest.raises(InvalidInput, match="pose"):
        controller.step((0.0, math.nan, 0.0), 0.0)
    controller.step((0.0, 0.0, 0.0), 1.0)
    with pytest.raises(InvalidInput, match="now"):
        controller.step((0.0, 0.0, 0.0), 0.5)


@pytest.mark.parametrize(("field", "kwargs"), [
    ("drive", {"drive": "tracked"}), ("lookahead", {"lookahead": 0.0}),
    ("max_angular_speed", {"max_angular_speed": -1.0}), ("teleop_timeout", {"teleop_timeout": math.nan}),
    ("max_linear_acceleration", {"max_linear_acceleration": -0.1}), ("scan_weighting", {"scan_weighting": "x"}),
    ("scan_sector_angle", {"scan_sector_angle": 7.0}), ("sensor_x", {"sensor_x": math.inf}),
])
def test_bad_config_is_rejected_by_name(field, kwargs):
    with pytest.raises(InvalidInput) as info:
        ControllerConfig(**kwargs)
    assert info.value.field == field


def test_update_scan_places_points_with_robot_pose_and_sensor_mount():
    from pfield.interfaces.sensor_msgs import LaserScan

    controller = BaseController(config=ControllerConfig(sensor_x=0.5, scan_weighting="sum"))
    scan = LaserScan(angle_min=0.0, angle_increment=0.1, range_min=0.0, range_max=5.0, ranges=[1.0])
    controller.update_scan(scan, (1.0, 2.0, math.pi / 2))  # laser 0.5 m ahead of a robot facing +y
    assert controller.obstacles.points == pytest.approx(np.array([[1.0, 3.5]]))
    with pytest.raises(InvalidInput, match="range_max"):
        controller.update_scan(scan.model_copy(update={"range_max": -1.0}), (0.0, 0.0, 0.0))
    assert controller.obstacles.points == pytest.approx(np.array([[1.0, 3.5]]))
