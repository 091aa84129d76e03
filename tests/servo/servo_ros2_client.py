"""Client of the rclpy test of ``/joint_states`` and ``/pfield_servo`` (``tests/servo/test_servo_ros2.py``).

Against ``pfield ros2 node --robot panda --params servo.yaml`` (a MoveIt Servo section): publishes the Panda's
joint states as a driver would (reversed joint order plus a finger joint, 50 Hz), calls the whole-body autonomy
vector without ``joint_angles``, drives the servo with a spacemouse ``Joy``, a tool-frame twist and a JointJog
(paused and resumed by ``~/pause_servo``), lets the command go stale, and writes what it saw to
``$ROS2_TEST_OUT/results.json``.
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "transport"))  # ros2_helpers

from rclpy.qos import QoSProfile, ReliabilityPolicy
from ros2_helpers.client import BlockingClient, Inbox
from ros2_helpers.scenario import AUTONOMY, run_phases

from pfield.robot import RobotModel
from pfield.transport._ros2_convert import interface_class, to_ros

ROBOT = RobotModel.builtin("panda")
READY = ROBOT.named_configuration("ready").tolist()
OUT = "/panda_arm_controller/joint_trajectory"
STATUS = "/pfield_servo/status"


def _volatile(client: BlockingClient, topic: str, type_name: str) -> Inbox:
    inbox = Inbox(type_name)
    qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
    client.node.create_subscription(interface_class(type_name), topic, inbox.receive, qos)
    return inbox


class Stream:
    """Publishes one message at a fixed rate from a thread until stopped (a driver, a joystick)."""

    def __init__(self, client: BlockingClient, topic: str, type_name: str, message: dict[str, Any],
                 rate: float) -> None:
        from pfield.interfaces import lookup_type

        client.publish(topic, type_name, message)  # waits for the node's subscription
        self._publisher = client._publishers[topic]
        self._message = to_ros(lookup_type(type_name).model_validate(message), interface_class(type_name))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(1.0 / rate,), daemon=True)
        self._thread.start()

    def _run(self, period: float) -> None:
        stamped = hasattr(self._message, "header")
        while not self._stop.wait(period):
            if stamped:  # dated as a driver dates them: the servo takes a command's age from its stamp
                self._message.header.stamp.sec, self._message.header.stamp.nanosec = divmod(time.time_ns(), 10**9)
            self._publisher.publish(self._message)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


def state_in(client: BlockingClient, results: dict[str, Any]) -> None:
    names = [*reversed(ROBOT.joint_names), "panda_finger_joint1"]
    states = Stream(client, "/joint_states", "sensor_msgs/msg/JointState",
                    {"name": names, "position": [*reversed(READY), 0.02]}, 50.0)
    results["_streams"] = [states]
    client.publish("/pfield/planning_goal_pose", "geometry_msgs/msg/PoseStamped",
                   {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.4, "y": 0.2, "z": 0.4}}})
    request = {"planning_method": "whole_body", "delta_time": 0.02}
    deadline = time.monotonic() + 60.0
    while True:  # until the goal and a joint state have arrived
        implicit = client.call(*AUTONOMY, request)
        if implicit["autonomy_vector"]["header"]["frame_id"] or time.monotonic() > deadline:
            break
        time.sleep(0.1)
    results["implicit"] = implicit
    results["explicit"] = client.call(*AUTONOMY, request | {"joint_angles": READY})


def at_rest(commands: Inbox, quiet: float = 0.3, timeout: float = 30.0) -> dict[str, Any]:
    """The servo's last command once the arm is held still: all velocities zero and nothing more for ``quiet`` s. A
    stopped stream's messages may still wait in the node's queue; the servo dates them by their stamps, so after
    ``quiet`` (> ``incoming_command_timeout``) none of them can move the arm again."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        count = len(commands.messages)
        time.sleep(quiet)
        if commands.messages and len(commands.messages) == count and \
                not any(commands.messages[-1]["points"][0]["velocities"]):
            return commands.messages[-1]
    raise TimeoutError(f"the arm was not held still within {timeout} s")


def joy_drives(client: BlockingClient, results: dict[str, Any]) -> None:
    commands = _volatile(client, OUT, "trajectory_msgs/msg/JointTrajectory")
    status = client.subscribe(STATUS, "std_msgs/msg/Int8")
    joy = Stream(client, "/pfield_servo/joy", "sensor_msgs/msg/Joy",
                 {"axes": [0.0, 0.0, 0.5, 0.0, 0.0, 0.0], "buttons": [0, 0]}, 100.0)
    results["joy_command"] = commands.wait_for(lambda m: any(m["points"][0]["velocities"]), timeout=60.0)
    time.sleep(0.3)
    joy.stop()
    results["timeout_status"] = status.wait_for(lambda m: m["data"] == 10, timeout=30.0)
    results["joy_last"] = at_rest(commands)
    commands.messages.clear()
    twist = Stream(client, "/pfield_servo/delta_twist_cmds", "geometry_msgs/msg/TwistStamped",
                   {"header": {"frame_id": "panda_hand_tcp"}, "twist": {"linear": {"z": 0.02}}}, 100.0)
    results["tool_command"] = commands.wait_for(lambda m: any(m["points"][0]["velocities"]), timeout=60.0)
    twist.stop()
    at_rest(commands)
    commands.messages.clear()
    jog = Stream(client, "/pfield_servo/delta_joint_cmds", "control_msgs/msg/JointJog",
                 {"joint_names": ["panda_joint7"], "velocities": [0.3]}, 100.0)
    results["jog_command"] = commands.wait_for(lambda m: m["points"][0]["velocities"][6] > 0.25, timeout=60.0)
    results["paused"] = client.call("/pfield_servo/pause_servo", "std_srvs/srv/SetBool", {"data": True})
    results["hold"] = commands.wait_for(lambda m: not any(m["points"][0]["velocities"]), timeout=30.0)
    commands.messages.clear()
    time.sleep(0.5)  # the jog streams on: nothing goes out while paused
    results["while_paused"] = len(commands.messages)
    results["resumed"] = client.call("/pfield_servo/pause_servo", "std_srvs/srv/SetBool", {"data": False})
    results["after_resume"] = commands.wait_for(lambda m: m["points"][0]["velocities"][6] > 0.0, timeout=30.0)
    jog.stop()
    results["params"] = client.get_parameters("/pfield_servo", ["publish_period", "scale.linear",
                                                                "joint_limit_margins"])
    for stream in results.pop("_streams"):
        stream.stop()


if __name__ == "__main__":
    run_phases([state_in, joy_drives])
