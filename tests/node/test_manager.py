"""``/pfield_manager`` state handling: obstacles, expiry, parameters, markers and request validation."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import message_from_data, message_from_yaml
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.geometry_msgs import PoseStamped
from pfield.interfaces.std_srvs import Trigger_Request
from pfield.interfaces.visualization_msgs import Marker, MarkerArray
from pfield.node._base import Bus
from pfield.node._planning import make_resolver
from pfield.node.manager import MAX_ITERATIONS_CAP, ManagerNode

PACKAGE = Path(__file__).resolve().parents[1] / "data" / "my_robot_description"
POSE = "pose: {position: {x: 0.4, y: 0.0, z: 0.1}, orientation: {w: 1.0}}"
SEED = [
    f"{{frame_id: 'ball', type: 'Sphere', group: 'Static', {POSE}, radius: 0.1}}",
    f"{{frame_id: 'table', type: 'Box', group: 'Static', {POSE}, length: 0.15, width: 0.7, height: 0.6}}",
    f"{{frame_id: 'pitcher', type: 'Cylinder', group: 'Static', {POSE}, radius: 0.09, height: 0.3}}",
    f"{{frame_id: 'ell', type: 'Ellipsoid', group: 'Static', {POSE}, semi_x: 0.08, semi_y: 0.05, semi_z: 0.12}}",
    f"{{frame_id: 'cap', type: 'Capsule', group: 'Dynamic', {POSE}, radius: 0.05, height: 0.2}}",
    f"{{frame_id: 'mesh', type: 'Mesh', group: 'Static', {POSE}, "
    "mesh_resource: 'package://my_robot_description/meshes/obstacle.dae', scale_x: 1, scale_y: 1, scale_z: 1}",
]


def obstacles(*items: str, frame: str = "world") -> pfi.ObstacleArray:
    return message_from_yaml(pfi.ObstacleArray, f"{{header: {{frame_id: '{frame}'}}, obstacles: [{', '.join(items)}]}}")


@pytest.fixture(scope="module")
def robot() -> Any:
    from pfield.robot import RobotModel

    return RobotModel.builtin("xarm7")


@pytest.fixture
def node(robot: Any) -> ManagerNode:
    manager = ManagerNode(Bus(), robot, resolver=make_resolver({"my_robot_description": PACKAGE}, []))
    manager.on_obstacles(obstacles(*SEED))
    return manager


def ids(node: ManagerNode) -> list[str]:
    return [o.id for o in node.obstacles()]


def test_seed_obstacles_are_held_and_replaced_by_id(node: ManagerNode) -> None:
    assert ids(node) == ["ball", "table", "pitcher", "ell", "cap", "mesh"]
    node.on_obstacles(obstacles(f"{{frame_id: 'ball', type: 'Sphere', group: 'Static', {POSE}, radius: 0.2}}"))
    assert ids(node) == ["ball", "table", "pitcher", "ell", "cap", "mesh"]
    assert node.obstacles()[0].shape.radius == pytest.approx(0.2)
    markers = node.bus.latest("/pfield/markers")
    assert isinstance(markers, MarkerArray) and markers.markers[0].action == Marker.DELETEALL
    by_ns = [m.ns for m in markers.markers]
    assert by_ns.count("obstacles") == 6 and by_ns.count("influence") == 6
    ball = next(m for m in markers.markers if m.ns == "influence" and m.id == 0)
    assert ball.scale.x == pytest.approx(2 * (0.2 + node.config.influence_distance))


@pytest.mark.parametrize(("item", "field"), [
    (f"{{frame_id: 'x', type: 'Cone', group: 'Static', {POSE}, radius: 0.1}}", "obstacles[1].type"),
    (f"{{frame_id: 'x', type: 'Sphere', group: 'Flying', {POSE}, radius: 0.1}}", "obstacles[1].group"),
    (f"{{frame_id: 'x', type: 'Sphere', group: 'Static', {POSE}, radius: -0.1}}", "obstacles[1].radius"),
    (f"{{frame_id: 'x', type: 'Box', group: 'Static', {POSE}, length: 0.1, width: 0.0, height: 0.1}}",
     "obstacles[1].width"),
    (f"{{frame_id: 'x', type: 'Ellipsoid', group: 'Static', {POSE}, semi_x: .nan, semi_y: 1, semi_z: 1}}",
     "obstacles[1].semi_x"),
    ("{frame_id: 'x', type: 'Sphere', group: 'Static', pose: {orientation: {w: 0.0}}, radius: 0.1}",
     "obstacles[1].pose.orientation"),
    ("{frame_id: 'x', type: 'Sphere', group: 'Static', pose: {position: {x: .inf}}, radius: 0.1}",
     "obstacles[1].pose.position"),
    ("{frame_id: '', type: 'Sphere', group: 'Static', radius: 0.1}", "obstacles[1].frame_id"),
    ("{frame_id: 'new', type: 'Sphere', group: 'Static', radius: 0.1}", "obstacles[1].frame_id"),
    ("{frame_id: 'x', type: 'Mesh', group: 'Static', mesh_resource: 'package://other/meshes/obstacle.dae', "
     "scale_x: 1, scale_y: 1, scale_z: 1}", "obstacles[1].mesh_resource"),
    ("{frame_id: 'x', type: 'Mesh', group: 'Static', mesh_resource: 'file:///etc/passwd', "
     "scale_x: 1, scale_y: 1, scale_z: 1}", "obstacles[1].mesh_resource"),
    ("{frame_id: 'x', type: 'Mesh', group: 'Static', mesh_resource: 'package://my_robot_description/package.xml', "
     "scale_x: 1, scale_y: 1, scale_z: 1}", "obstacles[1].mesh_resource"),
    ("{frame_id: 'x', type: 'Mesh', group: 'Static', mesh_resource: "
     "'package://my_robot_description/meshes/obstacle.dae', scale_x: 0, scale_y: 1, scale_z: 1}",
     "obstacles[1].scale_x"),
])
def test_one_bad_obstacle_rejects_the_whole_message(node: ManagerNode, item: str, field: str) -> None:
    before = node.bus.latest("/pfield/markers")
    good = f"{{frame_id: 'new', type: 'Sphere', group: 'Static', {POSE}, radius: 0.1}}"
    with pytest.raises(InvalidInput) as info:
        node.on_obstacles(obstacles(good, item))
    assert info.value.field == field
    assert ids(node) == ["ball", "table", "pitcher", "ell", "cap", "mesh"]
    assert node.bus.latest("/pfield/markers") is before


def test_other_frames_are_rejected(node: ManagerNode) -> None:
    with pytest.raises(UnknownFrame) as info:
        node.on_obstacles(obstacles(f"{{frame_id: 'n', type: 'Sphere', group: 'Static', {POSE}, radius: 1}}",
                                    frame="map"))
    assert info.value.field == "header.frame_id" and "n" not in ids(node)
    with pytest.raises(UnknownFrame):
        node.on_goal(message_from_yaml(PoseStamped, "{header: {frame_id: 'base_link'}}"))
    assert node.goal is None


def test_remove_is_all_or_nothing_and_clear_empties(node: ManagerNode) -> None:
    answer = node.remove_obstacles(pfi.RemoveObstacles_Request(frame_ids=["ball", "nope"]))
    assert not answer.success and "nope" in answer.message and "ball" in answer.remaining
    answer = node.remove_obstacles(pfi.RemoveObstacles_Request(frame_ids=["ball", "table"]))
    assert answer.success and answer.remaining == ["pitcher", "ell", "cap", "mesh"]
    assert node.clear_obstacles(Trigger_Request()).success and ids(node) == []


def test_dynamic_obstacles_expire_without_updates(node: ManagerNode) -> None:
    node.set_parameters({"dynamic_obstacle_timeout": 0.5})
    held = {o.id: o for o in node.obstacles()}
    assert held["cap"].group == "Dynamic"
    node.tick(time.monotonic() + 0.1)
    assert "cap" in ids(node)
    node.tick(time.monotonic() + 1.0)
    assert ids(node) == ["ball", "table", "pitcher", "ell", "mesh"]


def test_parameters_are_validated_together(node: ManagerNode) -> None:
    before = node.get_parameters()
    assert before["attractive_gain"] == 3.0 and before["fixed_frame"] == "world"
    for bad in ({"attractive_gain": -1.0}, {"attractive_gain": 2.0, "nope": 1}, {"safety_distance": 0.5},
                {"dynamic_obstacle_timeout": float("nan")}, {"fixed_frame": ""}, {"repulsive_gain": "high"}):
        with pytest.raises(InvalidInput):
            node.set_parameters(bad)
        assert node.get_parameters() == before
    after = node.set_parameters({"attractive_gain": 2.0, "influence_distance": 0.2, "fixed_frame": "map"})
    assert (after["attractive_gain"], after["influence_distance"], after["fixed_frame"]) == (2.0, 0.2, "map")


WHOLE_BODY = "{goal: {position: {x: 0.5}}, starting_joint_angles: [0, 0, 0, 0, 0, -1.5708, 0], delta_time: 0.02, " \
             "goal_tolerance: 0.01, planning_method: 'whole_body'}"


@pytest.mark.parametrize(("change", "field"), [
    ("planning_method: 'rrt'", "planning_method"),
    ("starting_joint_angles: [0.0, 0.0]", "starting_joint_angles"),
    ("starting_joint_angles: [0, 0, 0, 0, 0, 0, 9]", "starting_joint_angles[6]"),
    (f"max_iterations: {MAX_ITERATIONS_CAP + 1}", "max_iterations"),
    ("delta_time: -0.02", "delta_time"),
    ("goal_tolerance: -1.0", "goal_tolerance"),
    ("goal: {orientation: {w: 0.0}}", "goal.orientation"),
])
def test_plan_requests_are_validated_before_anything_changes(node: ManagerNode, change: str, field: str) -> None:
    request = message_from_data(pfi.PlanPath_Request, yaml.safe_load(WHOLE_BODY) | yaml.safe_load("{" + change + "}"))
    with pytest.raises(InvalidInput) as info:
        node.plan_path(request)
    assert info.value.field.startswith(field)
    assert node.goal is None and node.bus.latest("/pfield/planned_path") is None


def test_plan_fields_left_at_zero_take_the_documented_defaults(node: ManagerNode) -> None:
    """Issue 33: a plan_path request without delta_time (ROS fills 0) was refused; 0 means the default, as
    max_iterations 0 does."""
    from pfield.node.manager import DEFAULT_DELTA_TIME, DEFAULT_GOAL_TOLERANCE

    request = message_from_data(pfi.PlanPath_Request, yaml.safe_load(
        "{start: {position: {x: 0.3, y: 0.1, z: 0.9}, orientation: {w: 1.0}}, "
        "goal: {position: {x: 0.35, y: 0.1, z: 0.9}, orientation: {w: 1.0}}, max_iterations: 2000}"))
    assert request.delta_time == 0.0 and request.goal_tolerance == 0.0
    inputs = node._plan_inputs(request, 0)
    assert (inputs.delta_time, inputs.goal_tolerance) == (DEFAULT_DELTA_TIME, DEFAULT_GOAL_TOLERANCE)
    answer = node.plan_path(request)
    assert answer.success, answer.error_message


def test_the_work_cap_names_the_max_iterations_that_passes(node: ManagerNode) -> None:
    node.on_obstacles(message_from_data(pfi.ObstacleArray, {"obstacles": [
        {"frame_id": f"s{i}", "type": "Sphere", "group": "Static", "radius": 0.01,
         "pose": {"position": {"x": 5.0 + i, "y": 0.0, "z": 0.0}, "orientation": {"w": 1.0}}} for i in range(2001)]}))
    request = message_from_data(pfi.PlanPath_Request, yaml.safe_load(WHOLE_BODY) | {"max_iterations": 30000})
    largest = 50_000_000 // len(node.state.obstacles)  # MAX_PLAN_WORK over the obstacles held
    with pytest.raises(InvalidInput, match=rf"max_iterations <= {largest} passes") as info:
        node.plan_path(request)
    assert info.value.field == "max_iterations"


def test_autonomy_vector_needs_a_goal_and_the_fixed_frame(node: ManagerNode) -> None:
    request = message_from_yaml(pfi.ComputeAutonomyVector_Request, "{query_pose: {header: {frame_id: 'world'}}}")
    with pytest.raises(InvalidInput) as info:
        node.compute_autonomy_vector(request)
    assert info.value.field == "goal"
    request = message_from_yaml(pfi.ComputeAutonomyVector_Request, "{query_pose: {header: {frame_id: 'odom'}}}")
    with pytest.raises(UnknownFrame):
        node.compute_autonomy_vector(request)


def test_path_marker_is_thinned_but_keeps_both_ends() -> None:
    from pfield.node._markers import MAX_PATH_POINTS, state_markers

    positions = np.column_stack([np.arange(30001) * 1e-4, np.zeros(30001), np.zeros(30001)])
    markers = state_markers("world", None, [], 0.1, positions).markers
    (strip,) = [m for m in markers if m.ns == "path"]
    assert len(strip.points) <= MAX_PATH_POINTS + 1
    assert (strip.points[0].x, strip.points[-1].x) == (0.0, pytest.approx(3.0))


def test_meshes_resolve_from_mesh_roots_and_the_ament_index(robot: Any, tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    import shutil

    source = PACKAGE / "meshes" / "obstacle.dae"
    share = tmp_path / "prefix" / "share" / "ament_only_description" / "meshes"
    share.mkdir(parents=True)
    shutil.copy(source, share / "obstacle.dae")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "prefix"))
    manager = ManagerNode(Bus(), robot, resolver=make_resolver({}, [source.parent]))
    manager.on_obstacles(obstacles(
        f"{{frame_id: 'a', type: 'Mesh', group: 'Static', {POSE}, mesh_resource: 'file://{source}', "
        "scale_x: 1, scale_y: 1, scale_z: 1}",
        f"{{frame_id: 'b', type: 'Mesh', group: 'Static', {POSE}, mesh_resource: "
        "'package://ament_only_description/meshes/obstacle.dae', scale_x: 2, scale_y: 2, scale_z: 2}"))
    assert ids(manager) == ["a", "b"]
    outside = ManagerNode(Bus(), robot, resolver=make_resolver({}, [tmp_path / "elsewhere"]))
    with pytest.raises(InvalidInput) as info:
        outside.on_obstacles(obstacles(f"{{frame_id: 'a', type: 'Mesh', group: 'Static', {POSE}, "
                                       f"mesh_resource: 'file://{source}', scale_x: 1, scale_y: 1, scale_z: 1}}"))
    assert info.value.field == "obstacles[0].mesh_resource"


def test_plan_publishes_path_markers_goal_and_csv(robot: Any, tmp_path: Path) -> None:
    manager = ManagerNode(Bus(), robot, csv_dir=tmp_path)
    manager.on_obstacles(obstacles(SEED[0]))
    request = message_from_yaml(pfi.PlanPath_Request, "{start: {position: {x: 0.227, z: 0.294}}, "
                                "goal: {position: {x: 0.3, y: 0.2, z: 0.35}}, delta_time: 0.02, goal_tolerance: 0.01}")
    response = manager.plan_path(request)
    assert response.success, response.error_message
    assert manager.goal is not None and manager.goal.position.tolist() == [0.3, 0.2, 0.35]
    published = manager.bus.latest("/pfield/planned_path")
    assert published == response.end_effector_path
    markers = manager.bus.latest("/pfield/markers")
    assert isinstance(markers, MarkerArray)
    (strip,) = [m for m in markers.markers if m.ns == "path"]
    assert strip.points[-1] == published.poses[-1].pose.position
    (saved,) = list(tmp_path.glob("plan_*_task_space.csv"))
    assert len(saved.read_text().splitlines()) == len(published.poses) + 1
    twist = manager.compute_autonomy_vector(message_from_yaml(
        pfi.ComputeAutonomyVector_Request, "{query_pose: {pose: {position: {x: 0.3, y: 0.0, z: 0.35}}}}"))
    assert twist.autonomy_vector.twist.linear.y > 0.0  # toward the goal at y = 0.2


def test_task_space_plan_with_joint_angles_carries_a_joint_trajectory(robot: Any) -> None:
    manager = ManagerNode(Bus(), robot)
    request = message_from_yaml(pfi.PlanPath_Request, "{start: {position: {x: 0.227, y: 0.0, z: 0.294}, "
                                "orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}}, goal: {position: {x: 0.3, y: 0.1, "
                                "z: 0.35}, orientation: {x: 0.707, y: 0.0, z: 0.707, w: 0.0}}, delta_time: 0.02, "
                                "goal_tolerance: 0.01, starting_joint_angles: [0, 0, 0, 0, 0, -1.5708, 0]}")
    response = manager.plan_path(request)
    assert response.success, response.error_message
    trajectory = response.joint_trajectory
    assert trajectory.joint_names == list(robot.joint_names)
    assert len(trajectory.points) == len(response.end_effector_path.poses)
    last = robot.forward_kinematics(trajectory.points[-1].positions).position
    end = response.end_effector_path.poses[-1].pose.position
    assert np.allclose(last, (end.x, end.y, end.z), atol=1e-3)


def test_whole_body_autonomy_vector_at_the_seed_joints(robot: Any) -> None:
    manager = ManagerNode(Bus(), robot)
    manager.on_goal(message_from_yaml(PoseStamped, "{pose: {position: {x: 0.5, y: 0.2, z: 0.4}}}"))
    request = message_from_yaml(pfi.ComputeAutonomyVector_Request, "{joint_angles: [0, 0, 0, 0, 0, -1.5708, 0], "
                                "prev_joint_velocities: [0, 0, 0, 0, 0, 0, 0], delta_time: 0.02, "
                                "planning_method: 'whole_body'}")
    linear = manager.compute_autonomy_vector(request).autonomy_vector.twist.linear
    start = robot.forward_kinematics([0, 0, 0, 0, 0, -1.5708, 0]).position
    assert np.dot((linear.x, linear.y, linear.z), np.subtract((0.5, 0.2, 0.4), start)) > 0.0
    with pytest.raises(InvalidInput) as info:
        manager.compute_autonomy_vector(request.model_copy(update={"prev_joint_velocities": [0.0]}))
    assert info.value.field == "prev_joint_velocities"


def test_whole_body_query_pose_far_from_fk_is_reported_and_the_joints_win(
        robot: Any, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    import pfield.shared_control.autonomy

    monkeypatch.setattr(pfield.shared_control.autonomy, "_last_mismatch_warning", [-np.inf, 0])  # none in period
    manager = ManagerNode(Bus(), robot)
    manager.on_goal(message_from_yaml(PoseStamped, "{pose: {position: {x: 0.5, y: 0.2, z: 0.4}}}"))
    base = "joint_angles: [0, 0, 0, 0, 0, -1.5708, 0], delta_time: 0.02, planning_method: 'whole_body'"
    without = message_from_yaml(pfi.ComputeAutonomyVector_Request, f"{{{base}}}")
    with_far_pose = message_from_yaml(pfi.ComputeAutonomyVector_Request,
                                      f"{{{base}, query_pose: {{pose: {{position: {{x: 0.9, y: -0.4, z: 1.0}}}}}}}}")
    with caplog.at_level("WARNING"):
        silent = manager.compute_autonomy_vector(without).autonomy_vector.twist
        assert not [r for r in caplog.records if "disagrees" in r.getMessage()]
        reported = manager.compute_autonomy_vector(with_far_pose).autonomy_vector.twist
    assert [r for r in caplog.records if "disagrees" in r.getMessage()]
    assert reported == silent


def test_query_pose_topic_answers_on_autonomy_vector(robot: Any) -> None:
    manager = ManagerNode(Bus(), robot)
    manager.on_goal(message_from_yaml(PoseStamped, "{pose: {position: {x: 0.5, y: 0.2, z: 0.4}}}"))
    manager.on_query_pose(message_from_yaml(PoseStamped, "{header: {frame_id: 'world'}, "
                                                         "pose: {position: {x: 0.5, y: 0.1, z: 0.4}}}"))
    answer = manager.bus.latest("/pfield/autonomy_vector")
    assert answer is not None and answer.header.frame_id == "world"  # type: ignore[attr-defined]
    linear = answer.twist.linear  # type: ignore[attr-defined]
    assert linear.y > 0.0 and abs(linear.x) < 1e-9 and abs(linear.z) < 1e-9
