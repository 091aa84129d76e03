"""The ``/costmap`` node: FindValidPose requests, robot pose, maps, parameters, bad input; over real HTTP too."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest

from pfield.costmap import OccupancyMap, save_map
from pfield.errors import InvalidInput, PfieldError, ResourceNotFound, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces.nav_msgs import OccupancyGrid
from pfield.interfaces.potential_fields_interfaces import FindValidPose_Request
from pfield.node._base import Bus
from pfield.node.costmap_server import CostmapServer, costmap_node_from_options, published_costmap_values
from pfield.transport.http import ServerThread, create_app

SQUARE = "[[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]]"


def _occupancy() -> OccupancyMap:
    data = np.zeros((20, 30), dtype=np.int8)  # 3 m × 2 m at 0.1 m, origin (-1, -1)
    data[10, 10] = 100  # obstacle cell x ∈ [0.0, 0.1), y ∈ [0.0, 0.1)
    data[:, 25:] = -1  # unknown strip x ≥ 1.5
    return OccupancyMap(data, 0.1, (-1.0, -1.0, 0.0))


def _node() -> CostmapServer:
    node = CostmapServer(Bus())
    node.set_parameters({"footprint": SQUARE, "footprint_padding": 0.0, "inflation_radius": 0.0})
    node.set_map(_occupancy())
    return node


def _request(x: float, y: float, yaw: float = 0.0, frame: str = "map", **fields: object) -> FindValidPose_Request:
    body = {"pose": {"header": {"frame_id": frame},
                     "pose": {"position": {"x": x, "y": y},
                              "orientation": {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}},
            "costmap": 2} | fields
    return FindValidPose_Request.model_validate(body)


def test_free_pose_unchanged_and_lethal_pose_moved() -> None:
    node = _node()
    free = node.on_find_valid_pose(_request(-0.5, -0.5, 0.3, dist_tolerance=0.5))
    assert free.state == 0 and free.cost == 0
    assert (free.pose.pose.position.x, free.pose.pose.position.y) == (-0.5, -0.5)
    assert free.pose.header.frame_id == "map"
    moved = node.on_find_valid_pose(_request(0.05, 0.05, dist_tolerance=0.5))
    assert moved.state == 0
    assert math.hypot(moved.pose.pose.position.x - 0.05, moved.pose.pose.position.y - 0.05) == pytest.approx(0.2)
    stuck = node.on_find_valid_pose(_request(0.05, 0.05))
    assert stuck.state == 2 and stuck.pose == gm.PoseStamped()


def test_use_padded_fp_and_safety_dist_from_the_padded_footprint() -> None:
    node = _node()
    node.set_parameters({"footprint_padding": 0.1})
    # square spans x ∈ [-0.25, -0.05] at x = -0.15: the obstacle cell x ∈ [0.0, 0.1) is 0.05 m away
    plain = node.on_find_valid_pose(_request(-0.15, 0.05))
    padded = node.on_find_valid_pose(_request(-0.15, 0.05, use_padded_fp=True))
    assert (plain.state, padded.state) == (0, 2)
    # safety_dist 0.1 reaches the obstacle from the unpadded square, and farther from the padded one
    assert node.on_find_valid_pose(_request(-0.25, 0.05, safety_dist=0.1)).state == 0
    assert node.on_find_valid_pose(_request(-0.25, 0.05, safety_dist=0.1, use_padded_fp=True)).state == 2


def test_unknown_and_outside_states() -> None:
    node = _node()
    assert node.on_find_valid_pose(_request(1.55, 0.0)).state == 3
    assert node.on_find_valid_pose(_request(-0.95, 0.0)).state == 4


def test_current_pose_uses_the_robot_pose() -> None:
    node = _node()
    request = _request(0.05, 0.05, current_pose=True)  # the pose field points at the obstacle: ignored
    with pytest.raises(InvalidInput, match="robot pose"):
        node.on_find_valid_pose(request)
    node.on_robot_pose(gm.PoseStamped.model_validate({"header": {"frame_id": "map"},
                                                      "pose": {"position": {"x": 0.7, "y": 0.4}}}))
    answer = node.on_find_valid_pose(request)
    assert answer.state == 0 and (answer.pose.pose.position.x, answer.pose.pose.position.y) == (0.7, 0.4)


def test_local_costmap_window_around_the_robot() -> None:
    node = _node()
    node.set_parameters({"local_window_size": 1.0, "resolution": 0.1})
    with pytest.raises(InvalidInput, match="robot pose"):
        node.on_find_valid_pose(_request(0.0, 0.0, costmap=1))
    node.on_robot_pose(gm.PoseStamped.model_validate({"pose": {"position": {"x": -0.45, "y": -0.45}}}))
    # the 1 m window around the robot spans [-1, 0) in x and y: (0.5, 0.5) is free on the global map but
    # outside the local window
    assert node.on_find_valid_pose(_request(-0.45, -0.45, costmap=1)).state == 0
    assert node.on_find_valid_pose(_request(0.5, 0.5, costmap=1)).state == 4
    assert node.on_find_valid_pose(_request(0.5, 0.5, costmap=2)).state == 0


def test_frames_and_transforms() -> None:
    node = _node()
    with pytest.raises(UnknownFrame) as info:
        node.on_find_valid_pose(_request(0.0, 0.0, frame="odom"))
    assert info.value.field == "pose.header.frame_id"
    shifted = CostmapServer(Bus(), node.params, _occupancy(), frame_transforms={"odom": (0.5, 0.0, 0.0)})
    answer = shifted.on_find_valid_pose(_request(-1.0, -0.5, frame="odom"))
    assert answer.pose.header.frame_id == "map" and answer.pose.pose.position.x == pytest.approx(-0.5)
    assert node.on_find_valid_pose(_request(-0.5, -0.5, frame="")).state == 0


@pytest.mark.parametrize(
    ("fields", "field"),
    [({"costmap": 0}, "costmap"), ({"costmap": 3}, "costmap"), ({"dist_tolerance": -0.1}, "dist_tolerance"),
     ({"angle_tolerance": -0.1}, "angle_tolerance"), ({"safety_dist": -1.0}, "safety_dist")],
)
def test_bad_requests_rejected(fields: dict[str, object], field: str) -> None:
    node = _node()
    with pytest.raises(InvalidInput) as info:
        node.on_find_valid_pose(_request(0.0, 0.0, **fields))
    assert info.value.field == field


def test_non_finite_pose_rejected() -> None:
    node = _node()
    with pytest.raises(InvalidInput, match="finite"):
        node.on_find_valid_pose(_request(math.nan, 0.0))
    with pytest.raises(InvalidInput, match="finite"):
        node.on_robot_pose(gm.PoseStamped.model_validate({"pose": {"position": {"x": math.inf}}}))
    assert node.robot_pose is None


def test_no_map_is_a_clear_error() -> None:
    with pytest.raises(InvalidInput, match="no map"):
        CostmapServer(Bus()).on_find_valid_pose(_request(0.0, 0.0))


def test_bad_maps_and_parameters_keep_the_state(tmp_path: Path) -> None:
    node = _node()
    before, params = node.costmap, node.get_parameters()
    with pytest.raises(ResourceNotFound):
        node.load_map(tmp_path / "missing.yaml")
    with pytest.raises(InvalidInput):
        node.on_map(OccupancyGrid.model_validate({"info": {"width": 2, "height": 2, "resolution": 0.1},
                                                  "data": [0]}))
    for bad in ({"footprint": "[[0, 0], [1, 1], [1, 0], [0, 1]]"}, {"resolution": -1.0}, {"nope": 1},
                {"inflation_radius": 0.3, "robot_radius": -1.0}):
        with pytest.raises(PfieldError):
            node.set_parameters(bad)
    assert node.costmap is before and node.get_parameters() == params
    assert node.on_find_valid_pose(_request(-0.5, -0.5)).state == 0


def test_parameters_rebuild_inflation_and_publish_costmap() -> None:
    node = _node()
    assert node.costmap is not None and int(node.costmap.costs[10, 11]) == 0
    node.set_parameters({"inflation_radius": 0.3, "cost_scaling_factor": 1.0})
    assert int(node.costmap.costs[10, 11]) == 253  # 0.1 m from the obstacle, inside the 0.1 m inscribed radius
    published = node.bus.latest("/costmap/costmap")
    assert isinstance(published, OccupancyGrid) and published.info.width == 30
    assert published.data[10 * 30 + 10] == 100 and published.data[10 * 30 + 11] == 99
    assert published.data[10 * 30 + 29] == -1
    values = published_costmap_values(np.array([0, 1, 128, 252, 253, 254, 255], dtype=np.uint8))
    assert values.tolist() == [0, 1, 1 + 97 * 127 // 251, 98, 99, 100, -1]


def test_factory_loads_map_with_footprint(tmp_path: Path) -> None:
    path = save_map(_occupancy(), tmp_path / "map")
    node = costmap_node_from_options(Bus(), path, SQUARE, {"inflation_radius": 0.0})
    assert node.params.footprint == SQUARE and node.occupancy is not None
    assert node.occupancy.data[10, 10] == 100


@pytest.fixture(scope="module")
def served() -> Iterator[tuple[CostmapServer, str]]:
    node = _node()
    with ServerThread(create_app([node])) as server:
        yield node, server.url


def test_over_http(served: tuple[CostmapServer, str]) -> None:
    node, url = served
    body = {"pose": {"header": {"frame_id": "map"}, "pose": {"position": {"x": 0.05, "y": 0.05}}},
            "dist_tolerance": 0.5, "angle_tolerance": 0.5, "costmap": 2}
    answer = httpx.post(f"{url}/srv/pfield/find_valid_pose", json=body)
    assert answer.status_code == 200 and answer.json()["state"] == 0
    bad = httpx.post(f"{url}/srv/pfield/find_valid_pose", json=body | {"costmap": 5})
    assert bad.status_code == 400 and bad.json()["field"] == "costmap"
    pose = {"header": {"frame_id": "map"}, "pose": {"position": {"x": 0.7, "y": 0.4}}}
    assert httpx.post(f"{url}/topic/robot_pose", json=pose).is_success
    current = httpx.post(f"{url}/srv/pfield/find_valid_pose", json={"current_pose": True, "costmap": 2}).json()
    assert current["pose"]["pose"]["position"] == {"x": 0.7, "y": 0.4, "z": 0.0}
    params = httpx.get(f"{url}/param/costmap").json()
    assert params["footprint"] == SQUARE and params["global_frame"] == "map"
    assert node.robot_pose is not None and node.last_result is not None
