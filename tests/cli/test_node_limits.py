"""Bounded, all-or-nothing requests against a real ``pfield serve``: each refused request answers 400 naming
the field, the state read back through the GET routes is unchanged, and the server keeps serving; the
obstacle count is capped (memory stays bounded) and parameters describe themselves."""

from __future__ import annotations

import json
from typing import Any

import httpx
import pytest
from pfield_node_server import MESH_PACKAGE, NodeServer

from pfield.node.manager import MAX_OBSTACLES
from serve_process import rss_bytes, wait_warm

START = {"position": {"x": 0.3, "y": 0.0, "z": 0.3}, "orientation": {"w": 1.0}}
GOAL = {"position": {"x": 0.45, "y": 0.1, "z": 0.35}, "orientation": {"w": 1.0}}
PLAN = {"start": START, "goal": GOAL, "delta_time": 0.02, "goal_tolerance": 0.01, "max_iterations": 100,
        "planning_method": "task_space"}
OTHER = PLAN | {"goal": {"position": {"x": 0.2, "y": -0.3, "z": 0.5}, "orientation": {"w": 1.0}}}
"""A plan to another goal: a refused one that replaced the goal anyway would show in the markers."""


def sphere(key: str, x: float) -> dict[str, Any]:
    return {"frame_id": key, "type": "Sphere", "group": "Static", "radius": 0.01,
            "pose": {"position": {"x": x, "y": 5.0, "z": 5.0}, "orientation": {"w": 1.0}}}


def state(server: NodeServer) -> tuple[Any, ...]:
    markers = httpx.get(f"{server.url}/topic/pfield/markers")
    params = {node: httpx.get(f"{server.url}/param{node}").json() for node in httpx.get(f"{server.url}/nodes").json()}
    # the goal shows in the autonomy vector at a fixed query pose (the markers lag behind a goal set by a plan)
    query = {"query_pose": {"pose": {"position": {"x": 0.3, "y": 0.0, "z": 0.3}}}}
    autonomy = httpx.post(f"{server.url}/srv/pfield/compute_autonomy_vector", json=query)
    twist = autonomy.json()["autonomy_vector"]["twist"] if autonomy.status_code == 200 else autonomy.status_code
    return server.obstacle_ids(), markers.json() if markers.status_code == 200 else None, params, twist


def send(method: str, url: str, body: Any, timeout: float = 60) -> httpx.Response:
    """JSON with non-ASCII escaped (``"\\ud800"`` stays a lone surrogate escape, as a hostile client sends it)."""
    return httpx.request(method, url, content=json.dumps(body).encode(), timeout=timeout,
                         headers={"content-type": "application/json"})


CASES = {
    "delta_time 1e308": ("/srv/pfield/plan_path", OTHER | {"delta_time": 1e308}, "delta_time"),
    "delta_time 1e-30": ("/srv/pfield/plan_path", OTHER | {"delta_time": 1e-30}, "delta_time"),
    "delta_time 2^31 s": ("/srv/pfield/plan_path", OTHER | {"delta_time": 2.0**31}, "delta_time"),
    "start w 1e308": ("/srv/pfield/plan_path", OTHER | {"start": {"orientation": {"w": 1e308}}}, "start.orientation"),
    "goal w 1e308": ("/srv/pfield/plan_path", OTHER | {"goal": {"position": {"x": 0.2}, "orientation": {"w": 1e308}}},
                     "goal.orientation"),
    "surrogate obstacle id": ("/topic/pfield/obstacles", {"obstacles": [sphere("ok", 9.0), sphere("\ud800", 8.0)]},
                              "obstacles[1].frame_id"),
    "surrogate goal frame": ("/topic/pfield/planning_goal_pose", {"header": {"frame_id": "\ud800"}},
                             "header.frame_id"),
    "odom quaternion 1e308": ("/topic/odom", {"pose": {"pose": {"orientation": {"z": 1e308, "w": 1e308}}}},
                              "pose.pose.orientation"),
    "odom w 1e308": ("/topic/odom", {"pose": {"pose": {"orientation": {"w": 1e308}}}}, "pose.pose.orientation"),
    "too many obstacles at once": ("/topic/pfield/obstacles",
                                   {"obstacles": [sphere(f"f{i}", 10.0 + i) for i in range(MAX_OBSTACLES + 1)]},
                                   "obstacles"),
}
PARAM_CASES = {
    "surrogate fixed_frame": ("/pfield_manager", {"fixed_frame": "\ud800"}, "fixed_frame"),
    "surrogate static transform": ("/pfield_manager", {"static_transforms": {"\ud800": {"translation": [0, 0, 0]}}},
                                   "static_transforms key"),
    "huge velocity": ("/pfield_manager", {"max_linear_velocity": 1e6}, "max_linear_velocity"),
    "mesh cap zero": ("/pfield_manager", {"max_mesh_file_size": 0}, "max_mesh_file_size"),
    "teleop timeout": ("/base_controller", {"teleop_timeout": 1e9}, "teleop_timeout"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_refused_requests_name_the_field_and_change_nothing(node_server: NodeServer, case: str) -> None:
    route, body, field = CASES[case]
    before = state(node_server)
    answer = send("POST", node_server.url + route, body)
    assert answer.status_code == 400, answer.text
    assert answer.json()["field"] == field
    assert state(node_server) == before
    assert httpx.post(f"{node_server.url}/srv/pfield/plan_path", json=PLAN, timeout=120).status_code == 200


@pytest.mark.parametrize("case", list(PARAM_CASES))
def test_refused_parameters_name_the_field_and_change_nothing(node_server: NodeServer, case: str) -> None:
    node, values, field = PARAM_CASES[case]
    before = state(node_server)
    answer = send("PUT", f"{node_server.url}/param{node}", values)
    assert answer.status_code == 400, answer.text
    assert answer.json()["field"] == field
    assert state(node_server) == before


def test_a_plan_refused_after_a_good_one_keeps_its_goal_and_markers(node_server: NodeServer) -> None:
    done = httpx.post(f"{node_server.url}/srv/pfield/plan_path", json=PLAN, timeout=120)
    assert done.status_code == 200
    before = state(node_server)
    other = PLAN | {"goal": {"position": {"x": 0.1, "y": 0.4, "z": 0.2}}, "delta_time": 1e-30}
    assert httpx.post(f"{node_server.url}/srv/pfield/plan_path", json=other).status_code == 400
    assert state(node_server) == before
    goal = next(m for m in before[1]["markers"] if m["ns"] == "goal")["pose"]["position"]
    assert (goal["x"], goal["y"], goal["z"]) == pytest.approx((0.45, 0.1, 0.35))


def test_an_oversized_mesh_is_refused_before_loading(node_server: NodeServer) -> None:
    url = node_server.url
    size = (MESH_PACKAGE / "meshes" / "obstacle.dae").stat().st_size
    original = httpx.get(f"{url}/param/pfield_manager").json()["max_mesh_file_size"]
    httpx.put(f"{url}/param/pfield_manager", json={"max_mesh_file_size": size - 1}).raise_for_status()
    try:
        before = state(node_server)
        mesh = {"frame_id": "big_mesh", "type": "Mesh", "group": "Static", "scale_x": 1.0, "scale_y": 1.0,
                "scale_z": 1.0, "mesh_resource": "package://my_robot_description/meshes/obstacle.dae"}
        answer = httpx.post(f"{url}/topic/pfield/obstacles", json={"obstacles": [mesh]})
        assert answer.status_code == 400 and answer.json()["field"] == "obstacles[0].mesh_resource"
        assert "max_mesh_file_size" in answer.json()["error"]
        assert state(node_server) == before
    finally:
        httpx.put(f"{url}/param/pfield_manager", json={"max_mesh_file_size": original}).raise_for_status()


def test_an_obstacle_flood_stops_at_the_cap_with_bounded_memory(node_server: NodeServer) -> None:
    url = node_server.url
    assert httpx.post(f"{url}/srv/pfield/plan_path", json=PLAN, timeout=60).status_code == 200  # sets a goal
    wait_warm(url)  # kernels compiling on a cold cache would count as growth
    held = node_server.obstacle_ids()
    start_rss = rss_bytes(node_server.process.pid)
    added: list[str] = []
    try:
        batch = 1000
        for first in range(0, 112_000, batch):
            items = [sphere(f"flood{i}", 10.0 + i) for i in range(first, first + batch)]
            answer = httpx.post(f"{url}/topic/pfield/obstacles", json={"obstacles": items}, timeout=120)
            if answer.status_code != 200:
                assert answer.status_code == 400 and answer.json()["field"] == "obstacles"
                break
            added += [item["frame_id"] for item in items]
        assert len(held) + len(added) <= MAX_OBSTACLES < len(held) + len(added) + batch
        growth_mib = (rss_bytes(node_server.process.pid) - start_rss) / 2**20
        assert growth_mib < 400, f"RSS grew by {growth_mib:.0f} MiB"
        assert httpx.post(f"{url}/srv/pfield/compute_autonomy_vector", json={
            "query_pose": {"pose": {"position": {"x": 0.3, "y": 0.0, "z": 0.3}}}}).status_code == 200
    finally:
        if added:
            httpx.post(f"{url}/srv/pfield/remove_obstacles", json={"frame_ids": added}, timeout=120)
    assert node_server.obstacle_ids() == held


def test_parameters_describe_themselves(node_server: NodeServer) -> None:
    for node in httpx.get(f"{node_server.url}/nodes").json():
        rows = httpx.get(f"{node_server.url}/param{node}", params={"describe": "true"}).json()
        values = httpx.get(f"{node_server.url}/param{node}").json()
        assert list(rows) == list(values)
        assert all(row["description"] and row["type"] for row in rows.values())
    manager = httpx.get(f"{node_server.url}/param/pfield_manager?describe=true").json()
    assert manager["max_mesh_file_size"]["default"] == 50_000_000 and manager["fixed_frame"]["type"] == "string"
