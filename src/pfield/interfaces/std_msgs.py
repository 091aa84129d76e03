"""``std_msgs`` and ``builtin_interfaces`` messages."""

from __future__ import annotations

from typing import Self

from pydantic import Field

from pfield.interfaces._base import Float32, Float64, Int32, RosMessage, UInt32
from pfield.interfaces._base import Int8 as _Int8
from pfield.interfaces._base import String as _String


class _SecondsNanoseconds(RosMessage):
    """``sec`` + ``nanosec`` as in builtin_interfaces; ``from_seconds`` floors so nanosec is in [0, 1e9)."""

    sec: Int32 = 0
    nanosec: UInt32 = 0

    @classmethod
    def from_seconds(cls, seconds: float) -> Self:
        total_ns = round(seconds * 1e9)
        return cls(sec=total_ns // 1_000_000_000, nanosec=total_ns % 1_000_000_000)

    def to_seconds(self) -> float:
        return self.sec + self.nanosec * 1e-9


class Time(_SecondsNanoseconds):
    ros_type = "builtin_interfaces/msg/Time"


class Duration(_SecondsNanoseconds):
    ros_type = "builtin_interfaces/msg/Duration"


class Header(RosMessage):
    ros_type = "std_msgs/msg/Header"
    stamp: Time = Field(default_factory=Time)
    frame_id: _String = ""


class ColorRGBA(RosMessage):
    """Colour with components in [0, 1] (not enforced, as in ROS)."""

    ros_type = "std_msgs/msg/ColorRGBA"
    r: Float32 = 0.0
    g: Float32 = 0.0
    b: Float32 = 0.0
    a: Float32 = 0.0


class Empty(RosMessage):
    ros_type = "std_msgs/msg/Empty"


class Int8(RosMessage):
    """A signed byte (the servo's status code on ``status_topic``, as MoveIt Servo publishes it)."""

    ros_type = "std_msgs/msg/Int8"
    data: _Int8 = 0


class String(RosMessage):
    ros_type = "std_msgs/msg/String"
    data: _String = ""


class MultiArrayDimension(RosMessage):
    ros_type = "std_msgs/msg/MultiArrayDimension"
    label: _String = ""
    size: UInt32 = 0
    stride: UInt32 = 0


class MultiArrayLayout(RosMessage):
    ros_type = "std_msgs/msg/MultiArrayLayout"
    dim: list[MultiArrayDimension] = Field(default_factory=list)
    data_offset: UInt32 = 0


class Float64MultiArray(RosMessage):
    """Numbers with an optional layout: the servo's joint positions or velocities for a ros2_control
    forward command controller (``data`` in the controller's joint order)."""

    ros_type = "std_msgs/msg/Float64MultiArray"
    layout: MultiArrayLayout = Field(default_factory=MultiArrayLayout)
    data: list[Float64] = Field(default_factory=list)
