"""Client of the acceptance test: drives the real ``/pfield_manager`` (``pfield ros2 node``) over ROS 2
with the seed document's examples and records what it observes (summaries, not whole paths).

Writes ``$ROS2_TEST_OUT/results.json``; ``tests/transport/test_ros2_manager.py`` asserts on it.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # ros2_helpers
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the seed examples of all tests

import seed_examples as seed
from ros2_helpers.client import BlockingClient
from ros2_helpers.scenario import AUTONOMY, NODE, OBSTACLES, PLAN, REMOVE, remaining, run_phases

SEED_IDS = sorted(seed.OBSTACLES)
STARTED = time.perf_counter()


def wait_remaining(client: BlockingClient, expected: list[str], timeout: float = 30.0) -> list[str]:
    """The held obstacle ids once they equal ``expected`` (topic messages are handled asynchronously)."""
    deadline = time.monotonic() + timeout
    while (ids := sorted(remaining(client))) != expected and time.monotonic() < deadline:
        time.sleep(0.05)
    return ids


def plan_summary(response: dict[str, Any]) -> dict[str, Any]:
    poses = response["end_effector_path"]["poses"]
    points = response["joint_trajectory"]["points"]
    last = poses[-1]["pose"]["position"] if poses else None
    return {"success": response["success"], "error_message": response["error_message"], "poses": len(poses),
            "path_frame": response["end_effector_path"]["header"]["frame_id"],
            "final_position": [last["x"], last["y"], last["z"]] if last else None,
            "twists": len(response["end_effector_velocity_trajectory"]),
            "joint_names": response["joint_trajectory"]["joint_names"], "joint_points": len(points),
            "joint_point_sizes": sorted({len(p["positions"]) for p in points})}


def linear(response: dict[str, Any]) -> list[float]:
    vector = response["autonomy_vector"]["twist"]["linear"]
    return [vector["x"], vector["y"], vector["z"]]


def startup_parameters(client: BlockingClient, results: dict[str, Any]) -> None:
    """Values the node started with: ``--params`` YAML, then ``--ros-args -p`` on top."""
    results["startup_parameters"] = {
        "/pfield_manager": client.get_parameters(NODE, ["dynamic_obstacle_timeout", "influence_distance"]),
        "/costmap": client.get_parameters("/costmap", ["inflation_radius"]),
    }


def answered(client: BlockingClient, request: dict[str, Any], timeout: float = 30.0) -> dict[str, Any]:
    """The first autonomy answer the node gives (a refused call, e.g. before the goal topic was handled,
    answers the default response with an empty frame)."""
    deadline = time.monotonic() + timeout
    while not (response := client.call(*AUTONOMY, request))["autonomy_vector"]["header"]["frame_id"]:
        if time.monotonic() > deadline:
            break
        time.sleep(0.05)
    return response


def obstacles_and_plans(client: BlockingClient, results: dict[str, Any]) -> None:
    markers = client.subscribe("/pfield/markers", "visualization_msgs/msg/MarkerArray")
    paths = client.subscribe("/pfield/planned_path", "nav_msgs/msg/Path")
    for text in seed.OBSTACLES.values():  # one `ros2 topic pub --once` per shape, as in the seed
        client.publish("/pfield/obstacles", OBSTACLES, seed.parse(text))
    results["held_after_seed"] = wait_remaining(client, SEED_IDS)
    results["timeline"]["seed_obstacles_held"] = round(time.perf_counter() - STARTED, 2)
    seen = markers.wait_for(lambda m: sorted(k["text"] for k in m["markers"] if k["ns"] == "obstacles") == SEED_IDS)
    results["marker_namespaces"] = sorted({k["ns"] for k in seen["markers"]})
    for name, text in (("task_space", seed.PLAN_TASK_SPACE), ("whole_body", seed.PLAN_WHOLE_BODY)):
        start = time.perf_counter()
        summary = plan_summary(client.call(*PLAN, seed.parse(text), timeout=300.0))
        summary["seconds"] = time.perf_counter() - start
        results[f"plan_{name}"] = summary
        if summary["poses"]:
            published = paths.wait_for(lambda m, n=summary["poses"]: len(m["poses"]) == n)
            results[f"planned_path_{name}"] = {"poses": len(published["poses"]),
                                               "frame": published["header"]["frame_id"]}
    path_markers = markers.wait_for(lambda m: any(k["ns"] == "path" for k in m["markers"]))
    results["path_marker_points"] = max(len(k["points"]) for k in path_markers["markers"] if k["ns"] == "path")


def autonomy_and_parameters(client: BlockingClient, results: dict[str, Any]) -> None:
    goal = {"header": {"frame_id": "world"},
            "pose": seed.parse(seed.PLAN_TASK_SPACE)["goal"]}
    client.publish("/pfield/planning_goal_pose", "geometry_msgs/msg/PoseStamped", goal)
    results["autonomy_task_space"] = linear(answered(client, seed.parse(seed.AUTONOMY_TASK_SPACE)))
    results["autonomy_whole_body"] = linear(client.call(*AUTONOMY, seed.parse(seed.AUTONOMY_WHOLE_BODY)))
    # the topic form: a pose on /pfield/query_pose is answered on /pfield/autonomy_vector
    answers = client.subscribe("/pfield/autonomy_vector", "geometry_msgs/msg/TwistStamped")
    client.publish("/pfield/query_pose", "geometry_msgs/msg/PoseStamped",
                   seed.parse(seed.AUTONOMY_TASK_SPACE)["query_pose"])
    answer = answers.wait_for(lambda m: m["header"]["frame_id"] == "world")["twist"]["linear"]
    results["autonomy_topic"] = [answer["x"], answer["y"], answer["z"]]
    results["set_max_linear_velocity"] = client.set_parameters(NODE, {"max_linear_velocity": 0.01})
    results["autonomy_task_space_slow"] = linear(client.call(*AUTONOMY, seed.parse(seed.AUTONOMY_TASK_SPACE)))
    results["set_bad"] = client.set_parameters(NODE, {"max_linear_velocity": -1.0})
    results["set_bad_influence"] = client.set_parameters(NODE, {"influence_distance": float("nan")})
    results["params_after"] = client.get_parameters(NODE, ["max_linear_velocity", "influence_distance"])


def bad_obstacles(client: BlockingClient, results: dict[str, Any]) -> None:
    before = linear(client.call(*AUTONOMY, seed.parse(seed.AUTONOMY_TASK_SPACE)))
    ball = seed.parse(seed.OBSTACLES["ball"])["obstacles"][0]
    bad_messages = [
        [dict(ball, frame_id="ok_in_bad_message", pose={"position": {"x": 0.3, "y": 0.1, "z": 0.3}}),
         dict(ball, frame_id="negative", radius=-0.1)],
        [dict(ball, frame_id="blob", type="Blob")],
        [dict(ball, frame_id="passwd", type="Mesh", mesh_resource="file:///etc/passwd", scale_x=1.0, scale_y=1.0,
              scale_z=1.0)],
        [dict(ball, frame_id="no_package", type="Mesh", mesh_resource="package://nowhere/meshes/x.dae",
              scale_x=1.0, scale_y=1.0, scale_z=1.0)],
    ]
    for obstacles in bad_messages:
        client.publish("/pfield/obstacles", OBSTACLES, {"header": {"frame_id": "world"}, "obstacles": obstacles})
    # a good message after the bad ones: once it is held, the bad ones (same publisher, in order) were handled
    probe = dict(ball, frame_id="probe", pose={"position": {"x": -2.0, "y": -2.0, "z": 2.0}})
    client.publish("/pfield/obstacles", OBSTACLES, {"header": {"frame_id": "world"}, "obstacles": [probe]})
    results["held_after_bad"] = wait_remaining(client, sorted([*SEED_IDS, "probe"]))
    results["remove_probe"] = client.call(*REMOVE, {"frame_ids": ["probe"]})["success"]
    after = linear(client.call(*AUTONOMY, seed.parse(seed.AUTONOMY_TASK_SPACE)))
    results["autonomy_unchanged_by_bad"] = before == after and all(math.isfinite(v) for v in after)


def occupancy_grid() -> dict[str, Any]:
    """A 2 m x 2 m map at 5 cm, free but for a lethal 20 cm block centred at (1, 1)."""
    data = [0] * (40 * 40)
    for row in range(18, 22):
        for column in range(18, 22):
            data[row * 40 + column] = 100
    return {"header": {"frame_id": "map"}, "info": {"resolution": 0.05, "width": 40, "height": 40},
            "data": data}


def mobile_and_costmap(client: BlockingClient, results: dict[str, Any]) -> None:
    """The other nodes of the process: the base controller's topics and the costmap's FindValidPose."""
    commands = client.subscribe("/cmd_vel", "geometry_msgs/msg/Twist")
    scan = {"header": {"frame_id": ""}, "angle_min": -1.5, "angle_max": 1.5, "angle_increment": 0.5,
            "range_min": 0.05, "range_max": 10.0, "ranges": [8.0] * 7}
    client.publish("/scan", "sensor_msgs/msg/LaserScan", scan)
    client.publish("/goal_point", "geometry_msgs/msg/PointStamped", {"point": {"x": 2.0, "y": 0.0}})
    moving = commands.wait_for(lambda m: m["linear"]["x"] > 0.0)
    results["cmd_vel"] = [moving["linear"]["x"], moving["linear"]["y"], moving["angular"]["z"]]
    results["max_spd_norm"] = client.get_parameters("/base_controller", ["max_spd_norm"])["max_spd_norm"]
    client.publish("/map", "nav_msgs/msg/OccupancyGrid", occupancy_grid())
    costmaps = client.subscribe("/costmap/costmap", "nav_msgs/msg/OccupancyGrid")
    costmaps.wait_for(lambda m: m["info"]["width"] == 40)
    service = ("/pfield/find_valid_pose", "potential_fields_interfaces/srv/FindValidPose")
    request = {"pose": {"header": {"frame_id": "map"}, "pose": {"position": {"x": 0.3, "y": 0.3}}},
               "dist_tolerance": 0.5, "angle_tolerance": 0.5, "costmap": 2}
    free = client.call(*service, request)
    results["find_valid_pose_free"] = [free["state"], free["pose"]["pose"]["position"]["x"],
                                       free["pose"]["pose"]["position"]["y"], free["pose"]["header"]["frame_id"]]
    blocked = dict(request, pose={"header": {"frame_id": "map"}, "pose": {"position": {"x": 1.0, "y": 1.0}}},
                   dist_tolerance=0.0, angle_tolerance=0.0)
    results["find_valid_pose_blocked"] = client.call(*service, blocked)["state"]
    results["find_valid_pose_bad_costmap"] = client.call(*service, dict(request, costmap=7))["state"]


PHASES = (startup_parameters, obstacles_and_plans, autonomy_and_parameters, bad_obstacles, mobile_and_costmap)


if __name__ == "__main__":
    run_phases(PHASES)
