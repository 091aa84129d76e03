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
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import std_srvs
from pfield.interfaces.convert import point_from_msg, quaternion_from_msg
from pfield.interfaces.nav_msgs import Odometry
from pfield.interfaces.sensor_msgs import LaserScan
from pfield.mobile.config import DRIVES, TELEOP_MODES, ControllerConfig
from pfield.mobile.controller import BaseController, ControllerState
from pfield.mobile.params import ATTRACTION_LAWS, CLAMPING_MODES, VectorFieldParams
from pfield.mobile.scan import SCAN_WEIGHTINGS, compose_pose2d, scan_obstacles
from pfield.mobile.sim import integrate_pose
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.node._frames import StaticTransforms
from pfield.node._params import ParameterRow, ParameterTable, field_docs
from pfield.spatial import Pose

__all__ = ["FRAME_PARAMETERS", "BaseControllerNode", "BaseState", "base_controller_table"]

_log = logging.getLogger(__name__)
FRAME_PARAMETERS = {"odom_frame": "odom", "base_frame": "base_link", "sensor_frame": "laser"}
"""Frame-name parameters and their defaults."""


# Ranges a real mobile base stays well inside (SI units); the config classes add > 0 and cross-field rules.
_RANGES: dict[str, tuple[float, float, str]] = {
    "ka": (0.0, 10.0, ""), "kr_dist": (-10.0, 10.0, "m"), "kr_height": (0.0, 100.0, "m/s"),
    "kr_slope": (0.0, 1000.0, "1/m"), "min_spd_norm": (0.0, 10.0, "m/s"), "max_spd_norm": (0.0, 10.0, "m/s"),
    "goal_tolerance": (0.0, 10.0, "m"), "lookahead": (0.0, 10.0, "m"),
    "max_angular_speed": (0.0, 10 * math.pi, "rad/s"),
    "max_linear_acceleration": (0.0, 100.0, "m/s²"), "max_angular_acceleration": (0.0, 100.0, "rad/s²"),
    "teleop_timeout": (0.0, 60.0, "s"), "stuck_window": (0.0, 3600.0, "s"), "stuck_speed": (0.0, 10.0, "m/s"),
    "scan_sector_angle": (0.0, 2 * math.pi, "rad"), "sensor_x": (-50.0, 50.0, "m"), "sensor_y": (-50.0, 50.0, "m"),
    "sensor_yaw": (-2 * math.pi, 2 * math.pi, "rad"),
}
_POSITIVE = {"kr_slope", "max_spd_norm", "lookahead", "max_angular_speed", "teleop_timeout", "stuck_window",
             "scan_sector_angle"}
_CHOICES = {"attraction": ATTRACTION_LAWS, "clamping": CLAMPING_MODES, "drive": DRIVES,
            "scan_weighting": SCAN_WEIGHTINGS, "teleop_mode": TELEOP_MODES}
_FRAME_DOCS = {"odom_frame": "fixed frame of odometry, goals and the robot pose",
               "base_frame": "the robot's frame (goals in it are relative to the robot)",
               "sensor_frame": "the laser's frame (mounted at sensor_x, sensor_y, sensor_yaw)"}


def base_controller_table(name: str) -> ParameterTable:
    """The ``/base_controller`` parameter table: the field's and the controller's options, then the frames."""
    rows = []
    for cls in (VectorFieldParams, ControllerConfig):
        defaults, docs = cls(), field_docs(cls)
        for key in cls.names():
            default = getattr(defaults, key)
            if key in _CHOICES:
                rows.append(ParameterRow(key, "string", docs[key], default, choices=tuple(_CHOICES[key])))
            else:
                rows.append(ParameterRow(key, "double", docs[key], default, *_RANGES[key], positive=key in _POSITIVE))
    rows += [ParameterRow(key, "string", _FRAME_DOCS[key], default) for key, default in FRAME_PARAMETERS.items()]
    return ParameterTable(name, rows)


def _odometry_pose(msg: Odometry) -> NDArray[np.float64]:
    """(x, y, yaw) of an odometry message; yaw = atan2(2(wz + xy), w² + x² − y² − z²), the rotation about z
    of the quaternion (x, y, z, w), computed on the quaternion scaled to unit norm (rad)."""
    position = point_from_msg(msg.pose.pose.position, "pose.pose.position")
    q = quaternion_from_msg(msg.pose.pose.orientation, "pose.pose.orientation")
    scaled = q / np.max(np.abs(q))  # largest component 1: the squares below cannot overflow
    x, y, z, w = (scaled / np.linalg.norm(scaled)).tolist()
    yaw = math.atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)
    return np.array([position[0], position[1], yaw])


@dataclass(frozen=True, eq=False)
class BaseState:
    """The node's own state as one immutable value (swapped whole under the node's lock): the frame names,
    the robot pose (x, y, yaw) in ``odom_frame``, the last command, the last tick time and whether odometry
    has arrived. The controller's dynamics (goal, teleop, rate limits) live in its
    :class:`~pfield.mobile.controller.BaseController`."""

    frames: Mapping[str, str] = field(default_factory=lambda: MappingProxyType(dict(FRAME_PARAMETERS)))
    pose: NDArray[np.float64] = field(default_factory=lambda: _frozen(np.zeros(3)))
    command: NDArray[np.float64] = field(default_factory=lambda: _frozen(np.zeros(3)))
    last_tick: float | None = None
    has_odometry: bool = False
    version: int = 0

    def evolve(self, **changes: Any) -> BaseState:
        for name in ("pose", "command"):
            if name in changes:
                changes[name] = _frozen(np.array(changes[name], dtype=np.float64))
        if "frames" in changes:
            changes["frames"] = MappingProxyType(dict(changes["frames"]))
        return replace(self, **changes, version=self.version + 1)


def _frozen(array: NDArray[np.float64]) -> NDArray[np.float64]:
    array.setflags(write=False)
    return array


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
        self.parameter_table = base_controller_table(self.name)
        self._clock = clock
        self._state = BaseState()

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
            return self._controller.params.as_dict() | self._controller.config.as_dict() | dict(self._state.frames)

    def describe_parameters(self) -> dict[str, dict[str, Any]]:
        return self.parameter_table.describe()

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        field_names, config_names = set(VectorFieldParams.names()), set(ControllerConfig.names())
        values = self.parameter_table.check(values)
        for key, value in values.items():
            if key in FRAME_PARAMETERS and not value.strip():
                raise InvalidInput(key, value, "must be a non-empty frame name")
        with self._lock:
            params = replace(self._controller.params, **{k: v for k, v in values.items() if k in field_names})
            config = replace(self._controller.config, **{k: v for k, v in values.items() if k in config_names})
            self._controller.reconfigure(params, config)
            frames = dict(self._state.frames) | {k: str(v) for k, v in values.items() if k in FRAME_PARAMETERS}
            self._state = self._state.evolve(frames=frames)
        return self.get_parameters()

    def tick(self, now: float) -> None:
        """Dead-reckon the pose over the last period (until odometry arrives), run the controller and publish
        ``/cmd_vel``."""
        with self._lock:
            state = self._state
            pose = state.pose
            if not state.has_odometry and state.last_tick is not None and now > state.last_tick:
                pose = integrate_pose(state.pose, state.command, now - state.last_tick)
            command = self._controller.step(pose, now)
            self._state = state.evolve(pose=pose, last_tick=now,
                                       command=[command.linear_x, command.linear_y, command.angular_z])
        twist = gm.Twist(linear=gm.Vector3(x=command.linear_x, y=command.linear_y),
                         angular=gm.Vector3(z=command.angular_z))
        self.bus.publish("/cmd_vel", twist)

    # ---- handlers -------------------------------------------------------------------------------------
    def frames(self) -> StaticTransforms:
        """The frames service of this node: ``odom_frame`` fixed, ``base_frame`` at the robot pose and
        ``sensor_frame`` at the laser's mount on it (their poses in ``odom_frame``, at this instant)."""
        with self._lock:
            state = self._state
            robot = tuple(float(v) for v in state.pose)
            mount = compose_pose2d(state.pose, self._controller.config.sensor_pose)
            names = dict(state.frames)
        return StaticTransforms(names["odom_frame"], {names["base_frame"]: Pose.planar(*robot),
                                                      names["sensor_frame"]: Pose.planar(*mount)})

    def on_goal(self, msg: gm.PointStamped) -> None:
        """Follow the point; ``header.frame_id`` must be ``odom_frame``, empty or ``base_frame``."""
        point = point_from_msg(msg.point, "point")
        frame = msg.header.frame_id
        frames = self.frames()
        if frame not in ("", frames.fixed_frame, self._state.frames["base_frame"]):
            raise UnknownFrame("header.frame_id", frame, f"expected {frames.fixed_frame!r} or "
                               f"{self._state.frames['base_frame']!r}")
        transform = frames.lookup("header.frame_id", frame)
        goal = point[:2] if transform is None else (transform * Pose(point)).position[:2]
        with self._lock:
            self._controller.set_goal(np.array(goal))
        _log.info("goal (%.3f, %.3f) in %s", goal[0], goal[1], self._state.frames["odom_frame"])

    def on_scan(self, msg: LaserScan) -> None:
        """Replace the obstacles by the scan's points (weighted by ``scan_weighting``)."""
        with self._lock:
            frame = msg.header.frame_id
            config = self._controller.config
            if frame == self._state.frames["base_frame"]:
                mount = (0.0, 0.0, 0.0)
            elif frame in ("", self._state.frames["sensor_frame"]):
                mount = config.sensor_pose
            else:
                raise UnknownFrame("header.frame_id", frame, f"expected {self._state.frames['sensor_frame']!r} or "
                                   f"{self._state.frames['base_frame']!r}")
            sensor = compose_pose2d(self._state.pose, mount)  # the frames service's sensor_frame pose when mounted
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
            if frame not in ("", self._state.frames["odom_frame"]):
                raise UnknownFrame("header.frame_id", frame, f"expected {self._state.frames['odom_frame']!r} or empty")
            self._state = self._state.evolve(pose=pose, has_odometry=True)

    def on_cancel_goal(self, request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        """Stop point following."""
        with self._lock:
            had_goal = self._controller.goal is not None
            self._controller.set_goal(None)
        return std_srvs.Trigger_Response(success=True, message="goal cancelled" if had_goal else "no goal was set")

    # ---- state ----------------------------------------------------------------------------------------
    @property
    def snapshot(self) -> BaseState:
        """The node's current state value (immutable)."""
        return self._state

    @property
    def state(self) -> ControllerState:
        """State of the last tick (``idle``, ``following``, ``goal_reached``, ``stuck``, ``teleop`` …)."""
        with self._lock:
            return self._controller.state

    @property
    def pose(self) -> NDArray[np.float64]:
        """Robot pose (x, y, yaw) in ``odom_frame``: the last odometry, or dead-reckoned before any arrived."""
        with self._lock:
            return self._state.pose.copy()

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
