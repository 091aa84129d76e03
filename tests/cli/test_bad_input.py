"""Every bad input of the node's issue, against the running server: a clear error naming the field, the
node's state unchanged, the node still serving; afterwards the seed's plan still succeeds."""

from __future__ import annotations

import math
import shlex
import threading
from typing import Any

import httpx
import pytest
import yaml
from pfield_node_server import NodeServer

from seed_examples import (
    GOAL,
    GOAL_TOLERANCE,
    OBSTACLE_COMMANDS,
    PLAN_TASK_SPACE_COMMAND,
    PLAN_WHOLE_BODY_COMMAND,
)

OBSTACLES = "potential_fields_interfaces/msg/ObstacleArray"
PLAN = "potential_fields_interfaces/srv/PlanPath"
AUTONOMY = "potential_fields_interfaces/srv/ComputeAutonomyVector"
POSE = "pose: {position: {x: 0.3, y: 0.4, z: 0.2}, orientation: {w: 1.0}}"
GOOD = f"{{frame_id: 'extra', type: 'Sphere', group: 'Static', {POSE}, radius: 0.05}}"
WHOLE_BODY = ("goal: {position: {x: 0.5, y: 0.2, z: 0.4}}, delta_time: 0.02, goal_tolerance: 0.01, "
              "starting_joint_angles: [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0]")


def obstacle_array(item: str, frame: str = "world") -> str:
    """A message with a good new obstacle first, so a partial update would show."""
    return f"{{header: {{frame_id: '{frame}'}}, obstacles: [{GOOD}, {item}]}}"


def mesh(resource: str) -> str:
    return f"{{frame_id: 'm', type: 'Mesh', group: 'Static', {POSE}, mesh_resource: '{resource}', " \
           "scale_x: 1.0, scale_y: 1.0, scale_z: 1.0}"


# Sent over HTTP as JSON (YAML flow text decoded first): (route, request text, field the 400 answer names)
HTTP_CASES = {
    "unknown field": ("/topic/pfield/obstacles", "{obstacles: [{radiuss: 1}]}", "obstacles[0].radiuss"),
    "unknown shape": ("/topic/pfield/obstacles", obstacle_array(
        f"{{frame_id: 'c', type: 'Cone', group: 'Static', {POSE}, radius: 0.1}}"), "obstacles[1].type"),
    "unknown group": ("/topic/pfield/obstacles", obstacle_array(
        f"{{frame_id: 'c', type: 'Sphere', group: 'Flying', {POSE}, radius: 0.1}}"), "obstacles[1].group"),
    "negative size": ("/topic/pfield/obstacles", obstacle_array(
        f"{{frame_id: 'c', type: 'Sphere', group: 'Static', {POSE}, radius: -0.1}}"), "obstacles[1].radius"),
    "zero size": ("/topic/pfield/obstacles", obstacle_array(
        f"{{frame_id: 'c', type: 'Box', group: 'Static', {POSE}, length: 0.1, width: 0.0, height: 0.1}}"),
        "obstacles[1].width"),
    "zero quaternion": ("/topic/pfield/obstacles", obstacle_array(
        "{frame_id: 'c', type: 'Sphere', group: 'Static', pose: {orientation: {w: 0.0}}, radius: 0.1}"),
        "obstacles[1].pose.orientation"),
    "mesh without package path": ("/topic/pfield/obstacles", obstacle_array(
        mesh("package://other_description/meshes/obstacle.dae")), "obstacles[1].mesh_resource"),
    "mesh outside allowed roots": ("/topic/pfield/obstacles", obstacle_array(mesh("file:///etc/passwd")),
                                   "obstacles[1].mesh_resource"),
    "not a mesh": ("/topic/pfield/obstacles", obstacle_array(mesh("package://my_robot_description/package.xml")),
                   "obstacles[1].mesh_resource"),
    "other frame": ("/topic/pfield/obstacles", obstacle_array(GOOD, frame="map"), "header.frame_id"),
    "wrong joint count": ("/srv/pfield/plan_path", "{" + WHOLE_BODY.replace("-1.5708, 0.0]", "-1.5708]") +
                          ", planning_method: 'whole_body'}", "starting_joint_angles"),
    "unknown planning method": ("/srv/pfield/plan_path", "{" + WHOLE_BODY + ", planning_method: 'rrt_star'}",
                                "planning_method"),
    "max_iterations above the cap": ("/srv/pfield/plan_path", "{" + WHOLE_BODY + ", max_iterations: 2000000, "
                                     "planning_method: 'whole_body'}", "max_iterations"),
    "autonomy in another frame": ("/srv/pfield/compute_autonomy_vector", "{query_pose: {header: {frame_id: "
                                  "'base_link'}}, planning_method: 'task_space'}", "query_pose.header.frame_id"),
    "autonomy joint count": ("/srv/pfield/compute_autonomy_vector", "{query_pose: {header: {frame_id: 'world'}}, "
                             "joint_angles: [0.0, 0.1], planning_method: 'whole_body'}", "joint_angles"),
}

# Through the CLI: (arguments, text stderr must contain). Local checks (YAML, types) and server errors alike.
CLI_CASES = {
    "malformed YAML": (["topic", "pub", "--once", "/pfield/obstacles", OBSTACLES, "{header: {frame_id: 'world'}"],
                       "yaml"),
    "unknown message type": (["topic", "pub", "--once", "/pfield/obstacles", "potential_fields_interfaces/msg/Nope",
                              "{}"], "unknown message type"),
    "unknown service type": (["service", "call", "/pfield/plan_path", "potential_fields_interfaces/srv/Nope", "{}"],
                             "unknown service type"),
    "NaN size": (["topic", "pub", "--once", "/pfield/obstacles", OBSTACLES, obstacle_array(
        f"{{frame_id: 'c', type: 'Capsule', group: 'Static', {POSE}, radius: .nan, height: 0.1}}")],
        "obstacles[1].radius"),
    "wrong joint count": (["service", "call", "/pfield/plan_path", PLAN, "{" + WHOLE_BODY.replace(
        "-1.5708, 0.0]", "-1.5708]") + ", planning_method: 'whole_body'}"], "starting_joint_angles"),
    "bad parameter": (["param", "set", "/pfield_manager", "influence_distance", "--", "-0.5"], "influence_distance"),
}


def state(server: NodeServer) -> tuple[Any, ...]:
    markers = httpx.get(f"{server.url}/topic/pfield/markers").json()
    params = httpx.get(f"{server.url}/param/pfield_manager").json()
    return server.obstacle_ids(), markers, params


@pytest.mark.parametrize("case", list(HTTP_CASES))
def test_bad_request_is_refused_naming_the_field_and_changes_nothing(seeded: NodeServer, case: str) -> None:
    route, text, field = HTTP_CASES[case]
    before = state(seeded)
    answer = httpx.post(seeded.url + route, json=yaml.safe_load(text))
    assert answer.status_code == 400, answer.text
    assert answer.json()["field"] == field and field in answer.json()["error"]
    assert state(seeded) == before


@pytest.mark.parametrize("case", list(CLI_CASES))
def test_bad_cli_input_exits_2_and_changes_nothing(seeded: NodeServer, case: str) -> None:
    args, expected = CLI_CASES[case]
    before = state(seeded)
    done = seeded.cli(*args)
    assert done.returncode == 2  # refused as given, locally or by the node (docs/node.md, "Exit codes")
    error = done.stderr.strip().splitlines()[-1]
    assert error.startswith("error: ") and expected in error
    assert state(seeded) == before


@pytest.mark.parametrize(("path", "body", "params", "status", "field"), [
    ("/topic/pfield/obstacles", b"{not json", None, 400, "body"),
    ("/srv/pfield/plan_path", b"[1, 2", None, 400, "body"),
    ("/topic/pfield/obstacles", b"{}", {"type": "potential_fields_interfaces/msg/Nope"}, 400, "type"),
    ("/srv/pfield/nope", b"{}", None, 404, "service"),
    ("/srv/pfield/plan_path", b'{"goal": {"position": {"x": "far"}}}', None, 400, "goal.position.x"),
    ("/srv/pfield/plan_path", b'{"planning_method": "whole_body", "max_iterations": 1e12}', None, 400,
     "max_iterations"),
    ("/srv/pfield/plan_path", b'{"padding": "' + b"x" * 2_000_000 + b'"}', None, 413, "body"),
])
def test_bad_http_requests(seeded: NodeServer, path: str, body: bytes, params: dict[str, str] | None, status: int,
                           field: str) -> None:
    before = state(seeded)
    answer = httpx.post(seeded.url + path, content=body, params=params, headers={"content-type": "application/json"})
    assert answer.status_code == status
    assert answer.json()["field"] == field and answer.json()["error"]
    assert state(seeded) == before


@pytest.mark.parametrize("command", [PLAN_TASK_SPACE_COMMAND, PLAN_WHOLE_BODY_COMMAND],
                         ids=["task_space", "whole_body"])
def test_the_seed_plans_still_succeed_after_all_bad_input(seeded: NodeServer, command: str) -> None:
    assert sorted(seeded.obstacle_ids()) == sorted(OBSTACLE_COMMANDS)
    response = seeded.call(*shlex.split(command)[3:])
    assert response["success"] is True, response["error_message"]
    end = response["end_effector_path"]["poses"][-1]["pose"]["position"]
    assert math.dist((end["x"], end["y"], end["z"]), GOAL) <= GOAL_TOLERANCE


def test_autonomy_answers_while_a_30000_iteration_plan_runs(seeded: NodeServer) -> None:
    url = seeded.url
    original = httpx.get(f"{url}/param/pfield_manager").json()
    # a slow, steady approach: the plan uses all 30000 steps (max_iterations 0) without reaching the goal
    slow = {"max_linear_velocity": 0.0002, "stagnation_progress": 1e-6}
    httpx.put(f"{url}/param/pfield_manager", json=slow).raise_for_status()
    request = {"start": {"position": {"x": 0.227, "y": 0.0, "z": 0.294}},
               "goal": {"position": {"x": 0.3, "y": 0.3, "z": 0.45}},
               "delta_time": 0.02, "goal_tolerance": 0.001, "max_iterations": 0, "planning_method": "task_space"}
    query = {"query_pose": {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.3, "y": 0.1, "z": 0.35}}},
             "delta_time": 0.02, "planning_method": "task_space"}
    result: dict[str, Any] = {}
    planner = threading.Thread(target=lambda: result.update(
        httpx.post(f"{url}/srv/pfield/plan_path", json=request, timeout=600).json()))
    try:
        planner.start()
        answered_during_plan = 0
        with httpx.Client(base_url=url, timeout=600) as client:
            while planner.is_alive():
                answer = client.post("/srv/pfield/compute_autonomy_vector", json=query)
                assert answer.status_code == 200
                answered_during_plan += planner.is_alive() and not result
        planner.join()
    finally:
        httpx.put(f"{url}/param/pfield_manager", json={k: original[k] for k in slow}).raise_for_status()
    assert answered_during_plan >= 1
    assert result["success"] is False and result["error_message"]
    assert len(result["end_effector_path"]["poses"]) == 30001
