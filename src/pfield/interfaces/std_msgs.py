"""``std_msgs`` and ``builtin_interfaces`` messages."""

from __future__ import annotations

from typing import Self

from pydantic import Field

from pfield.interfaces._base import Float32, Int32, RosMessage, String, UInt32


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
    frame_id: String = ""


class ColorRGBA(RosMessage):
    """Colour with components in [0, 1] (not enforced, as in ROS)."""

    ros_type = "std_msgs/msg/ColorRGBA"
    r: Float32 = 0.0
    g: Float32 = 0.0
    b: Float32 = 0.0
    a: Float32 = 0.0


class Empty(RosMessage):
    ros_type = "std_msgs/msg/Empty"
