"""Message ↔ core type conversions: round trips, field paths in errors, PlanPath response layout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pfield.errors import InvalidInput
from pfield.geometry import ResourceResolver
from pfield.interfaces import convert, message_from_yaml
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces.convert import obstacle_from_msg, obstacle_to_msg, plan_response, pose_from_msg, pose_to_msg
from pfield.interfaces.potential_fields_interfaces import Obstacle as ObstacleMsg
from pfield.planning import PlanStatus
from pfield.planning.result import PlannedPath
from pfield.spatial import Pose

PACKAGE = Path(__file__).resolve().parents[1] / "data" / "my_robot_description"
RESOLVER = ResourceResolver(package_paths={"my_robot_description": PACKAGE})


def make_mesh(resource: str, sx: float, sy: float, sz: float) -> object:
    from pfield.geometry import Mesh

    return Mesh(resource, sx, sy, sz, resolver=RESOLVER)


@pytest.mark.parametrize("text", [
    "{type: 'Sphere', radius: 0.1}",
    "{type: 'Box', length: 0.15, width: 0.7, height: 0.6}",
    "{type: 'Cylinder', radius: 0.09, height: 0.3}",
    "{type: 'Ellipsoid', semi_x: 0.08, semi_y: 0.05, semi_z: 0.12}",
    "{type: 'Capsule', radius: 0.05, height: 0.2}",
    "{type: 'Mesh', mesh_resource: 'package://my_robot_description/meshes/obstacle.dae', "
    "scale_x: 1.0, scale_y: 2.0, scale_z: 0.5}",
])
def test_obstacle_round_trip(text: str) -> None:
    message = message_from_yaml(ObstacleMsg, text[:-1] + ", frame_id: 'o', group: 'Dynamic', "
                                "pose: {position: {x: 0.5, y: -0.25, z: 0.125}, orientation: {z: 1.0, w: 1.0}}}")
    obstacle = obstacle_from_msg(message, make_mesh)
    assert (obstacle.id, obstacle.group, type(obstacle.shape).__name__) == ("o", "Dynamic", message.type)
    assert obstacle.pose.isclose(Pose((0.5, -0.25, 0.125), (0, 0, np.sqrt(0.5), np.sqrt(0.5))))
    back = obstacle_to_msg(obstacle)
    expected = message.model_copy(update={"pose": pose_to_msg(obstacle.pose)})
    assert back == expected


def test_pose_errors_name_the_path() -> None:
    with pytest.raises(InvalidInput) as info:
        pose_from_msg(gm.Pose(orientation=gm.Quaternion(w=0.0)), "goal")
    assert info.value.field == "goal.orientation"
    pose = pose_from_msg(gm.Pose(orientation=gm.Quaternion(x=0.707, z=0.707, w=0.0)), "goal")
    assert np.linalg.norm(pose.orientation) == pytest.approx(1.0)


def test_plan_response_layout() -> None:
    n, dt = 4, 0.02
    times = np.arange(n) * dt
    positions = np.column_stack([np.linspace(0, 0.3, n), np.zeros(n), np.full(n, 0.2)])
    orientations = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    twists = np.tile([0.05, 0, 0, 0, 0, 0.1], (n, 1))
    joints = np.arange(n * 2, dtype=float).reshape(n, 2)
    path = PlannedPath(False, "stagnation near 'ball'", times, positions, orientations, twists, np.full(n, 0.3),
                       iterations=n - 1, joint_names=("j1", "j2"), joint_positions=joints,
                       joint_velocities=joints * 0.5, status=PlanStatus.STAGNATION)
    response = plan_response(path, "world")
    assert not response.success and response.error_message == "stagnation near 'ball'"
    poses = response.end_effector_path.poses
    assert len(poses) == len(response.end_effector_velocity_trajectory) == n
    assert [p.header.stamp.to_seconds() for p in poses] == pytest.approx(times.tolist())
    assert poses[-1].pose.position.x == pytest.approx(0.3) and poses[2].header.frame_id == "world"
    assert response.end_effector_velocity_trajectory[1].twist.angular.z == pytest.approx(0.1)
    trajectory = response.joint_trajectory
    assert trajectory.joint_names == ["j1", "j2"]
    assert trajectory.points[3].positions == [6.0, 7.0] and trajectory.points[3].velocities == [3.0, 3.5]
    assert trajectory.points[3].time_from_start.to_seconds() == pytest.approx(0.06)
    task_only = PlannedPath(True, "", times, positions, orientations, twists, np.full(n, np.inf))
    assert plan_response(task_only, "world").joint_trajectory.points == []


@pytest.mark.parametrize("values", [(0.3, -0.1, 0.35), (1e6, -1e6, 0.0), (5e-324, -0.0, 2.5)])
def test_points_within_range_come_back_exactly_and_read_only(values: tuple[float, float, float]) -> None:
    point = convert.point_from_msg(gm.Point(x=values[0], y=values[1], z=values[2]))
    assert point.tolist() == list(values) and not point.flags.writeable


@pytest.mark.parametrize(("values", "field"), [((1e6 + 1, 0.0, 0.0), "p"), ((float("nan"), 0.0, 0.0), "p"),
                                               ((0.0, float("inf"), 0.0), "p")])
def test_points_out_of_range_or_not_finite_are_refused_naming_the_field(values: tuple[float, ...], field: str) -> None:
    with pytest.raises(InvalidInput) as error:
        convert.point_from_msg(gm.Point(x=values[0], y=values[1], z=values[2]), field)
    assert error.value.field == field


@pytest.mark.parametrize("q", [(0.0, 0.0, 0.0, 1e-10), (1e7, 0.0, 0.0, 0.0), (0.0, float("nan"), 0.0, 1.0)])
def test_quaternions_outside_the_norm_range_are_refused(q: tuple[float, ...]) -> None:
    with pytest.raises(InvalidInput) as error:
        convert.quaternion_from_msg(gm.Quaternion(x=q[0], y=q[1], z=q[2], w=q[3]), "q")
    assert error.value.field == "q"


def test_a_stamped_twist_equals_the_validated_message() -> None:
    from pfield.spatial import Twist

    message = convert.twist_stamped(Twist((0.1, -0.2, 0.3), (0.0, 0.5, -1e-9)), "world", 12.25)
    assert message == gm.TwistStamped.model_validate_json(message.model_dump_json())
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (12, 250_000_000)
    assert message.twist.angular.z == -1e-9 and message.header.frame_id == "world"
