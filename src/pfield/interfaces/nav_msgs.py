"""``nav_msgs`` messages used by pfield (planned paths, occupancy grids)."""

from __future__ import annotations

from pydantic import Field

from pfield.interfaces._base import Float32, Int8, RosMessage, UInt32
from pfield.interfaces.geometry_msgs import Pose, PoseStamped
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
