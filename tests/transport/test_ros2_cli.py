"""``pfield ros2 node`` refuses a bad ``--ros-args`` parameter with the node's reason (exit code 2), and the
availability checks of the ROS 2 tests fail in CI instead of skipping."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from ros2_helpers import support
from ros2_helpers.support import REPO, require_netns, require_ros2_python, ros_environment


@pytest.mark.ros2
def test_bad_ros_args_parameter_stops_the_node_with_the_reason() -> None:
    require_ros2_python()
    require_netns()
    pfield = str(Path(sys.executable).with_name("pfield"))
    command = ["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "sh", pfield, "ros2", "node",
               "--ros-args", "-p", "max_linear_velocity:=-2.0"]
    process = subprocess.run(command, env=ros_environment(), cwd=REPO, capture_output=True, text=True,
                             timeout=300, check=False)
    assert process.returncode == 2, process.stderr
    assert "error: max_linear_velocity=-2.0: must be > 0" in process.stderr


def test_missing_pieces_fail_in_ci_and_skip_elsewhere(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(support.shutil, "which", lambda name: None)
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match=r"unshare.*CI is set, so this is a failure"):
        support.require_netns()
    monkeypatch.delenv("CI")
    with pytest.raises(pytest.skip.Exception, match="private network namespace"):
        support.require_netns()
    monkeypatch.setattr(support.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(pytest.skip.Exception, match="rclpy is not installed"):
        support.require_ros2_python()
