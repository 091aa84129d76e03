"""``/base_controller``: the transport-free node of the mobile base's 2D vector-field controller.

Topics in: ``/goal_point`` (geometry_msgs/PointStamped: start point following; frame ``odom_frame`` or empty =
fixed frame, ``base_frame`` = relative to the robot), ``/scan`` (sensor_msgs/LaserScan: replaces the
obstacles; frame ``sensor_frame`` or empty = the laser mounted at ``sensor_x/y/yaw``, ``base_frame`` = at the
robot's origin), ``/cmd_vel_teleop`` (geometry_msgs/Twist: the operator's velocity in the robot frame; has
priority while newer than ``teleop_timeout``), ``/odom`` (nav_msgs/Odometry: the robot pose; frame
``odom_frame`` or empty). Topic out: ``/cmd_vel`` (geometry_msgs/Twist, robot frame),
published on every tick (``tick_period`` = 1/``rate`` s). Service: ``/base_controller/cancel_goal``
(std_srvs/Trigger). Parameters: the :class:`~pfield.mobile.VectorFieldParams` and
:class:`~pfield.mobile.config.ControllerConfig` fields plus the three frame names, settable at run time.

The robot pose (x, y, yaw) in the fixed frame ``odom_frame`` is the latest ``/odom`` message's pose once one
has arrived; before that it is dead-reckoned from the published commands, so a goal given in ``base_frame``
and scan points stay consistent with the commanded motion. There is no odometry timeout: after the first
message the last received pose is used until a newer one arrives (a stopped odometry source freezes the pose;
guard it with a watchdog outside the node). Handlers validate everything before changing state; a rejected
message leaves the node as it was.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import std_srvs
from pfield.interfaces.nav_msgs import Odometry
from pfield.interfaces.sensor_msgs import LaserScan
from pfield.mobile.config import ControllerConfig
from pfield.mobile.controller import BaseController, ControllerState
from pfield.mobile.params import VectorFieldParams
from pfield.mobile.scan import compose_pose2d, scan_obstacles
from pfield.mobile.sim import integrate_pose
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec

__all__ = ["FRAME_PARAMETERS", "BaseControllerNode"]

_log = logging.getLogger(__name__)
FRAME_PARAMETERS = {"odom_frame": "odom", "base_frame": "base_link", "sensor_frame": "laser"}
"""Frame-name parameters and their defaults."""


def _finite_point(msg: gm.PointStamped) -> NDArray[np.float64]:
    values = (msg.point.x, msg.point.y, msg.point.z)
    if not all(math.isfinite(v) for v in values):
        raise InvalidInput("point", values, "must be finite (no NaN or inf)")
    return np.array(values[:2])


def _odometry_pose(msg: Odometry) -> NDArray[np.float64]:
    """(x, y, yaw) of an odometry message; yaw = atan2(2(wz + xy), w² + x² − y² − z²), the rotation about z
    of the quaternion (x, y, z, w), valid for any non-zero scale of it (rad)."""
    position, q = msg.pose.pose.position, msg.pose.pose.orientation
    values = (position.x, position.y, q.x, q.y, q.z, q.w)
    if not all(math.isfinite(v) for v in values):
        raise InvalidInput("pose.pose", values, "must be finite (no NaN or inf)")
    if q.x == q.y == q.z == q.w == 0.0:
        raise InvalidInput("pose.pose.orientation", (q.x, q.y, q.z, q.w), "must be a non-zero quaternion")
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), q.w**2 + q.x**2 - q.y**2 - q.z**2)
    return np.array([position.x, position.y, yaw])


class BaseControllerNode(Node):
    """The ``/base_controller`` node (see the module docstring); ``clock`` gives monotonic seconds."""

    name = "/base_controller"

    def __init__(self, bus: Bus, params: VectorFieldParams | None = None, config: ControllerConfig | None = None,
                 rate: float = 20.0, clock: Callable[[], float] = time.monotonic) -> None:
        super().__init__(bus)
        if not (math.isfinite(rate) and rate > 0):
            raise InvalidInput("rate", rate, "must be a positive number of ticks per second")
        self.tick_period = 1.0 / rate
        self._lock = threading.Lock()
        self._controller = BaseController(params, config)
        self._frames = dict(FRAME_PARAMETERS)
        self._clock = clock
        self._pose = np.zeros(3)
        self._command = np.zeros(3)
        self._last_tick: float | None = None
        self._has_odometry = False

    # ---- contract -----------------------------------------------------------------------------------
    def services(self) -> list[ServiceSpec]:
        return [ServiceSpec("/base_controller/cancel_goal", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, self.on_cancel_goal)]

    def subscriptions(self) -> list[SubscriptionSpec]:
        return [SubscriptionSpec("/goal_point", "geometry_msgs/msg/PointStamped", gm.PointStamped, self.on_goal),
                SubscriptionSpec("/scan", "sensor_msgs/msg/LaserScan", LaserScan, self.on_scan),
                SubscriptionSpec("/cmd_vel_teleop", "geometry_msgs/msg/Twist", gm.Twist, self.on_teleop),
                SubscriptionSpec("/odom", "nav_msgs/msg/Odometry", Odometry, self.on_odom)]

    def publications(self) -> list[PublicationSpec]:
        return [PublicationSpec("/cmd_vel", "geometry_msgs/msg/Twist", gm.Twist)]

    def get_parameters(self) -> dict[str, Any]:
        with self._lock:
            return self._controller.params.as_dict() | self._controller.config.as_dict() | dict(self._frames)

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        field_names, config_names = set(VectorFieldParams.names()), set(ControllerConfig.names())
        for key, value in values.items():
            if key not in field_names | config_names | set(FRAME_PARAMETERS):
                raise InvalidInput(key, value, f"unknown parameter of {self.name}")
            if isinstance(value, bool):
                raise InvalidInput(key, value, "booleans are not accepted here")
            if key in FRAME_PARAMETERS and (not isinstance(value, str) or not value.strip()):
                raise InvalidInput(key, value, "must be a non-empty frame name")
        with self._lock:
            params = replace(self._controller.params, **{k: v for k, v in values.items() if k in field_names})
            config = replace(self._controller.config, **{k: v for k, v in values.items() if k in config_names})
            self._controller.reconfigure(params, config)
            self._frames.update({k: str(v) for k, v in values.items() if k in FRAME_PARAMETERS})
        return self.get_parameters()

    def tick(self, now: float) -> None:
        """Dead-reckon the pose over the last period (until odometry arrives), run the controller and publish
        ``/cmd_vel``."""
        with self._lock:
            if not self._has_odometry and self._last_tick is not None and now > self._last_tick:
                self._pose = integrate_pose(self._pose, self._command, now - self._last_tick)
            self._last_tick = now
            command = self._controller.step(self._pose, now)
            self._command = np.array([command.linear_x, command.linear_y, command.angular_z])
        twist = gm.Twist(linear=gm.Vector3(x=command.linear_x, y=command.linear_y),
                         angular=gm.Vector3(z=command.angular_z))
        self.bus.publish("/cmd_vel", twist)

    # ---- handlers -------------------------------------------------------------------------------------
    def on_goal(self, msg: gm.PointStamped) -> None:
        """Follow the point; ``header.frame_id`` must be ``odom_frame``, empty or ``base_frame``."""
        point = _finite_point(msg)
        with self._lock:
            frame = msg.header.frame_id
            if frame in ("", self._frames["odom_frame"]):
                goal = point
            elif frame == self._frames["base_frame"]:
                goal = compose_pose2d(self._pose, (point[0], point[1], 0.0))[:2]
            else:
                raise UnknownFrame("header.frame_id", frame, f"expected {self._frames['odom_frame']!r} or "
                                   f"{self._frames['base_frame']!r}")
            self._controller.set_goal(goal)
        _log.info("goal (%.3f, %.3f) in %s", goal[0], goal[1], self._frames["odom_frame"])

    def on_scan(self, msg: LaserScan) -> None:
        """Replace the obstacles by the scan's points (weighted by ``scan_weighting``)."""
        with self._lock:
            frame = msg.header.frame_id
            config = self._controller.config
            if frame == self._frames["base_frame"]:
                mount = (0.0, 0.0, 0.0)
            elif frame in ("", self._frames["sensor_frame"]):
                mount = config.sensor_pose
            else:
                raise UnknownFrame("header.frame_id", frame, f"expected {self._frames['sensor_frame']!r} or "
                                   f"{self._frames['base_frame']!r}")
            sensor = compose_pose2d(self._pose, mount)
            obstacles = scan_obstacles(msg, sensor, config.scan_weighting, config.scan_sector_angle)
            self._controller.set_obstacles(obstacles)

    def on_teleop(self, msg: gm.Twist) -> None:
        """The operator's velocity (robot frame); live for ``teleop_timeout`` seconds."""
        with self._lock:
            self._controller.set_teleop(msg.linear.x, msg.linear.y, msg.angular.z, self._clock())

    def on_odom(self, msg: Odometry) -> None:
        """Take the robot pose from odometry (``header.frame_id`` must be ``odom_frame`` or empty); from the
        first accepted message on, dead-reckoning stops."""
        pose = _odometry_pose(msg)
        with self._lock:
            frame = msg.header.frame_id
            if frame not in ("", self._frames["odom_frame"]):
                raise UnknownFrame("header.frame_id", frame, f"expected {self._frames['odom_frame']!r} or empty")
            self._pose = pose
            self._has_odometry = True

    def on_cancel_goal(self, request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        """Stop point following."""
        with self._lock:
            had_goal = self._controller.goal is not None
            self._controller.set_goal(None)
        return std_srvs.Trigger_Response(success=True, message="goal cancelled" if had_goal else "no goal was set")

    # ---- state ----------------------------------------------------------------------------------------
    @property
    def state(self) -> ControllerState:
        """State of the last tick (``idle``, ``following``, ``goal_reached``, ``stuck``, ``teleop`` …)."""
        with self._lock:
            return self._controller.state

    @property
    def pose(self) -> NDArray[np.float64]:
        """Robot pose (x, y, yaw) in ``odom_frame``: the last odometry, or dead-reckoned before any arrived."""
        with self._lock:
            return self._pose.copy()

    @property
    def goal(self) -> NDArray[np.float64] | None:
        """Active goal (x, y) in ``odom_frame``, or None."""
        with self._lock:
            return self._controller.goal

    @property
    def obstacle_points(self) -> NDArray[np.float64]:
        """Current obstacle points (M, 2) in ``odom_frame`` (from the last accepted scan)."""
        with self._lock:
            return self._controller.obstacles.points.copy()
