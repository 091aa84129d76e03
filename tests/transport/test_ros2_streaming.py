"""The servo over rclpy in a private network namespace, with the tests' MuJoCo arm (``tests/servo/sim_arm.py``).

* README's "Drive a robot" executes a plan through the FollowJointTrajectory action and then streams 2 s of tool-frame
  twists: ``streaming_teleop.py`` does that :data:`~ros2_helpers.streaming_teleop.SESSIONS` times against one real
  ``pfield ros2 node`` (README's servo configuration), and in every session the servo answers the stream with
  commands out while it lasts.
* ``pfield.transport.ros2``: the servo's inputs are handled in its own thread (not the shared executor's workers)
  and keep only the latest message (depth 1).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

HELPERS = Path(__file__).resolve().parent / "ros2_helpers"
REPO = Path(__file__).resolve().parents[2]


@pytest.mark.ros2
@pytest.mark.slow
def test_the_servo_answers_teleop_after_every_trajectory_execution(tmp_path: Path) -> None:
    from ros2_helpers.streaming_teleop import SESSIONS, TWISTS
    from ros2_helpers.support import require_netns, require_ros2_python, run_scenario

    require_ros2_python()
    require_netns()
    node = [str(Path(sys.executable).with_name("pfield")), "ros2", "node", "--robot", "panda", "--params",
            str(REPO / "ros" / "config" / "pfield_servo.yaml")]
    out = tmp_path / "session"
    seen = run_scenario(node, [sys.executable, str(HELPERS / "streaming_teleop.py")], out)
    assert seen["session"]["node_returncode"] == 0, seen["logs"]["node.log"]
    sessions = seen["results"]["sessions"]
    assert len(sessions) == SESSIONS, seen["logs"]["client.log"]
    for index, session in enumerate(sessions):
        assert session["execution"] == "SUCCEEDED (SUCCESSFUL)", (index, session)
        # each of the stream's twists is stepped as it is read: commands come out while the twists come, and the
        # stop after them (the arm had just been moved by the trajectory, the servo idle meanwhile)
        assert session["commands"] >= 2, (index, sessions, seen["logs"]["node.log"][-3000:])
        assert session["first_after_s"] < session["stream_s"], (index, sessions)
    assert all(session["stream_s"] >= 0.01 * TWISTS for session in sessions)  # each stream ran its 2 s


@pytest.mark.ros2
@pytest.mark.slow
def test_the_servo_spins_on_its_own_executor_and_keeps_its_latest_inputs(tmp_path: Path) -> None:
    """``pfield.transport.ros2``: the servo's inputs are handled in its own thread (not the shared executor's workers,
    where the manager's are) and keep only the latest message (depth 1), so a command never waits behind other nodes'
    callbacks or a backlog of older commands; ``/joint_states`` is among them (the servo subscribes it for the
    manager: ``ManagerNode.joint_states_subscriber``); the servo still answers with a command out."""
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
    assert host["threads"]["joint_states"] == ["pfield-ros2-pfield_servo"]
    assert host["threads"]["manager"] and "pfield-ros2-pfield_servo" not in host["threads"]["manager"]
    depths = host["depths"]
    assert depths["/pfield_servo /pfield_servo/delta_twist_cmds"] == 1
    assert depths["/pfield_servo /pfield_servo/joy"] == 1
    assert depths["/pfield_servo /joint_states"] == 1 and "/pfield_manager /joint_states" not in depths
    assert depths["/pfield_manager /pfield/planning_goal_pose"] > 1  # the other nodes keep their queues
    # while the servo runs, a thread waiting for the GIL gets it within 0.5 ms (5 ms by default), and after it as before
    from pfield.transport.ros2 import STREAMING_SWITCH_INTERVAL

    before, during, after = host["switch_interval"]
    assert before == after == 0.005 and during == STREAMING_SWITCH_INTERVAL
    command = seen["results"]["command"]
    assert command["joint_names"] == list(RobotModel.builtin("panda").joint_names)
    assert any(command["points"][0]["velocities"])


def test_overlapping_streaming_hosts_restore_the_switch_interval_when_the_last_stops() -> None:
    from ros2_helpers.support import require_ros2_python

    require_ros2_python()
    from pfield.transport import ros2

    before = sys.getswitchinterval()
    ros2._streaming_started()
    ros2._streaming_started()  # a second host starts while the first runs
    ros2._streaming_stopped()  # the first stops: the second still streams
    assert sys.getswitchinterval() == ros2.STREAMING_SWITCH_INTERVAL
    ros2._streaming_stopped()
    assert sys.getswitchinterval() == before
