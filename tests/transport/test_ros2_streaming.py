"""A node that streams commands (the servo) on its own executor, over rclpy in a private network namespace.

``pfield.transport.ros2``: its inputs are handled in its own thread (not the shared executor's workers, where the
manager's are) and keep only the latest message (depth 1), so a command never waits behind other nodes' callbacks or
a backlog of older commands; the servo still answers with a command out.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

HELPERS = Path(__file__).resolve().parent / "ros2_helpers"


@pytest.mark.ros2
@pytest.mark.slow
def test_the_servo_spins_on_its_own_executor_and_keeps_its_latest_inputs(tmp_path: Path) -> None:
    from ros2_helpers.support import require_netns, require_ros2_python, run_scenario

    require_ros2_python()
    require_netns()
    from pfield.robot import RobotModel

    out = tmp_path / "session"
    seen = run_scenario([sys.executable, str(HELPERS / "streaming_node.py")],
                        [sys.executable, str(HELPERS / "streaming_client.py")], out)
    assert seen["session"]["node_returncode"] == 0, seen["logs"]["node.log"]
    host = json.loads((out / "host.json").read_text())
    assert host["threads"]["servo"] == ["pfield-ros2-pfield_servo"]
    assert host["threads"]["manager"] and "pfield-ros2-pfield_servo" not in host["threads"]["manager"]
    depths = host["depths"]
    assert depths["/pfield_servo /pfield_servo/delta_twist_cmds"] == 1
    assert depths["/pfield_servo /pfield_servo/joy"] == 1
    assert depths["/pfield_manager /joint_states"] > 1  # the other nodes keep their queues
    command = seen["results"]["command"]
    assert command["joint_names"] == list(RobotModel.builtin("panda").joint_names)
    assert any(command["points"][0]["velocities"])
