"""``nav_msgs`` messages used by pfield (planned paths, occupancy grids, odometry)."""

from __future__ import annotations

from pydantic import Field

from pfield.interfaces._base import Float32, Int8, RosMessage, String, UInt32
from pfield.interfaces.geometry_msgs import Pose, PoseStamped, PoseWithCovariance, TwistWithCovariance
from pfield.interfaces.std_msgs import Header, Time


class Path(RosMessage):
    ros_type = "nav_msgs/msg/Path"
    header: Header = Field(default_factory=Header)
    poses: list[PoseStamped] = Field(default_factory=list)


class MapMetaData(RosMessage):
    """Grid geometry: ``resolution`` (m/cell), ``width``/``height`` (cells), ``origin`` of cell (0, 0)."""

    ros_type = "nav_msgs/msg/MapMetaData"
    map_load_time: Time = Field(default_factory=Time)
    resolution: Float32 = 0.0
    width: UInt32 = 0
    height: UInt32 = 0
    origin: Pose = Field(default_factory=Pose)


class OccupancyGrid(RosMessage):
    """Row-major grid (row = y index), values 0..100 occupancy probability, -1 unknown."""

    ros_type = "nav_msgs/msg/OccupancyGrid"
    header: Header = Field(default_factory=Header)
    info: MapMetaData = Field(default_factory=MapMetaData)
    data: list[Int8] = Field(default_factory=list)


class Odometry(RosMessage):
    """Pose in ``header.frame_id`` (e.g. ``odom``) and velocity in ``child_frame_id`` (the robot, e.g.
    ``base_link``), each with a row-major 6x6 covariance."""

    ros_type = "nav_msgs/msg/Odometry"
    header: Header = Field(default_factory=Header)
    child_frame_id: String = ""
    pose: PoseWithCovariance = Field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = Field(default_factory=TwistWithCovariance)
