"""2D simulation: a holonomic or differential-drive robot with the controller in the loop at a fixed rate.

Each control period ``dt = 1/rate``: sense (the known point obstacles, or a laser ray-cast against the
world from the sensor pose), :meth:`BaseController.step`, then integrate the command exactly over ``dt``
(holonomic: constant body-frame velocity with ω = 0 is a straight line; diff drive: the unicycle arc).
The run ends when the controller reports ``goal_reached`` or ``stuck``, when the robot's disc touches an
obstacle (``collision``) or at ``duration`` (``timeout``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pfield.mobile.controller import BaseController, ControllerState
from pfield.mobile.scan import ObstaclePoints, compose_pose2d, point_obstacles, scan_ranges_obstacles
from pfield.mobile.scenarios import Scenario

__all__ = ["SimResult", "integrate_pose", "simulate"]

Progress = Callable[[float, float], None]
"""Called as ``progress(sim_time, duration)`` every control period."""


@dataclass(frozen=True)
class SimResult:
    """One run: ``times`` (T,), ``poses`` (T, 3) x, y, yaw, ``commands`` (T, 3) robot-frame vx, vy, ω,
    ``states`` (T,), the sensed obstacle points per step (``sensed``), the ``outcome`` and the smallest
    clearance between the robot's centre and an obstacle (m)."""

    scenario: Scenario
    times: NDArray[np.float64]
    poses: NDArray[np.float64]
    commands: NDArray[np.float64]
    states: tuple[str, ...]
    sensed: tuple[NDArray[np.float64], ...]
    outcome: str
    min_clearance: float

    @property
    def final_distance_to_goal(self) -> float:
        """Distance (m) from the last pose to the goal."""
        return float(np.hypot(*(self.poses[-1, :2] - np.asarray(self.scenario.goal))))


def integrate_pose(pose: NDArray[np.float64], command: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
    """Pose after applying the body-frame ``command`` (vx, vy, ω) for ``dt`` s (exact for constant input)."""
    x, y, yaw = pose
    vx, vy, w = command
    if abs(w) < 1e-9:
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([x + (c * vx - s * vy) * dt, y + (s * vx + c * vy) * dt, yaw])
    yaw1 = yaw + w * dt
    # ∫ R(yaw + w t) v dt over [0, dt] for constant body velocity v
    sin_d = math.sin(yaw1) - math.sin(yaw)
    cos_d = math.cos(yaw1) - math.cos(yaw)
    dx = (vx * sin_d + vy * cos_d) / w
    dy = (-vx * cos_d + vy * sin_d) / w
    return np.array([x + dx, y + dy, math.atan2(math.sin(yaw1), math.cos(yaw1))])


def _laser(scenario: Scenario, pose: NDArray[np.float64], angles: NDArray[np.float64]) -> ObstaclePoints:
    config = scenario.config
    sensor = compose_pose2d(pose, config.sensor_pose)
    ranges = scenario.world.raycast(sensor[:2], angles + sensor[2], scenario.laser_range)
    return scan_ranges_obstacles(ranges, float(angles[0]), float(angles[1] - angles[0]), 0.05,
                                 scenario.laser_range, sensor, config.scan_weighting, config.scan_sector_angle)


def simulate(scenario: Scenario, progress: Progress | None = None) -> SimResult:
    """Run ``scenario`` (its ``config.drive`` chooses the robot) and return the trajectory and outcome."""
    controller = BaseController(scenario.params, scenario.config)
    controller.set_goal(scenario.goal)
    dt = 1.0 / scenario.rate
    steps = math.ceil(scenario.duration / dt)
    angles: NDArray[np.float64] = -math.pi + np.arange(scenario.laser_beams, dtype=np.float64) * (
        2.0 * math.pi / scenario.laser_beams)
    pose = np.array(scenario.start, dtype=np.float64)
    times, poses, commands, states, sensed = [], [pose], [], [], []
    outcome, min_clearance = "timeout", scenario.world.clearance(pose)
    known = point_obstacles(scenario.world.points) if scenario.sensor == "points" else None
    for k in range(steps):
        now = k * dt
        obstacles = _laser(scenario, pose, angles) if known is None else known
        controller.set_obstacles(obstacles)
        command = controller.step(pose, now)
        vector = np.array([command.linear_x, command.linear_y, command.angular_z])
        times.append(now)
        commands.append(vector)
        states.append(str(command.state))
        sensed.append(obstacles.points)
        if progress is not None:
            progress(now, scenario.duration)
        if command.state in (ControllerState.REACHED, ControllerState.STUCK):
            outcome = str(command.state)
            break
        pose = integrate_pose(pose, vector, dt)
        poses.append(pose)
        clearance = scenario.world.clearance(pose)
        min_clearance = min(min_clearance, clearance)
        if scenario.sensor == "laser" and clearance < scenario.robot_radius:
            outcome = "collision"
            times.append(now + dt)
            commands.append(np.zeros(3))
            states.append("collision")
            sensed.append(obstacles.points)
            break
    poses = poses[: len(times)]
    return SimResult(scenario, np.array(times), np.array(poses), np.array(commands), tuple(states),
                     tuple(sensed), outcome, float(min_clearance))
