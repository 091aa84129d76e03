"""The 2D base controller: point following and assisted teleoperation on the seed's vector field.

Every :meth:`BaseController.step` (called at a fixed rate with the robot pose (x, y, yaw) in the fixed frame
and a monotonic time in s) returns one command in the robot frame and a :class:`ControllerState`:

* **Teleop** (priority while live, i.e. newer than ``teleop_timeout``): the operator's velocity u plus the
  clamped repulsion (rotated into the robot frame), less any part pointing back against u, then scaled down
  to ‖u‖ if longer: assistance slows, stops and steers, but never drives faster than asked nor backs the
  robot away (nav2's assisted teleop only slows and stops); driven into a wall, the robot stops where the
  repulsion equals ‖u‖. Diff drive: the operator's ω is kept and v = u_x + r_x clipped between 0 and u_x.
  ``teleop_mode="field"`` keeps the seed's pure law (u + r capped at ‖u‖), which may push the robot back.
* **Point following**: the clamped −∇V of :mod:`pfield.mobile.clamping`; within ``goal_tolerance`` the goal
  is cleared and the state becomes ``goal_reached``. ``stuck`` is reported while the mean speed over
  ``stuck_window`` stays under ``stuck_speed`` (the goal is kept; the field may still free the robot).
* **Stale teleop** with no goal → exactly zero, state ``teleop_timeout``.

Holonomic output rotates the world velocity into the robot frame (ω = 0). Diff-drive output moves the point
at ``lookahead`` L ahead of the axle with the field velocity (feedback linearisation):
v = cos ψ·v_x + sin ψ·v_y, ω = (−sin ψ·v_x + cos ψ·v_y)/L, scaled as a whole when |ω| > max_angular_speed.
Acceleration limits bound the change of motion commands; stops (goal reached, timeout, idle) are immediate.
Every command is finite and within ``max_spd_norm`` and ``max_angular_speed`` (:mod:`pfield.safety`): a
non-finite one (absurd poses can overflow the field) is zero.
"""

from __future__ import annotations

import enum
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield import safety
from pfield._validation import as_vector, finite
from pfield.errors import InvalidInput
from pfield.mobile.clamping import HARD, clamp_norm
from pfield.mobile.config import ControllerConfig
from pfield.mobile.field2d import components_at, velocity_at
from pfield.mobile.params import VectorFieldParams
from pfield.mobile.scan import LaserScanLike, ObstaclePoints, compose_pose2d, point_obstacles, scan_obstacles

__all__ = ["BaseController", "Command2D", "ControllerState"]

_NO_GOAL = np.zeros(2)  # assisted teleop evaluates the repulsion alone

class ControllerState(enum.StrEnum):
    """What the controller is doing (reported with every command)."""

    IDLE = "idle"
    FOLLOWING = "following"
    REACHED = "goal_reached"
    STUCK = "stuck"
    TELEOP = "teleop"
    TIMEOUT = "teleop_timeout"


@dataclass(frozen=True)
class Command2D:
    """A velocity command in the robot frame: ``linear_x``, ``linear_y`` (m/s), ``angular_z`` (rad/s)."""

    linear_x: float
    linear_y: float
    angular_z: float
    state: ControllerState

    @property
    def speed(self) -> float:
        """Norm of the linear command (m/s)."""
        return math.hypot(self.linear_x, self.linear_y)


@dataclass(frozen=True)
class _Teleop:
    linear_x: float
    linear_y: float
    angular_z: float
    received: float


class BaseController:
    """Stateful controller over the compiled field; not thread-safe (the node serialises calls)."""

    def __init__(self, params: VectorFieldParams | None = None, config: ControllerConfig | None = None) -> None:
        self._params = params or VectorFieldParams()
        self._config = config or ControllerConfig()
        self._goal: NDArray[np.float64] | None = None
        self._obstacles = point_obstacles(None)
        self._columns = (np.empty(0), np.empty(0))
        self._teleop: _Teleop | None = None
        self._last = np.zeros(3)
        self._last_time: float | None = None
        self._idle_state = ControllerState.IDLE
        self._state = ControllerState.IDLE
        self._history: deque[tuple[float, float, float]] = deque()

    @property
    def params(self) -> VectorFieldParams:
        return self._params

    @property
    def config(self) -> ControllerConfig:
        return self._config

    @property
    def goal(self) -> NDArray[np.float64] | None:
        """The active goal (2,) in the fixed frame, or None."""
        return None if self._goal is None else self._goal.copy()

    @property
    def obstacles(self) -> ObstaclePoints:
        return self._obstacles

    @property
    def state(self) -> ControllerState:
        """State reported with the last command."""
        return self._state

    def reconfigure(self, params: VectorFieldParams | None = None, config: ControllerConfig | None = None) -> None:
        """Replace the (already validated) field parameters and/or options; the next step uses them."""
        self._params = params or self._params
        self._config = config or self._config

    def set_goal(self, goal: ArrayLike | None) -> None:
        """Follow ``goal`` (x, y) in the fixed frame (m); None cancels point following."""
        self._goal = None if goal is None else np.array(as_vector("goal", goal, 2))
        self._history.clear()
        if goal is None:
            self._idle_state = ControllerState.IDLE

    def set_obstacles(self, obstacles: ObstaclePoints) -> None:
        """Replace the obstacle points (fixed frame) and weights."""
        self._store(point_obstacles(obstacles.points, obstacles.weights))

    def update_scan(self, scan: LaserScanLike, robot_pose: ArrayLike) -> None:
        """Replace the obstacles by the points of ``scan`` taken at ``robot_pose`` (x, y, yaw)."""
        sensor = compose_pose2d(robot_pose, self._config.sensor_pose)
        self._store(scan_obstacles(scan, sensor, self._config.scan_weighting, self._config.scan_sector_angle))

    def _store(self, obstacles: ObstaclePoints) -> None:
        self._obstacles = obstacles
        # the kernels take x and y as separate contiguous columns (vectorised loop)
        self._columns = (np.ascontiguousarray(obstacles.points[:, 0]), np.ascontiguousarray(obstacles.points[:, 1]))

    def set_teleop(self, linear_x: float, linear_y: float, angular_z: float, now: float) -> None:
        """Operator velocity in the robot frame (m/s, rad/s) received at monotonic time ``now`` (s)."""
        values = (finite("linear.x", linear_x), finite("linear.y", linear_y), finite("angular.z", angular_z))
        self._teleop = _Teleop(*values, received=finite("now", now))

    def step(self, pose: ArrayLike, now: float) -> Command2D:
        """One control period: the command for the robot at ``pose`` (x, y, yaw) at time ``now`` (s)."""
        x, y, yaw = as_vector("pose", pose, 3)
        now = finite("now", now)
        if self._last_time is not None and now < self._last_time:
            raise InvalidInput("now", now, f"time went backwards (last step at {self._last_time})")
        dt = 0.0 if self._last_time is None else now - self._last_time
        self._last_time = now
        desired, state, caps = self._desired(float(x), float(y), float(yaw), now)
        if desired is None:
            command = np.zeros(3)
        else:
            command = self._within_limits(self._cap(self._rate_limited(desired, dt), caps))
        self._last = command
        self._state = state
        return Command2D(float(command[0]), float(command[1]), float(command[2]), state)

    def _within_limits(self, command: NDArray[np.float64]) -> NDArray[np.float64]:
        """The output contract (:mod:`pfield.safety`) on (v_x, v_y, ω): finite (else zero), the linear part within
        ``max_spd_norm`` and ω within ``max_angular_speed``, by one factor."""
        twist = np.array([command[0], command[1], 0.0, 0.0, 0.0, command[2]])
        if safety.limit_twist(twist, self._params.max_spd_norm, self._config.max_angular_speed) == safety.WITHIN:
            return command
        return np.array([twist[0], twist[1], twist[5]])

    # -- modes ---------------------------------------------------------------------------------------
    def _desired(self, x: float, y: float, yaw: float,
                 now: float) -> tuple[NDArray[np.float64] | None, ControllerState, tuple[float, float] | None]:
        teleop = self._teleop
        if teleop is not None and now - teleop.received <= self._config.teleop_timeout:
            command, caps = self._assisted_teleop(teleop, x, y, yaw)
            return command, ControllerState.TELEOP, caps
        if teleop is not None:
            self._teleop = None
            self._idle_state = ControllerState.TIMEOUT
        if self._goal is None:
            return None, self._idle_state, None
        # Python floats: a difference beyond the largest float is inf, with no numpy overflow warning
        if math.hypot(float(self._goal[0]) - x, float(self._goal[1]) - y) <= self._params.goal_tolerance:
            self._goal = None
            self._idle_state = ControllerState.REACHED
            return None, ControllerState.REACHED, None
        p = self._params
        vx, vy = velocity_at(x, y, self._goal, True, *self._columns, self._obstacles.weights, p.core_field,
                             p.core_limits)
        stuck = self._update_stuck(x, y, now)
        return self._drive_command(vx, vy, yaw), ControllerState.STUCK if stuck else ControllerState.FOLLOWING, None

    def _assisted_teleop(self, teleop: _Teleop, x: float, y: float,
                         yaw: float) -> tuple[NDArray[np.float64], tuple[float, float]]:
        p = self._params
        diff = self._config.drive == "diff_drive"
        ux, uy = clamp_norm(teleop.linear_x, 0.0 if diff else teleop.linear_y, 0.0, p.max_spd_norm, HARD)
        wz = float(np.clip(teleop.angular_z, -self._config.max_angular_speed, self._config.max_angular_speed))
        rx, ry = components_at(x, y, _NO_GOAL, False, *self._columns, self._obstacles.weights, p.core_field).repulsion
        rx, ry = clamp_norm(rx, ry, 0.0, p.max_spd_norm, p.core_limits.mode)
        c, s = math.cos(yaw), math.sin(yaw)
        bx, by = c * rx + s * ry, -s * rx + c * ry
        speed = math.hypot(ux, uy)
        assisted = self._config.teleop_mode == "assisted"
        if diff:  # assisted: along the operator's sign only, slowed or stopped, never reversed
            low, high = (min(ux, 0.0), max(ux, 0.0)) if assisted else (-speed, speed)
            return np.array([float(np.clip(ux + bx, low, high)), 0.0, wz]), (speed, abs(wz))
        if speed == 0.0:
            return np.array([0.0, 0.0, wz]), (0.0, abs(wz))
        vx, vy = ux + bx, uy + by
        along = (vx * ux + vy * uy) / speed  # the blend's part along the operator's direction
        if along < 0.0 and assisted:  # it would push the base back: it only slows and stops, as nav2's assisted teleop
            vx, vy = vx - along * ux / speed, vy - along * uy / speed
        vx, vy = clamp_norm(vx, vy, 0.0, speed, HARD)
        return np.array([vx, vy, wz]), (speed, abs(wz))

    def _drive_command(self, vx: float, vy: float, yaw: float) -> NDArray[np.float64]:
        c, s = math.cos(yaw), math.sin(yaw)
        if self._config.drive == "holonomic":
            return np.array([c * vx + s * vy, -s * vx + c * vy, 0.0])
        v = c * vx + s * vy
        w = (-s * vx + c * vy) / self._config.lookahead
        w_max = self._config.max_angular_speed
        if abs(w) > w_max:
            v, w = v * w_max / abs(w), math.copysign(w_max, w)
        return np.array([v, 0.0, w])

    # -- limits and bookkeeping ------------------------------------------------------------------------
    def _rate_limited(self, desired: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        out = desired.copy()
        a_lin, a_ang = self._config.max_linear_acceleration, self._config.max_angular_acceleration
        if a_lin > 0.0:
            dvx, dvy = clamp_norm(desired[0] - self._last[0], desired[1] - self._last[1], 0.0, a_lin * dt, HARD)
            out[0], out[1] = self._last[0] + dvx, self._last[1] + dvy
        if a_ang > 0.0:
            out[2] = self._last[2] + float(np.clip(desired[2] - self._last[2], -a_ang * dt, a_ang * dt))
        return out

    @staticmethod
    def _cap(command: NDArray[np.float64], caps: tuple[float, float] | None) -> NDArray[np.float64]:
        if caps is None:
            return command
        command[0], command[1] = clamp_norm(command[0], command[1], 0.0, caps[0], HARD) if caps[0] > 0 else (0.0, 0.0)
        command[2] = float(np.clip(command[2], -caps[1], caps[1]))
        return command

    def _update_stuck(self, x: float, y: float, now: float) -> bool:
        history = self._history
        history.append((now, x, y))
        window = self._config.stuck_window
        while len(history) >= 2 and history[1][0] <= now - window:
            history.popleft()
        t0, x0, y0 = history[0]
        if now - t0 < window:
            return False
        return math.hypot(x - x0, y - y0) < self._config.stuck_speed * (now - t0)
