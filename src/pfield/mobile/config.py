"""Options of the 2D base controller (:class:`ControllerConfig`); field names equal the ROS parameter names.

The field's own shape and speed bounds are :class:`~pfield.mobile.params.VectorFieldParams`; this holds
what turns the field into a robot command: drive type, limits, timeouts, stuck detection, scan handling.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, Literal

from pfield._validation import finite, nonnegative, positive
from pfield.errors import InvalidInput
from pfield.mobile.scan import SCAN_WEIGHTINGS

__all__ = ["DRIVES", "TELEOP_MODES", "ControllerConfig"]

DRIVES = ("holonomic", "diff_drive")
TELEOP_MODES = ("assisted", "field")
"""``assisted`` (default): the field slows, stops and steers the operator's command but never reverses it (as
nav2's assisted teleop). ``field``: the seed's pure law u + r, capped at ‖u‖: near a wall the repulsion may
push the base back, up to the operator's speed."""


@dataclass(frozen=True)
class ControllerConfig:
    """Controller options (SI units).

    Attributes:
        drive: ``holonomic`` (command vx, vy in the robot frame) or ``diff_drive`` (v, ω only).
        lookahead: diff drive: distance (m) ahead of the axle of the point whose velocity follows the
            field (feedback linearisation, Siciliano et al., *Robotics*, 2009, §11.6.3), > 0.
        max_angular_speed: bound on |ω| (rad/s), > 0; a diff-drive command over it is scaled as a whole
            (path curvature kept).
        max_linear_acceleration: bound on the change of the linear command (m/s²); 0 = unlimited.
        max_angular_acceleration: bound on the change of ω (rad/s²); 0 = unlimited.
        teleop_timeout: a teleop command older than this (s) is stale: the controller commands zero.
        stuck_window: window (s) of stuck detection.
        stuck_speed: a goal is reported ``stuck`` when the robot's mean speed over the window stays
            below this (m/s) while the goal is not reached.
        scan_weighting: ``sector`` (default), ``arc_length`` or ``sum``, see :mod:`pfield.mobile.scan`.
        scan_sector_angle: sector width (rad) of the ``sector`` weighting, in (0, 2π].
        sensor_x, sensor_y, sensor_yaw: pose of the laser in the robot frame (m, m, rad).
        teleop_mode: ``assisted`` (default: the repulsion slows, stops and steers the operator's command,
            never reverses it) or ``field`` (the seed's pure law, which may push the base back), see
            :data:`TELEOP_MODES`.
    """

    drive: Literal["holonomic", "diff_drive"] = "holonomic"
    lookahead: float = 0.2
    max_angular_speed: float = 1.0
    max_linear_acceleration: float = 1.0
    max_angular_acceleration: float = 2.0
    teleop_timeout: float = 0.5
    stuck_window: float = 2.0
    stuck_speed: float = 0.02
    scan_weighting: Literal["sector", "arc_length", "sum"] = "sector"
    scan_sector_angle: float = math.radians(5.0)
    sensor_x: float = 0.0
    sensor_y: float = 0.0
    sensor_yaw: float = 0.0
    teleop_mode: Literal["assisted", "field"] = "assisted"

    def __post_init__(self) -> None:
        if self.drive not in DRIVES:
            raise InvalidInput("drive", self.drive, f"must be one of {DRIVES}")
        if self.teleop_mode not in TELEOP_MODES:
            raise InvalidInput("teleop_mode", self.teleop_mode, f"must be one of {TELEOP_MODES}")
        if self.scan_weighting not in SCAN_WEIGHTINGS:
            raise InvalidInput("scan_weighting", self.scan_weighting, f"must be one of {SCAN_WEIGHTINGS}")
        set_ = object.__setattr__
        for name in ("lookahead", "max_angular_speed", "teleop_timeout", "stuck_window", "scan_sector_angle"):
            set_(self, name, positive(name, getattr(self, name)))
        for name in ("max_linear_acceleration", "max_angular_acceleration", "stuck_speed"):
            set_(self, name, nonnegative(name, getattr(self, name)))
        for name in ("sensor_x", "sensor_y", "sensor_yaw"):
            set_(self, name, finite(name, getattr(self, name)))
        if self.scan_sector_angle > 2.0 * math.pi:
            raise InvalidInput("scan_sector_angle", self.scan_sector_angle, "must be <= 2*pi")

    @property
    def sensor_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the laser in the robot frame."""
        return (self.sensor_x, self.sensor_y, self.sensor_yaw)

    def as_dict(self) -> dict[str, Any]:
        """Options by ROS parameter name (JSON-compatible)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The ROS parameter names, in declaration order."""
        return tuple(f.name for f in fields(cls))
