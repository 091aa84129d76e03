"""pydantic models <-> rclpy messages (pfield.transport._ros2_convert), in-process, no DDS traffic."""

from __future__ import annotations

import array
import math

import pytest
from pydantic import Field
from ros2_helpers.support import require_ros2_python

require_ros2_python()

import numpy as np  # noqa: E402
from builtin_interfaces.msg import Duration as RosDuration  # noqa: E402
from geometry_msgs.msg import PoseWithCovariance as RosPoseWithCovariance  # noqa: E402
from nav_msgs.msg import OccupancyGrid as RosOccupancyGrid  # noqa: E402
from potential_fields_interfaces.msg import ObstacleArray as RosObstacleArray  # noqa: E402
from potential_fields_interfaces.srv import PlanPath as RosPlanPath  # noqa: E402
from visualization_msgs.msg import MarkerArray as RosMarkerArray  # noqa: E402

import pfield.interfaces.all  # noqa: E402, F401
import pfield.interfaces.potential_fields_interfaces as pfi  # noqa: E402
from pfield.interfaces import registered_types  # noqa: E402
from pfield.interfaces._base import Float64, RosMessage  # noqa: E402
from pfield.interfaces.geometry_msgs import Pose  # noqa: E402
from pfield.interfaces.nav_msgs import OccupancyGrid  # noqa: E402
from pfield.interfaces.visualization_msgs import MarkerArray  # noqa: E402
from pfield.transport._ros2_convert import from_ros, interface_class, to_ros  # noqa: E402

SEED_SPHERE = {"frame_id": "ball", "type": "Sphere", "group": "Static",
               "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.1}, "orientation": {"w": 1.0}}, "radius": 0.1}


def _ros_class_for(type_name: str) -> type | None:
    try:
        return interface_class(type_name)
    except (ImportError, AttributeError):
        return None


@pytest.mark.parametrize("type_name", sorted(registered_types()))
def test_every_model_round_trips_through_its_rclpy_class(type_name: str) -> None:
    ros_class = _ros_class_for(type_name)
    if ros_class is None:
        pytest.skip(f"{type_name} has no rclpy class in this install")
    model = registered_types()[type_name]()
    message = to_ros(model, ros_class)
    assert isinstance(message, ros_class)
    assert message == ros_class()  # pfield's defaults are ROS's defaults
    assert from_ros(message, type(model)) == model


def test_seed_obstacle_array_matches_a_hand_built_rclpy_message() -> None:
    from geometry_msgs.msg import Point, Quaternion
    from geometry_msgs.msg import Pose as RosPose
    from potential_fields_interfaces.msg import Obstacle as RosObstacle

    model = pfi.ObstacleArray.model_validate({"header": {"frame_id": "world"}, "obstacles": [SEED_SPHERE]})
    expected = RosObstacleArray()
    expected.header.frame_id = "world"
    expected.obstacles = [RosObstacle(frame_id="ball", type="Sphere", group="Static", radius=0.1,
                                      pose=RosPose(position=Point(x=0.4, y=0.0, z=0.1), orientation=Quaternion()))]
    assert to_ros(model, RosObstacleArray) == expected
    back = from_ros(expected, pfi.ObstacleArray)
    assert back.obstacles[0].radius == pytest.approx(0.1, rel=1e-7)  # float32 on the wire
    assert back.obstacles[0].pose.position.x == 0.4 and back.header.frame_id == "world"


def test_plan_path_response_round_trip_keeps_every_value() -> None:
    response = pfi.PlanPath_Response.model_validate({
        "success": True, "error_message": "",
        "end_effector_path": {"header": {"frame_id": "world"},
                              "poses": [{"pose": {"position": {"x": 0.25 * i}}} for i in range(5)]},
        "joint_trajectory": {"joint_names": ["joint1", "joint2"],
                             "points": [{"positions": [0.5, -1.25], "velocities": [0.0, 0.125],
                                         "time_from_start": {"sec": 1, "nanosec": 500}}]},
        "end_effector_velocity_trajectory": [{"twist": {"linear": {"x": 0.05}, "angular": {"z": -0.4}}}],
    })
    message = to_ros(response, RosPlanPath.Response)
    assert [p.pose.position.x for p in message.end_effector_path.poses] == [0.0, 0.25, 0.5, 0.75, 1.0]
    point = message.joint_trajectory.points[0]
    assert isinstance(point.positions, array.array) and point.positions.typecode == "d"
    assert list(point.positions) == [0.5, -1.25]
    assert point.time_from_start == RosDuration(sec=1, nanosec=500)
    assert message.end_effector_velocity_trajectory[0].twist.angular.z == -0.4
    assert from_ros(message, pfi.PlanPath_Response) == response


def test_request_float32_arrays_and_constants() -> None:
    request = pfi.PlanPath_Request(starting_joint_angles=[0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0],
                                   planning_method=pfi.PLANNING_METHOD_WHOLE_BODY, max_iterations=25000)
    message = to_ros(request, RosPlanPath.Request)
    assert message.starting_joint_angles.typecode == "f"
    assert message.starting_joint_angles[5] == pytest.approx(-1.5708, rel=1e-6)
    assert message.planning_method == RosPlanPath.Request.PLANNING_METHOD_WHOLE_BODY
    assert message.max_iterations == 25000


def test_int8_sequences_and_nested_sequences() -> None:
    grid = OccupancyGrid.model_validate({"info": {"width": 2, "height": 2, "resolution": 0.05},
                                         "data": [0, 100, -1, 50]})
    message = to_ros(grid, RosOccupancyGrid)
    assert list(message.data) == [0, 100, -1, 50] and message.info.width == 2
    assert from_ros(message, OccupancyGrid) == grid
    markers = MarkerArray.model_validate({"markers": [{"ns": "path", "id": 3, "type": 4,
                                                       "points": [{"x": 1.0}, {"y": 2.0}],
                                                       "texture": {"data": [1, 2, 255]}}]})
    ros_markers = to_ros(markers, RosMarkerArray)
    assert ros_markers.markers[0].points[1].y == 2.0 and list(ros_markers.markers[0].texture.data) == [1, 2, 255]
    assert from_ros(ros_markers, MarkerArray) == markers


class PoseWithCovariance(RosMessage):
    """Defined here (not registered): exercises a fixed-size array field, float64[36]."""

    pose: Pose = Field(default_factory=Pose)
    covariance: list[Float64] = Field(default_factory=lambda: [0.0] * 36)


def test_fixed_size_arrays() -> None:
    model = PoseWithCovariance(covariance=[float(i) for i in range(36)])
    message = to_ros(model, RosPoseWithCovariance)
    assert isinstance(message.covariance, np.ndarray) and message.covariance[35] == 35.0
    assert from_ros(message, PoseWithCovariance) == model


class NotAnObstacleArray(RosMessage):
    header: Pose = Field(default_factory=Pose)
    extra: Float64 = math.pi


def test_field_mismatch_names_the_fields() -> None:
    with pytest.raises(TypeError, match=r"only in the model \['extra'\], only in ROS \['obstacles'\]"):
        to_ros(NotAnObstacleArray(), RosObstacleArray)
    with pytest.raises(TypeError, match="extra"):
        from_ros(RosObstacleArray(), NotAnObstacleArray)


def test_interface_class_names() -> None:
    assert interface_class("potential_fields_interfaces/srv/PlanPath") is RosPlanPath
    assert interface_class("potential_fields_interfaces/srv/PlanPath_Request") is RosPlanPath.Request
    assert interface_class("potential_fields_interfaces/msg/ObstacleArray") is RosObstacleArray
    for bad in ("ObstacleArray", "potential_fields_interfaces/ObstacleArray", "a/b/c/d", "pkg/foo/Name"):
        with pytest.raises(ValueError, match="not a ROS interface type name"):
            interface_class(bad)
    with pytest.raises(ModuleNotFoundError):
        interface_class("no_such_package/msg/Thing")
