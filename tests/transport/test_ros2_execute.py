"""``/pfield/execute_trajectory`` on the ROS 2 node: the real ``/pfield_manager`` (``pfield ros2 node --robot
xarm7``) plans a whole-body path (the seed's request) and sends its retimed ``joint_trajectory`` to a real rclpy
FollowJointTrajectory server (``ros2_helpers/trajectory_server.py``), in a private network namespace.
``ros2_helpers/execute_scenario.py`` is the client.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import pytest
from ros2_helpers.support import HELPERS, missing, require_netns, require_ros2_python, run_scenario

pytestmark = [pytest.mark.ros2, pytest.mark.slow]
XARM7_JOINTS = [f"joint{i}" for i in range(1, 8)]


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    require_ros2_python()
    if importlib.util.find_spec("control_msgs") is None:
        missing("control_msgs (ros/control_msgs) is not built: run `make ros2-interfaces`")
    require_netns()
    out = tmp_path_factory.mktemp("ros2_execute")
    node = [str(Path(sys.executable).with_name("pfield")), "ros2", "node", "--robot", "xarm7"]
    return run_scenario(node, [sys.executable, str(HELPERS / "execute_scenario.py")], out)


def test_default_controller_action_parameter(session: dict[str, Any]) -> None:
    assert session["results"]["default_action"] == {
        "trajectory_controller_action": "/joint_trajectory_controller/follow_joint_trajectory"}


def test_plan_then_execute_succeeds(session: dict[str, Any]) -> None:
    results = session["results"]
    assert results["plan"]["success"] and results["plan"]["joint_names"] == XARM7_JOINTS
    assert results["execute"] == {"success": True, "outcome": "SUCCEEDED", "error_code": 0, "error_message": ""}


def test_other_services_answer_while_a_trajectory_runs(session: dict[str, Any]) -> None:
    assert session["results"]["autonomy_during_execution"] == {"answered": True, "execution_still_running": True}


def test_controller_codes_come_back_by_name(session: dict[str, Any]) -> None:
    invalid = session["results"]["invalid_joints"]
    assert (invalid["success"], invalid["outcome"], invalid["error_code"]) == (False, "ABORTED", -2)
    assert "gripper" in invalid["error_message"]


def test_absent_controller_is_a_clear_failure(session: dict[str, Any]) -> None:
    absent = session["results"]["absent"]
    assert (absent["success"], absent["outcome"]) == (False, "")
    assert "no FollowJointTrajectory action server at '/absent_controller/follow_joint_trajectory'" in \
        absent["error_message"]


def test_bad_trajectory_is_refused_naming_the_field(session: dict[str, Any]) -> None:
    bad = session["results"]["bad_trajectory"]
    assert (bad["success"], bad["outcome"]) == (False, "")
    assert bad["error_message"].startswith("trajectory.points[1].time_from_start=")


def test_session_ends_cleanly(session: dict[str, Any]) -> None:
    state = session["session"]
    assert state["client_returncode"] == 0 and not state["node_killed"] and state["shm_left"] == []
    assert session["results"]["server_returncode"] == 0
