"""Client of ``tests/transport/test_ros2_streaming.py``: teleop right after a trajectory execution, as README's "Drive
a robot" does it, :data:`SESSIONS` times against one ``pfield ros2 node`` with the servo.

Starts the tests' arm (``tests/servo/sim_arm.py``: the Panda in MuJoCo publishing ``/joint_states``, following the
servo's commands on :data:`OUT_TOPIC` and serving FollowJointTrajectory) in this network namespace, then streams
twists until the servo's first command comes back (discovery both ways, once). Each session then starts from rest:
a FollowJointTrajectory goal from the measured joints (joint 1 out by ±:data:`SWING` rad and back in
:data:`DURATION` s) through :class:`~pfield.transport.trajectory_client.TrajectoryClient` on a context of its own
(README's ``python`` block), and at once :data:`TWISTS` tool-frame twists at 100 Hz (README's ``ros2 topic pub -r 100
-t 200``). Writes ``$ROS2_TEST_OUT/results.json``: per session the execution's outcome, the stream's duration, the
commands out received from its first twist to :data:`AFTER` s after its last, and when the first came.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rclpy.qos import QoSProfile, ReliabilityPolicy

from pfield.interfaces import trajectory_msgs
from pfield.robot import RobotModel
from pfield.transport._ros2_convert import interface_class
from pfield.transport.trajectory_client import TrajectoryClient
from ros2_helpers.client import BlockingClient

REPO = Path(__file__).resolve().parents[3]
OUT_TOPIC = "/panda_arm_controller/joint_trajectory"
ACTION = "/panda_arm_controller/follow_joint_trajectory"
TWIST_TOPIC = "/pfield_servo/delta_twist_cmds"
SESSIONS = 5
TWISTS = 200
"""Twists per session at 100 Hz (README's ``-r 100 -t 200``: 2 s)."""
SWING = 0.15
"""rad: joint 1's excursion in each session's trajectory."""
DURATION = 1.0
"""s: the trajectory's duration."""
AFTER = 1.0
"""s after the last twist a command out still counts (the servo's stop after ``incoming_command_timeout``)."""
RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


def _latest_joints(latest: list[Any], names: list[str], timeout: float) -> list[float]:
    """The arm's joints from the next ``/joint_states`` that ``latest`` (a subscription's list, kept for the whole
    scenario: one reader to discover, not one per session) receives, in ``names``' order."""
    latest.clear()
    deadline = time.monotonic() + timeout
    while not latest and time.monotonic() < deadline:
        time.sleep(0.02)
    if not latest:
        raise TimeoutError(f"no /joint_states within {timeout} s")
    message = latest[-1]
    return [float(message.position[list(message.name).index(name)]) for name in names]


def _trajectory(names: list[str], start: list[float], sign: float) -> trajectory_msgs.JointTrajectory:
    """Joint 1 out by ``sign * SWING`` and back, q1(t) = q1(0) + sign SWING (1 - cos 2πt/T) / 2, 51 samples."""
    points = []
    for k in range(51):
        t = DURATION * k / 50
        phase = 2 * math.pi * t / DURATION
        positions, velocities = list(start), [0.0] * len(start)
        positions[0] += sign * SWING * 0.5 * (1 - math.cos(phase))
        velocities[0] = sign * SWING * 0.5 * math.sin(phase) * 2 * math.pi / DURATION
        points.append({"positions": positions, "velocities": velocities,
                       "time_from_start": {"sec": int(t), "nanosec": round((t - int(t)) * 1e9)}})
    return trajectory_msgs.JointTrajectory.model_validate({"joint_names": names, "points": points})


def _stream(publisher: Any, twist: Any, arrivals: list[float]) -> dict[str, Any]:
    """:data:`TWISTS` twists at 100 Hz (as ``ros2 topic pub -r 100`` sends them: a sleep of one period after each);
    the commands out that arrived from the first twist to :data:`AFTER` s after the last."""
    before = len(arrivals)
    begin = time.monotonic()
    for _ in range(TWISTS):
        publisher.publish(twist)
        time.sleep(0.01)
    end = time.monotonic()
    time.sleep(AFTER)
    during = [t for t in arrivals[before:] if begin <= t <= end + AFTER]
    first = (min(during) - begin) if during else None
    return {"stream_s": end - begin, "commands": len(during), "first_after_s": first}


def main() -> None:
    out = Path(os.environ["ROS2_TEST_OUT"])
    names = list(RobotModel.builtin("panda").joint_names)
    arm = subprocess.Popen([sys.executable, str(REPO / "tests" / "servo" / "sim_arm.py"), "panda", "--out",
                            str(out / "sim_arm.json"), "--command-topic", OUT_TOPIC, "--action", ACTION],
                           stdout=(out / "sim_arm.log").open("wb"), stderr=subprocess.STDOUT)
    results: dict[str, Any] = {"sessions": []}
    client = BlockingClient("streaming_teleop")
    arrivals: list[float] = []
    try:
        client.node.create_subscription(interface_class("trajectory_msgs/msg/JointTrajectory"), OUT_TOPIC,
                                        lambda _: arrivals.append(time.monotonic()), RELIABLE)
        states: list[Any] = []
        client.node.create_subscription(interface_class("sensor_msgs/msg/JointState"), "/joint_states",
                                        states.append, RELIABLE)
        twist_class = interface_class("geometry_msgs/msg/TwistStamped")
        publisher = client.node.create_publisher(twist_class, TWIST_TOPIC, RELIABLE)
        twist = twist_class()
        twist.header.frame_id = "panda_hand_tcp"
        twist.twist.linear.z = -0.05  # the tool up (a zero twist would command nothing)
        deadline = time.monotonic() + 180.0  # the node's start and the robot's first fit on a loaded machine
        while not arrivals and time.monotonic() < deadline:
            publisher.publish(twist)
            time.sleep(0.01)
        if not arrivals:
            raise TimeoutError("the servo sent no command within 180 s of twists")
        for session in range(SESSIONS):
            time.sleep(2 * AFTER)  # the servo has stopped: each session starts from rest
            start = _latest_joints(states, names, timeout=60.0)
            with TrajectoryClient(ACTION) as controller:
                outcome = controller.execute(_trajectory(names, start, 1.0 if session % 2 == 0 else -1.0))
            twist.twist.linear.z = 0.05 * (1 if session % 2 == 0 else -1)  # the tool down, then up again
            record = {"execution": outcome.describe(), **_stream(publisher, twist, arrivals)}
            results["sessions"].append(record)
            print(f"session {session}: {record}", flush=True)
    except Exception as error:  # the test prints it with the logs
        results["error"] = repr(error)
    finally:
        client.close()
        arm.send_signal(signal.SIGINT)
        arm.wait(30)
    (out / "results.json").write_text(json.dumps(results))


if __name__ == "__main__":
    main()
