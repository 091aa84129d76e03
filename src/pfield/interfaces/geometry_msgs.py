"""``geometry_msgs`` messages used by pfield."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from pfield.interfaces._base import Float64, RosMessage, RosType
from pfield.interfaces.std_msgs import Header


class Vector3(RosMessage):
    ros_type = "geometry_msgs/msg/Vector3"
    x: Float64 = 0.0
    y: Float64 = 0.0
    z: Float64 = 0.0


class Point(RosMessage):
    ros_type = "geometry_msgs/msg/Point"
    x: Float64 = 0.0
    y: Float64 = 0.0
    z: Float64 = 0.0


class Quaternion(RosMessage):
    """Note the ROS default: a missing ``w`` is 1.0 (identity), as in ``geometry_msgs/Quaternion``."""

    ros_type = "geometry_msgs/msg/Quaternion"
    x: Float64 = 0.0
    y: Float64 = 0.0
    z: Float64 = 0.0
    w: Float64 = 1.0


class Pose(RosMessage):
    ros_type = "geometry_msgs/msg/Pose"
    position: Point = Field(default_factory=Point)
    orientation: Quaternion = Field(default_factory=Quaternion)


class PoseStamped(RosMessage):
    ros_type = "geometry_msgs/msg/PoseStamped"
    header: Header = Field(default_factory=Header)
    pose: Pose = Field(default_factory=Pose)


class PointStamped(RosMessage):
    ros_type = "geometry_msgs/msg/PointStamped"
    header: Header = Field(default_factory=Header)
    point: Point = Field(default_factory=Point)


Covariance36 = Annotated[list[Float64], Field(min_length=36, max_length=36), RosType("float64[36]")]
"""Row-major 6x6 covariance (x, y, z, rotation about x, y, z), ROS's fixed-size ``float64[36]``."""


def _zero_covariance() -> list[float]:
    return [0.0] * 36


class PoseWithCovariance(RosMessage):
    ros_type = "geometry_msgs/msg/PoseWithCovariance"
    pose: Pose = Field(default_factory=Pose)
    covariance: Covariance36 = Field(default_factory=_zero_covariance)


class Twist(RosMessage):
    ros_type = "geometry_msgs/msg/Twist"
    linear: Vector3 = Field(default_factory=Vector3)
    angular: Vector3 = Field(default_factory=Vector3)


class TwistWithCovariance(RosMessage):
    ros_type = "geometry_msgs/msg/TwistWithCovariance"
    twist: Twist = Field(default_factory=Twist)
    covariance: Covariance36 = Field(default_factory=_zero_covariance)


class TwistStamped(RosMessage):
    ros_type = "geometry_msgs/msg/TwistStamped"
    header: Header = Field(default_factory=Header)
    twist: Twist = Field(default_factory=Twist)


class Pose2D(RosMessage):
    ros_type = "geometry_msgs/msg/Pose2D"
    x: Float64 = 0.0
    y: Float64 = 0.0
    theta: Float64 = 0.0
