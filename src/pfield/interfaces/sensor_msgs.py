"""``sensor_msgs`` messages: ``LaserScan`` (the mobile base), ``JointState`` and ``Joy`` (robot state and operator
devices in: the manager's ``/joint_states``, the servo loop's joystick input).

Fields exactly as ``sensor_msgs/msg/LaserScan`` (ROS 2 Jazzy). Beam ``i`` points at
``angle_min + i * angle_increment`` (rad, counter-clockwise from the sensor frame's +x axis). Ranges outside
``[range_min, range_max]`` or non-finite (``inf`` = no return, ``nan`` = invalid) are to be ignored by consumers;
the model therefore accepts ``inf``/``nan`` in ``ranges`` (pydantic's default), as the ROS type does.
"""

from __future__ import annotations

from pydantic import ConfigDict, Field

from pfield.interfaces._base import Float32, Float64, Int32, RosMessage, String
from pfield.interfaces.std_msgs import Header

__all__ = ["JointState", "Joy", "LaserScan"]


class LaserScan(RosMessage):
    """A planar laser scan (angles in rad, ranges in m, times in s)."""

    # ``inf`` ranges are normal ("no return"): keep them through JSON as ``Infinity``/``NaN`` literals
    # (what Python's json module and pydantic read back) instead of pydantic's default ``null``.
    model_config = ConfigDict(**{**RosMessage.model_config, "ser_json_inf_nan": "constants"})  # type: ignore[typeddict-item]

    ros_type = "sensor_msgs/msg/LaserScan"
    header: Header = Field(default_factory=Header)
    angle_min: Float32 = 0.0
    angle_max: Float32 = 0.0
    angle_increment: Float32 = 0.0
    time_increment: Float32 = 0.0
    scan_time: Float32 = 0.0
    range_min: Float32 = 0.0
    range_max: Float32 = 0.0
    ranges: list[Float32] = Field(default_factory=list)
    intensities: list[Float32] = Field(default_factory=list)


class JointState(RosMessage):
    """The state of named joints (``sensor_msgs/msg/JointState``): ``position`` in rad or m, ``velocity`` in rad/s
    or m/s, ``effort`` in N·m or N, each either empty or as long as ``name`` (the ROS definition's rule)."""

    ros_type = "sensor_msgs/msg/JointState"
    header: Header = Field(default_factory=Header)
    name: list[String] = Field(default_factory=list)
    position: list[Float64] = Field(default_factory=list)
    velocity: list[Float64] = Field(default_factory=list)
    effort: list[Float64] = Field(default_factory=list)


class Joy(RosMessage):
    """A joystick's state (``sensor_msgs/msg/Joy``): ``axes`` (unitless, usually in [-1, 1]) and ``buttons``
    (0 or 1); their meaning is the device's (the servo's mapping: docs/servo.md)."""

    ros_type = "sensor_msgs/msg/Joy"
    header: Header = Field(default_factory=Header)
    axes: list[Float32] = Field(default_factory=list)
    buttons: list[Int32] = Field(default_factory=list)
