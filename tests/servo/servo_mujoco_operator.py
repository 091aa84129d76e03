"""Client of ``tests/servo/test_servo_mujoco.py``: a scripted operator steering the Panda in MuJoCo through
``/pfield_servo``, over ROS 2 topics only.

Against ``pfield ros2 node --robot panda --params SERVO.yaml`` (``SERVO_MUJOCO`` in the environment: JSON with
``sphere`` [x, y, z, r], ``twist`` [vx, vy, vz] m/s, ``seconds``, ``command_topic``, ``command_type``). Starts
``sim_arm.py`` (the arm in MuJoCo: ``/joint_states`` out, the servo's commands in), tells the node about the sphere
(``/pfield/obstacles``; the same sphere is in the simulation), streams the fixed-frame twist at 100 Hz for
``seconds``, goes silent until the arm has stood still for a second (:func:`settle`; at least 2 s, longer than
``incoming_command_timeout``), stops the arm and writes the arm's
report, the status codes seen (with the seconds since the twist began) and the phase times to
``$ROS2_TEST_OUT/results.json``.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "transport"))  # ros2_helpers
sys.path.insert(0, str(Path(__file__).resolve().parent))

from ros2_helpers.client import LATCHED, BlockingClient
from ros2_helpers.scenario import run_phases
from sensor_msgs.msg import JointState
from servo_ros2_client import Stream
from std_msgs.msg import Int8

SETUP: dict[str, Any] = json.loads(os.environ.get("SERVO_MUJOCO", "{}"))
OUT = Path(os.environ.get("ROS2_TEST_OUT", "."))
STATUS = "/pfield_servo/status"
ARM: list[subprocess.Popen[bytes]] = []


def arm_up(client: BlockingClient, results: dict[str, Any]) -> None:
    x, y, z, r = SETUP["sphere"]
    arm = subprocess.Popen([sys.executable, str(Path(__file__).with_name("sim_arm.py")), "panda",
                            "--out", str(OUT / "arm.json"), "--sphere", f"{x},{y},{z},{r}",
                            "--command-topic", SETUP["command_topic"], "--command-type", SETUP["command_type"]],
                           stdout=(OUT / "arm.log").open("wb"), stderr=subprocess.STDOUT)
    ARM.append(arm)
    arrived = threading.Event()
    client.node.create_subscription(JointState, "/joint_states", lambda m: arrived.set(), 10)
    if not arrived.wait(120.0):
        raise TimeoutError("the simulated arm published no /joint_states within 120 s (arm.log)")
    client.publish("/pfield/obstacles", "potential_fields_interfaces/msg/ObstacleArray", {
        "header": {"frame_id": "world"},
        "obstacles": [{"frame_id": "ball", "type": "Sphere", "group": "Static", "radius": r,
                       "pose": {"position": {"x": x, "y": y, "z": z}, "orientation": {"w": 1.0}}}]})
    time.sleep(1.0)  # the obstacle message is applied by the node's executor


def moved_by_controller(client: BlockingClient, results: dict[str, Any]) -> None:
    """With ``move_first`` (rad per joint): the arm's FollowJointTrajectory action moves it that far in 2 s while
    the servo idles, as a plan's execution would; then the servo's first command must start from there."""
    if not SETUP.get("move_first"):
        return
    import numpy as np
    from trajectory_msgs.msg import JointTrajectory

    from pfield.robot import RobotModel
    from pfield.transport.trajectory_client import TrajectoryClient

    robot = RobotModel.builtin("panda")
    start = robot.named_configuration("ready")
    end = start + np.array(SETUP["move_first"])
    trajectory = {"joint_names": list(robot.joint_names), "points": [
        {"positions": start.tolist(), "time_from_start": {"sec": 0}},
        {"positions": end.tolist(), "time_from_start": {"sec": 2}}]}
    from pfield.interfaces.trajectory_msgs import JointTrajectory as Model

    with TrajectoryClient("/panda_arm_controller/follow_joint_trajectory") as controller:
        results["moved"] = controller.execute(Model.model_validate(trajectory)).describe()
    results["moved_to"] = end.tolist()
    first: list[list[float]] = []
    client.node.create_subscription(JointTrajectory, SETUP["command_topic"],
                                    lambda m: first.append(list(m.points[0].positions)) if not first else None, 1)
    results["_first"] = first


def operator(client: BlockingClient, results: dict[str, Any]) -> None:
    start = time.monotonic()
    seen: list[tuple[float, int]] = []
    client.node.create_subscription(Int8, STATUS, lambda m: seen.append((round(time.monotonic() - start, 3),
                                                                            int(m.data))), LATCHED)
    vx, vy, vz = SETUP["twist"]
    twist = Stream(client, "/pfield_servo/delta_twist_cmds", "geometry_msgs/msg/TwistStamped",
                   {"header": {"frame_id": "world"}, "twist": {"linear": {"x": vx, "y": vy, "z": vz}}}, 100.0)
    start = time.monotonic()
    time.sleep(SETUP["seconds"])
    twist.stop()
    results["stopped_at"] = round(time.monotonic() - start, 3)
    results["settled_after"] = settle(client)
    results["statuses"] = seen
    if "_first" in results:
        results["first_command"] = results.pop("_first")[:1]
    arm = ARM.pop()
    arm.send_signal(signal.SIGINT)
    results["arm_returncode"] = arm.wait(30)
    results["arm"] = json.loads((OUT / "arm.json").read_text())


def settle(client: BlockingClient, still: float = 1.0, at_least: float = 2.0, timeout: float = 30.0) -> float | None:
    """Seconds after the twist went silent until the arm has stood still (every joint slower than 0.005 rad/s on
    ``/joint_states``) for ``still`` s, and at least ``at_least`` s (longer than ``incoming_command_timeout``); None
    when it never did within ``timeout``. Waiting on the arm, not a fixed time: on a loaded machine the physics and
    the commands run late, and a fixed wait would read the arm mid-stop."""
    begin = time.monotonic()
    since: float | None = None  # when the arm was last seen starting to stand still

    def on_state(message: JointState) -> None:
        nonlocal since
        moving = any(abs(v) >= 0.005 for v in message.velocity)
        since = None if moving else (since or time.monotonic())

    subscription = client.node.create_subscription(JointState, "/joint_states", on_state, 10)
    try:
        while (now := time.monotonic()) - begin < timeout:
            if now - begin >= at_least and since is not None and now - since >= still:
                return round(now - begin, 3)
            time.sleep(0.05)
        return None
    finally:
        client.node.destroy_subscription(subscription)


if __name__ == "__main__":
    try:
        run_phases([arm_up, moved_by_controller, operator])
    finally:
        for left in ARM:  # a phase failed: stop the arm anyway
            left.send_signal(signal.SIGINT)
            left.wait(30)
