"""``visualization_msgs`` Marker/MarkerArray (ROS 2 Jazzy layout) for RViz-style displays.

``Marker`` of Jazzy carries a ``sensor_msgs/CompressedImage`` texture; that small type is defined here
(registered under its ``sensor_msgs`` name) so that this module does not depend on the LaserScan module.
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field

from pfield.interfaces._base import Bool, Float32, Int32, RosMessage, String, UInt8
from pfield.interfaces.geometry_msgs import Point, Pose, Vector3
from pfield.interfaces.std_msgs import ColorRGBA, Duration, Header


class CompressedImage(RosMessage):
    ros_type = "sensor_msgs/msg/CompressedImage"
    header: Header = Field(default_factory=Header)
    format: String = ""
    data: list[UInt8] = Field(default_factory=list)


class UVCoordinate(RosMessage):
    ros_type = "visualization_msgs/msg/UVCoordinate"
    u: Float32 = 0.0
    v: Float32 = 0.0


class MeshFile(RosMessage):
    ros_type = "visualization_msgs/msg/MeshFile"
    filename: String = ""
    data: list[UInt8] = Field(default_factory=list)


_MARKER_CONSTANTS = {
    "ARROW": 0, "CUBE": 1, "SPHERE": 2, "CYLINDER": 3, "LINE_STRIP": 4, "LINE_LIST": 5, "CUBE_LIST": 6,
    "SPHERE_LIST": 7, "POINTS": 8, "TEXT_VIEW_FACING": 9, "MESH_RESOURCE": 10, "TRIANGLE_LIST": 11,
    "ARROW_STRIP": 12, "ADD": 0, "MODIFY": 0, "DELETE": 2, "DELETEALL": 3,
}


class Marker(RosMessage):
    """One RViz marker; ``scale`` is in m (full extents for CUBE/SPHERE/CYLINDER, line width for lines)."""

    ros_type = "visualization_msgs/msg/Marker"
    ros_constants: ClassVar[dict[str, tuple[str, Any]]] = {
        name: ("int32", value) for name, value in _MARKER_CONSTANTS.items()
    }
    ARROW: ClassVar[int] = 0
    CUBE: ClassVar[int] = 1
    SPHERE: ClassVar[int] = 2
    CYLINDER: ClassVar[int] = 3
    LINE_STRIP: ClassVar[int] = 4
    LINE_LIST: ClassVar[int] = 5
    CUBE_LIST: ClassVar[int] = 6
    SPHERE_LIST: ClassVar[int] = 7
    POINTS: ClassVar[int] = 8
    TEXT_VIEW_FACING: ClassVar[int] = 9
    MESH_RESOURCE: ClassVar[int] = 10
    TRIANGLE_LIST: ClassVar[int] = 11
    ARROW_STRIP: ClassVar[int] = 12
    ADD: ClassVar[int] = 0
    MODIFY: ClassVar[int] = 0
    DELETE: ClassVar[int] = 2
    DELETEALL: ClassVar[int] = 3

    header: Header = Field(default_factory=Header)
    ns: String = ""
    id: Int32 = 0
    type: Int32 = 0
    action: Int32 = 0
    pose: Pose = Field(default_factory=Pose)
    scale: Vector3 = Field(default_factory=Vector3)
    color: ColorRGBA = Field(default_factory=ColorRGBA)
    lifetime: Duration = Field(default_factory=Duration)
    frame_locked: Bool = False
    points: list[Point] = Field(default_factory=list)
    colors: list[ColorRGBA] = Field(default_factory=list)
    texture_resource: String = ""
    texture: CompressedImage = Field(default_factory=CompressedImage)
    uv_coordinates: list[UVCoordinate] = Field(default_factory=list)
    text: String = ""
    mesh_resource: String = ""
    mesh_file: MeshFile = Field(default_factory=MeshFile)
    mesh_use_embedded_materials: Bool = False


class MarkerArray(RosMessage):
    ros_type = "visualization_msgs/msg/MarkerArray"
    markers: list[Marker] = Field(default_factory=list)
