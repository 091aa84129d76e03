"""Client of the transport test: drives ``echo_node.py`` over ROS 2 and records what it observes.

Writes ``$ROS2_TEST_OUT/results.json``; ``tests/transport/test_ros2_transport.py`` asserts on it.
"""

from __future__ import annotations

import sys
import threading
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ros2_helpers.client import BlockingClient, Inbox
from ros2_helpers.scenario import AUTONOMY, NODE, OBSTACLES, PLAN, REMOVE, remaining, run_phases

QUERY = {"query_pose": {"header": {"frame_id": "world"},
                        "pose": {"position": {"x": 0.3, "y": 0.1, "z": 0.35}, "orientation": {"w": 1.0}}}}
BALL = {"frame_id": "ball", "type": "Sphere", "group": "Static",
        "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.1}, "orientation": {"w": 1.0}}, "radius": 0.1}
DYN = {"frame_id": "dyn", "type": "Box", "group": "Dynamic", "length": 0.1, "width": 0.1, "height": 0.1}


def plan_while_querying(client: BlockingClient, paths: Inbox, results: dict[str, Any]) -> None:
    """A slow plan in one thread; once the node says it is planning, autonomy calls in this one until the
    plan answers: each counted answer came while the node was inside the plan handler."""
    client.set_parameters(NODE, {"plan_seconds": 2.0})
    plan: dict[str, Any] = {}
    request = {"start": {"position": {"x": 0.0}}, "goal": {"position": {"x": 1.0, "y": 0.5}},
               "planning_method": "task_space"}
    thread = threading.Thread(target=lambda: plan.update(client.call(*PLAN, request)))
    thread.start()
    paths.wait_for(lambda m: m["header"]["frame_id"] == "planning")
    answered = 0
    while thread.is_alive() and answered < 1000:
        client.call(*AUTONOMY, QUERY)
        answered += 1 if thread.is_alive() else 0
    thread.join()
    client.set_parameters(NODE, {"plan_seconds": 0.0})
    results["autonomy_answers_during_plan"] = answered
    results["plan"] = plan


def run(client: BlockingClient, results: dict[str, Any]) -> None:
    markers = client.subscribe("/pfield/markers", "visualization_msgs/msg/MarkerArray")
    paths = client.subscribe("/pfield/planned_path", "nav_msgs/msg/Path")
    client.publish("/pfield/obstacles", OBSTACLES, {"header": {"frame_id": "world"}, "obstacles": [BALL, DYN]})
    results["markers_two"] = markers.wait_for(lambda m: len(m["markers"]) == 2)
    results["dynamic_expired"] = markers.wait_for(lambda m: [k["ns"] for k in m["markers"]] == ["ball"])
    results["autonomy"] = client.call(*AUTONOMY, QUERY)
    results["autonomy_bad_frame"] = client.call(*AUTONOMY, {"query_pose": {"header": {"frame_id": "map"}}})
    plan_while_querying(client, paths, results)
    results["planned_path"] = paths.wait_for(lambda m: len(m["poses"]) == 20)
    results["plan_bad_method"] = client.call(*PLAN, {"planning_method": "sideways"})
    results["set_ok"] = client.set_parameters(NODE, {"max_linear_velocity": 0.02, "gain": 2, "weights": [3, 4]})
    results["set_bad"] = client.set_parameters(NODE, {"max_linear_velocity": -1.0})
    results["set_wrong_type"] = client.set_parameters(NODE, {"max_linear_velocity": "fast"})
    results["set_undeclared"] = client.set_parameters(NODE, {"no_such_parameter": 1.0})
    results["params_after"] = client.get_parameters(NODE, ["max_linear_velocity", "gain", "weights"])
    results["autonomy_after_set"] = client.call(*AUTONOMY, QUERY)
    before = remaining(client)
    bad_sphere = dict(BALL, frame_id="bad", radius=-1.0)
    client.publish("/pfield/obstacles", OBSTACLES, {"obstacles": [dict(BALL, frame_id="ok"), bad_sphere]})
    client.publish("/pfield/obstacles", OBSTACLES, {"obstacles": [dict(BALL, frame_id="blob", type="Blob")]})
    client.publish("/pfield/obstacles", OBSTACLES, {"obstacles": [dict(BALL, frame_id="cup")]})
    markers.wait_for(lambda m: "cup" in [k["ns"] for k in m["markers"]])  # the node read the bad ones first
    results["remaining_before_bad"], results["remaining_after_bad"] = before, remaining(client)
    results["remove_unknown"] = client.call(*REMOVE, {"frame_ids": ["cup", "nope"]})
    results["remove_cup"] = client.call(*REMOVE, {"frame_ids": ["cup"]})
    results["services"] = sorted(map(list, client.node.get_service_names_and_types()))
    results["topics"] = sorted(map(list, client.node.get_topic_names_and_types()))


if __name__ == "__main__":
    run_phases([run])
