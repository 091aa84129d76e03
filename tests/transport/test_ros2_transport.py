"""pfield.transport.ros2 end to end with a test-only node: two real rclpy processes in a private network.

``ros2_helpers/echo_node.py`` implements the node contract without planners; ``echo_scenario.py`` is the
second process (a real rclpy client). One session serves every test of this module.
"""

from __future__ import annotations

import json
import math
from typing import Any

import pytest
from ros2_helpers.support import HELPERS, require_netns, require_ros2_python, run_session

pytestmark = pytest.mark.ros2


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    require_ros2_python()
    require_netns()
    import sys

    out = tmp_path_factory.mktemp("ros2_echo")
    process = run_session([sys.executable, str(HELPERS / "echo_node.py")],
                          [sys.executable, str(HELPERS / "echo_scenario.py")], out)
    assert process.returncode == 0, process.stderr
    logs = {name: (out / name).read_text() for name in ("node.log", "client.log")}
    results = json.loads((out / "results.json").read_text()) if (out / "results.json").exists() else {}
    assert "error" not in results, results["error"] + "\n" + logs["node.log"]
    return {"results": results, "session": json.loads((out / "session.json").read_text()), "logs": logs}


def _norm(vector: dict[str, float]) -> float:
    return math.sqrt(vector["x"] ** 2 + vector["y"] ** 2 + vector["z"] ** 2)


def test_services_and_topics_have_the_ros_types(session: dict[str, Any]) -> None:
    services = dict((name, types) for name, types in session["results"]["services"])
    assert services["/pfield/plan_path"] == ["potential_fields_interfaces/srv/PlanPath"]
    assert services["/pfield/compute_autonomy_vector"] == ["potential_fields_interfaces/srv/ComputeAutonomyVector"]
    assert services["/pfield_manager/set_parameters"] == ["rcl_interfaces/srv/SetParameters"]
    topics = dict((name, types) for name, types in session["results"]["topics"])
    assert topics["/pfield/obstacles"] == ["potential_fields_interfaces/msg/ObstacleArray"]
    assert topics["/pfield/markers"] == ["visualization_msgs/msg/MarkerArray"]
    assert topics["/pfield/planned_path"] == ["nav_msgs/msg/Path"]


def test_subscription_publication_and_tick(session: dict[str, Any]) -> None:
    results = session["results"]
    assert [m["ns"] for m in results["markers_two"]["markers"]] == ["ball", "dyn"]
    assert [m["ns"] for m in results["dynamic_expired"]["markers"]] == ["ball"]  # expired by the node's tick


def test_autonomy_vector_service(session: dict[str, Any]) -> None:
    results = session["results"]
    twist = results["autonomy"]["autonomy_vector"]["twist"]["linear"]
    # echo node: gain 1 * (goal - query) = (0.2, 0.1, 0.05), limited to max_linear_velocity 0.05
    direction = [0.2, 0.1, 0.05]
    scale = 0.05 / math.sqrt(sum(c * c for c in direction))
    assert [twist["x"], twist["y"], twist["z"]] == pytest.approx([c * scale for c in direction], rel=1e-9)
    # a request the node refuses and whose response has no error field: the default (zero) response
    assert results["autonomy_bad_frame"] == {"autonomy_vector": {"header": {"stamp": {"sec": 0, "nanosec": 0},
                                             "frame_id": ""}, "twist": {"linear": {"x": 0.0, "y": 0.0, "z": 0.0},
                                                                        "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}}}
    assert "query_pose.header.frame_id='map'" in session["logs"]["node.log"]


def test_long_plan_does_not_block_autonomy_calls(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["plan"]["success"] is True
    assert results["autonomy_answers_during_plan"] >= 1
    poses = results["planned_path"]["poses"]
    assert len(poses) == 20 and poses[-1]["pose"]["position"]["x"] == 1.0 and poses[-1]["pose"]["position"]["y"] == 0.5
    assert results["plan"]["end_effector_path"] == results["planned_path"]


def test_bad_service_request_reports_the_reason(session: dict[str, Any]) -> None:
    failed = session["results"]["plan_bad_method"]
    assert failed["success"] is False
    assert failed["error_message"] == "planning_method='sideways': task_space or whole_body"
    unknown = session["results"]["remove_unknown"]
    assert unknown == {"success": False, "message": "frame_ids=['nope']: unknown obstacle ids", "remaining": []}
    # all or nothing: "cup" was not removed by the failed call
    assert session["results"]["remove_cup"] == {"success": True, "message": "removed", "remaining": ["ball"]}


def test_parameters_validated_by_the_node(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["set_ok"] == [[True, ""], [True, ""], [True, ""]]
    assert results["set_bad"] == [[False, "max_linear_velocity=-1.0: must be a finite number >= 0"]]
    assert results["set_wrong_type"][0][0] is False
    assert results["set_undeclared"][0][0] is False
    # integers given for double parameters are widened, as a ros2 CLI user expects
    assert results["params_after"] == {"max_linear_velocity": 0.02, "gain": 2.0, "weights": [3.0, 4.0]}
    twist = results["autonomy_after_set"]["autonomy_vector"]["twist"]["linear"]
    assert _norm(twist) == pytest.approx(0.02, rel=1e-9)


def test_bad_obstacles_leave_the_state_intact(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["remaining_before_bad"] == ["ball"]
    # the message with one bad obstacle was refused as a whole ("ok" not added), the next one accepted
    assert results["remaining_after_bad"] == ["ball", "cup"]
    log = session["logs"]["node.log"]
    assert "obstacles[1].radius=-1.0: must be > 0" in log and "obstacles[0].type='Blob'" in log


def test_clean_shutdown(session: dict[str, Any]) -> None:
    # nothing left in the session's private /dev/shm (Fast DDS segments outlive an aborted process)
    assert session["session"] == {"client_returncode": 0, "node_returncode": 0, "node_died_early": False,
                                  "node_killed": False, "shm_left": []}
    assert "terminate called" not in session["logs"]["node.log"]
