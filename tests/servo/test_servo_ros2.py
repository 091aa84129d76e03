"""Over rclpy in a private network namespace: ``/joint_states`` replaces ``joint_angles``; the MoveIt Servo
configuration of ``--params`` starts ``/pfield_servo``; Joy, a tool-frame twist and a JointJog drive it;
``~/pause_servo`` holds it and resumes it; a stale command stops."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "transport"))

SERVO_FILE = Path(__file__).with_name("data") / "servo_panda.yaml"


@pytest.mark.ros2
@pytest.mark.slow
def test_servo_over_rclpy(tmp_path: Path) -> None:
    from ros2_helpers.support import require_netns, require_ros2_python, run_session

    require_ros2_python()
    require_netns()
    from pfield.robot import RobotModel

    params = tmp_path / "params.yaml"  # Servo's file as its launch files load it, under the servo node's name
    params.write_text(yaml.safe_dump({"servo_node": {"ros__parameters": {
        "moveit_servo": yaml.safe_load(SERVO_FILE.read_text())}}}))
    node = [str(Path(sys.executable).with_name("pfield")), "ros2", "node", "--robot", "panda", "--params", str(params)]
    client = [sys.executable, str(Path(__file__).with_name("servo_ros2_client.py"))]
    process = run_session(node, client, tmp_path / "session", timeout=600)
    assert process.returncode == 0, process.stderr
    out = tmp_path / "session"
    results: dict[str, Any] = json.loads((out / "results.json").read_text())
    log = (out / "node.log").read_text()
    assert "error" not in results, results["error"] + log
    implicit, explicit = results["implicit"]["autonomy_vector"], results["explicit"]["autonomy_vector"]
    assert implicit["header"]["frame_id"] == "world"
    for part in ("linear", "angular"):  # the same joints (the QP's warm start may move the last digits)
        assert implicit["twist"][part] == pytest.approx(explicit["twist"][part], rel=1e-6, abs=1e-7)
    robot = RobotModel.builtin("panda")

    def twist_of(command: dict[str, Any]) -> np.ndarray:
        point = command["points"][0]
        return robot.jacobian(point["positions"]) @ np.array(point["velocities"])

    assert results["joy_command"]["joint_names"] == list(robot.joint_names)
    assert twist_of(results["joy_command"])[2] > 0.0  # spacemouse axis 2: +z
    assert results["timeout_status"]["data"] == 10  # COMMAND_TIMEOUT
    assert results["joy_last"]["points"][0]["velocities"] == [0.0] * 7  # stopped after the stale command
    assert twist_of(results["tool_command"])[2] < 0.0  # tool +z is world -z at the ready pose
    jogged = results["jog_command"]["points"][0]["velocities"]  # control_msgs/JointJog: the wrist alone
    assert jogged[:6] == [0.0] * 6 and 0.25 < jogged[6] <= 0.3
    assert results["paused"]["success"] and results["resumed"]["message"] == "running"  # std_srvs/SetBool
    assert results["hold"]["points"][0]["velocities"] == [0.0] * 7 and results["while_paused"] == 0
    assert results["after_resume"]["points"][0]["velocities"][6] > 0.0
    assert results["params"] == {"publish_period": 0.01, "scale.linear": 0.2, "joint_limit_margins": [0.12]}
    assert "ignored MoveIt Servo parameters pfield does not use" in log and "use_smoothing" in log
