"""Bounded, all-or-nothing node state: each request is validated completely (ranges, UTF-8, overflow-free
quaternions, representable durations) before the state snapshot changes; caps on obstacles, mesh files and
search work; one parameter table per node (get/set/describe); one frames service."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pfield.costmap import CostmapParams, Footprint, OccupancyMap, build_costmap, find_valid_pose
from pfield.costmap.find_valid_pose import MAX_KERNEL_CELLS
from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import message_from_data
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.interfaces.nav_msgs import Odometry
from pfield.node._base import Bus
from pfield.node._planning import make_resolver
from pfield.node.base_controller import BaseControllerNode
from pfield.node.costmap_server import CostmapServer
from pfield.node.manager import MAX_OBSTACLES, ManagerNode
from pfield.planning.cancel import CancelToken
from pfield.spatial import Pose, normalize_quaternion

PACKAGE = Path(__file__).resolve().parents[1] / "data" / "my_robot_description"
MESH = "package://my_robot_description/meshes/obstacle.dae"
GOAL = {"position": {"x": 0.5, "y": 0.2, "z": 0.4}, "orientation": {"w": 1.0}}


def sphere(key: str, x: float = 0.4) -> dict[str, Any]:
    return {"frame_id": key, "type": "Sphere", "group": "Static", "radius": 0.05,
            "pose": {"position": {"x": x, "y": 0.0, "z": 0.1}, "orientation": {"w": 1.0}}}


def array(*items: dict[str, Any]) -> pfi.ObstacleArray:
    return message_from_data(pfi.ObstacleArray, {"header": {"frame_id": "world"}, "obstacles": list(items)})


def plan_request(**fields: Any) -> pfi.PlanPath_Request:
    body = {"start": {"position": {"x": 0.3, "y": 0.0, "z": 0.3}, "orientation": {"w": 1.0}}, "goal": GOAL,
            "delta_time": 0.02, "goal_tolerance": 0.01, "max_iterations": 200, "planning_method": "task_space"}
    return message_from_data(pfi.PlanPath_Request, body | fields)


@pytest.fixture
def node() -> ManagerNode:
    manager = ManagerNode(Bus(), robot=None, resolver=make_resolver({"my_robot_description": PACKAGE}, []))
    manager.on_obstacles(array(sphere("ball")))
    manager.on_goal(message_from_data(gm.PoseStamped, {"pose": {"position": {"x": 0.1, "y": 0.1, "z": 0.5}}}))
    return manager


def snapshot(node: Any) -> tuple[Any, ...]:
    markers = node.bus.latest("/pfield/markers")
    return node.state.version, node.get_parameters(), markers.model_dump_json() if markers else None


# ---- plan_path: the whole request before the goal changes ------------------------------------------------
@pytest.mark.parametrize(("fields", "field"), [
    ({"delta_time": 1e-30}, "delta_time"),
    ({"delta_time": float(2**31)}, "delta_time"),
    ({"delta_time": math.inf}, "delta_time"),
    ({"delta_time": 0.05, "max_iterations": 200_000}, "max_iterations"),  # fine alone; with the cap below
    ({"start": {"orientation": {"w": 1e308}}}, "start.orientation"),
    ({"goal": {"orientation": {"x": 1e308, "w": 1e308}}}, "goal.orientation"),
    ({"goal": {"position": {"x": 1e300}}}, "goal.position"),
])
def test_a_refused_plan_leaves_goal_and_markers_as_they_were(node: ManagerNode, fields: dict[str, Any],
                                                             field: str) -> None:
    if field == "max_iterations":  # 200 000 iterations among 1 501 obstacles exceed the work cap
        node.on_obstacles(array(*(sphere(f"s{i}", 2.0 + i) for i in range(1500))))
    goal, before = node.goal, snapshot(node)
    with pytest.raises(InvalidInput) as error:
        node.plan_path(plan_request(**fields))
    assert error.value.field == field
    assert node.goal is goal and snapshot(node) == before


def test_a_cancelled_plan_changes_nothing(node: ManagerNode) -> None:
    token = CancelToken()
    token.cancel()
    goal, before = node.goal, snapshot(node)
    response = node.plan_path(plan_request(), cancel=token)
    assert response.success is False and "cancelled" in response.error_message
    assert node.goal is goal and snapshot(node) == before


def test_a_completed_plan_sets_goal_and_path_in_one_new_state(node: ManagerNode) -> None:
    version = node.state.version
    response = node.plan_path(plan_request(max_iterations=50))
    assert node.state.version == version + 1
    assert node.goal is not None and node.goal.isclose(Pose((0.5, 0.2, 0.4)))
    assert len(node.state.path_positions) == len(response.end_effector_path.poses)
    assert [m.ns for m in node.markers().markers].count("path") == 1


def test_the_field_and_markers_are_memoised_on_the_version(node: ManagerNode) -> None:
    field, markers = node._current_field(), node.markers()
    assert node._current_field() is field and node.markers() is markers
    node.on_obstacles(array(sphere("other", 0.2)))
    assert node._current_field() is not field and node.markers() is not markers
    field, markers = node._current_field(), node.markers()
    node.plan_path(plan_request(goal={"position": {"x": 0.1, "y": 0.1, "z": 0.5}}, max_iterations=20))
    assert node.goal.isclose(Pose((0.1, 0.1, 0.5)))  # a new goal object: a new field
    assert node._current_field() is not field and node.markers() is not markers
    field = node._current_field()
    node.remove_obstacles(pfi.RemoveObstacles_Request(frame_ids=[]))  # no change, no new state
    assert node._current_field() is field


# ---- strings: valid UTF-8 everywhere ---------------------------------------------------------------------
@pytest.mark.parametrize("values", [{"fixed_frame": "\ud800"},
                                    {"static_transforms": {"\ud800": {"translation": [0, 0, 0]}}}])
def test_a_lone_surrogate_parameter_is_refused(node: ManagerNode, values: dict[str, Any]) -> None:
    before = snapshot(node)
    with pytest.raises(InvalidInput, match="UTF-8"):
        node.set_parameters(values)
    assert snapshot(node) == before


@pytest.mark.parametrize(("model", "data", "field"), [
    (pfi.ObstacleArray, {"obstacles": [sphere("\ud800")]}, "obstacles[0].frame_id"),
    (gm.PoseStamped, {"header": {"frame_id": "\udfff"}}, "header.frame_id"),
    (pfi.RemoveObstacles_Request, {"frame_ids": ["ok", "\ud800"]}, "frame_ids[1]"),
])
def test_every_message_string_must_be_utf8(model: Any, data: dict[str, Any], field: str) -> None:
    with pytest.raises(InvalidInput, match="UTF-8") as error:
        message_from_data(model, data)
    assert error.value.field == field


def test_float32_fields_refuse_finite_values_beyond_float32() -> None:
    with pytest.raises(InvalidInput) as error:
        message_from_data(pfi.FindValidPose_Request, {"dist_tolerance": 1e308})
    assert error.value.field == "dist_tolerance"
    assert message_from_data(pfi.FindValidPose_Request, {"dist_tolerance": 3.0e38}).dist_tolerance == 3.0e38


def test_quaternion_normalisation_scales_before_squaring() -> None:
    assert normalize_quaternion([0.0, 0.0, 1e308, 1e308]) == pytest.approx([0, 0, math.sqrt(0.5), math.sqrt(0.5)])


# ---- caps ------------------------------------------------------------------------------------------------
def test_obstacle_count_is_capped_and_a_refused_message_changes_nothing(node: ManagerNode) -> None:
    node.on_obstacles(array(*(sphere(f"s{i}", 2.0 + i) for i in range(MAX_OBSTACLES - 1))))
    assert len(node.obstacles()) == MAX_OBSTACLES
    before = snapshot(node)
    with pytest.raises(InvalidInput, match=str(MAX_OBSTACLES)) as error:
        node.on_obstacles(array(sphere("one_more")))
    assert error.value.field == "obstacles" and snapshot(node) == before
    node.on_obstacles(array(sphere("s0", 0.3)))  # replacing by id stays possible at the cap
    assert len(node.obstacles()) == MAX_OBSTACLES


def test_mesh_files_over_the_size_cap_are_refused_before_loading(node: ManagerNode) -> None:
    mesh = {"frame_id": "m", "type": "Mesh", "group": "Static", "mesh_resource": MESH,
            "scale_x": 1.0, "scale_y": 1.0, "scale_z": 1.0}
    node.set_parameters({"max_mesh_file_size": 1000})
    before = snapshot(node)
    with pytest.raises(InvalidInput, match="max_mesh_file_size") as error:
        node.on_obstacles(array(sphere("extra"), mesh))
    assert error.value.field == "obstacles[1].mesh_resource" and snapshot(node) == before
    node.set_parameters({"max_mesh_file_size": 50_000_000})
    node.on_obstacles(array(mesh))
    assert [o.id for o in node.obstacles()] == ["ball", "m"]


HUGE = 10**400
"""An integer JSON or YAML can carry and a double cannot: ``float(HUGE)`` raises OverflowError."""


# ---- parameter tables ------------------------------------------------------------------------------------
@pytest.mark.parametrize("make", [lambda: ManagerNode(Bus(), robot=None), lambda: CostmapServer(Bus()),
                                  lambda: BaseControllerNode(Bus())], ids=["manager", "costmap", "base"])
def test_describe_matches_the_parameters_and_their_defaults(make: Any) -> None:
    node = make()
    rows, values = node.describe_parameters(), node.get_parameters()
    assert list(rows) == list(values)
    for name, row in rows.items():
        assert set(row) == {"type", "description", "range", "unit", "default", "read_only", "positive"}
        assert row["description"], name
        assert row["default"] == values[name] or name == "static_transforms"
        if row["type"] in ("double", "integer") and row["range"] is not None:
            low, high = row["range"]
            assert low <= values[name] <= high, name


@pytest.mark.parametrize(("make", "values", "field"), [
    (lambda: CostmapServer(Bus()), {"angle_increment": 1e-5}, "angle_increment"),
    (lambda: CostmapServer(Bus()), {"local_window_size": 300.0}, "local_window_size"),
    (lambda: CostmapServer(Bus()), {"resolution": 0.005, "local_window_size": 40.0}, "local_window_size"),
    (lambda: CostmapServer(Bus()), {"footprint": [[[0.1, 0.2]], [[0.3, 0.1]], [[0.1, 0.1]]]}, "footprint"),
    (lambda: CostmapServer(Bus()), {"footprint": [[1, [2]], [3, 4], [5, 6]]}, "footprint"),
    (lambda: ManagerNode(Bus(), robot=None), {"max_linear_velocity": 1e6}, "max_linear_velocity"),
    (lambda: ManagerNode(Bus(), robot=None), {"nope": 1.0}, "nope"),
    (lambda: BaseControllerNode(Bus()), {"drive": "walking"}, "drive"),
    (lambda: BaseControllerNode(Bus()), {"teleop_timeout": 1e9}, "teleop_timeout"),
    # absurd sizes (issue 31 F3): a 400-digit integer was a 500 OverflowError, a 100 kB frame name was taken
    (lambda: ManagerNode(Bus(), robot=None), {"influence_distance": HUGE}, "influence_distance"),
    (lambda: ManagerNode(Bus(), robot=None), {"influence_distance": -HUGE}, "influence_distance"),
    (lambda: ManagerNode(Bus(), robot=None), {"max_mesh_file_size": HUGE}, "max_mesh_file_size"),
    (lambda: ManagerNode(Bus(), robot=None), {"max_mesh_file_size": math.inf}, "max_mesh_file_size"),
    (lambda: ManagerNode(Bus(), robot=None), {"fixed_frame": "f" * 100_000}, "fixed_frame"),
    (lambda: ManagerNode(Bus(), robot=None), {"static_transforms": {"camera": {"translation": [HUGE, 0, 0]}}},
     "static_transforms.camera.translation"),
    (lambda: ManagerNode(Bus(), robot=None), {"static_transforms": {"camera": {"translation": [1e300, 0, 0]}}},
     "static_transforms.camera.translation"),
    (lambda: ManagerNode(Bus(), robot=None), {"static_transforms": {"c" * 100_000: {"translation": [0, 0, 0]}}},
     "static_transforms key"),
    (lambda: CostmapServer(Bus()), {"lethal_cost_threshold": math.inf}, "lethal_cost_threshold"),
    (lambda: CostmapServer(Bus()), {"inflation_radius": HUGE}, "inflation_radius"),
    (lambda: CostmapServer(Bus()), {"footprint": f"[[{HUGE}, 0], [1, 1], [0, 1]]"}, "footprint"),
    (lambda: CostmapServer(Bus()), {"footprint": [[HUGE, 0], [1, 1], [0, 1]]}, "footprint"),
    (lambda: CostmapServer(Bus()), {"global_frame": "g" * 100_000}, "global_frame"),
    (lambda: BaseControllerNode(Bus()), {"kr_slope": HUGE}, "kr_slope"),
    (lambda: BaseControllerNode(Bus()), {"odom_frame": "o" * 100_000}, "odom_frame"),
])
def test_out_of_range_parameters_are_refused_and_change_nothing(make: Any, values: dict[str, Any],
                                                                 field: str) -> None:
    node = make()
    before = node.get_parameters()
    with pytest.raises(InvalidInput) as error:
        node.set_parameters(values)
    assert error.value.field == field and node.get_parameters() == before


# ---- costmap: bounded search -----------------------------------------------------------------------------
def costmap_node() -> CostmapServer:
    data = np.zeros((40, 40), dtype=np.int8)  # 2 m × 2 m at 5 cm
    data[20, 20] = 100
    node = CostmapServer(Bus(), CostmapParams(robot_radius=0.2, inflation_radius=0.3))
    node.set_map(OccupancyMap(data, 0.05, (0.0, 0.0, 0.0)))
    return node


@pytest.mark.parametrize(("fields", "field"), [({"safety_dist": 100.0}, "safety_dist"),
                                               ({"dist_tolerance": 1e30}, "dist_tolerance"),
                                               ({"angle_tolerance": 100.0}, "angle_tolerance")])
def test_find_valid_pose_fields_are_bounded_by_the_map(fields: dict[str, Any], field: str) -> None:
    node = costmap_node()
    request = message_from_data(pfi.FindValidPose_Request, {"pose": {"pose": {"position": {"x": 0.5, "y": 0.5}}},
                                                            "costmap": 2} | fields)
    with pytest.raises(InvalidInput) as error:
        node.on_find_valid_pose(request)
    assert error.value.field == field


def test_find_valid_pose_caps_its_work_before_building_kernels() -> None:
    costmap = build_costmap(OccupancyMap(np.zeros((40, 40), dtype=np.int8), 0.05, (0.0, 0.0, 0.0)), CostmapParams())
    with pytest.raises(InvalidInput, match=str(MAX_KERNEL_CELLS)) as error:
        find_valid_pose(costmap, Footprint.from_radius(0.2), Pose.planar(1.0, 1.0, 0.0), safety_dist=20.0,
                        angle_tolerance=math.pi, angle_increment=math.radians(0.1))
    assert error.value.field == "safety_dist"
    with pytest.raises(InvalidInput) as error:
        find_valid_pose(costmap, Footprint.from_radius(0.2), Pose.planar(1.0, 1.0, 0.0), safety_dist=100.0)
    assert error.value.field == "safety_dist"
    # a huge finite tolerance is clamped by the map, never squared into an overflow
    result = find_valid_pose(costmap, Footprint.from_radius(0.2), Pose.planar(1.0, 1.0, 0.0), dist_tolerance=1e308)
    assert result.state == 0


# ---- frames: one service for the three nodes -------------------------------------------------------------
def test_each_node_resolves_frames_through_the_static_transform_table() -> None:
    costmap = CostmapServer(Bus(), frame_transforms={"odom": (1.0, 0.0, 0.0)})
    assert costmap.frames().lookup("f", "map") is None
    assert costmap.frames().lookup("f", "odom").isclose(Pose.planar(1.0, 0.0, 0.0))
    with pytest.raises(UnknownFrame):
        costmap.frames().lookup("f", "camera")
    base = BaseControllerNode(Bus())
    base.on_odom(message_from_data(Odometry, {"pose": {"pose": {"position": {"x": 2.0},
                                                                "orientation": {"z": 1.0, "w": 0.0}}}}))
    frames = base.frames()
    assert frames.fixed_frame == "odom" and frames.lookup("f", "base_link").isclose(Pose.planar(2.0, 0.0, math.pi))
    manager = ManagerNode(Bus(), robot=None)
    manager.set_parameters({"static_transforms": {"camera": {"translation": [0.0, 0.0, 1.0]}}})
    assert manager.state.params.frames().lookup("f", "camera").isclose(Pose((0.0, 0.0, 1.0)))


@pytest.mark.parametrize(("orientation", "field"), [({"w": 1e308}, "pose.pose.orientation"),
                                                    ({"z": 1e308, "w": 1e308}, "pose.pose.orientation")])
def test_odometry_quaternions_never_overflow(orientation: dict[str, float], field: str) -> None:
    node = BaseControllerNode(Bus())
    with pytest.raises(InvalidInput) as error:
        node.on_odom(message_from_data(Odometry, {"pose": {"pose": {"orientation": orientation}}}))
    assert error.value.field == field and node.pose.tolist() == [0.0, 0.0, 0.0]
    node.on_odom(message_from_data(Odometry, {"pose": {"pose": {"orientation": {"z": 1e5, "w": 1e5}}}}))
    assert node.pose[2] == pytest.approx(math.pi / 2)
