"""Client of ``tests/transport/test_ros2_streaming.py``: joint states and twists to ``streaming_node.py`` (at 50 and
100 Hz, as a driver and an operator would) until the servo's command comes out; writes it to
``$ROS2_TEST_OUT/results.json``."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rclpy.qos import QoSProfile, ReliabilityPolicy

from pfield.interfaces import lookup_type
from pfield.robot import RobotModel
from pfield.transport._ros2_convert import interface_class, to_ros
from ros2_helpers.client import BlockingClient, Inbox
from ros2_helpers.streaming_node import OUT_TOPIC


def _message(type_name: str, data: dict[str, Any]) -> Any:
    return to_ros(lookup_type(type_name).model_validate(data), interface_class(type_name))


def main() -> None:
    robot = RobotModel.builtin("panda")
    client = BlockingClient()
    results: dict[str, Any] = {}
    try:
        commands = Inbox("trajectory_msgs/msg/JointTrajectory")  # volatile, as the servo publishes its commands
        client.node.create_subscription(interface_class("trajectory_msgs/msg/JointTrajectory"), OUT_TOPIC,
                                        commands.receive, QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE))
        state = {"name": list(robot.joint_names), "position": robot.named_configuration("ready").tolist()}
        client.publish("/joint_states", "sensor_msgs/msg/JointState", state)  # waits for the manager's subscription
        client.publish("/pfield_servo/delta_twist_cmds", "geometry_msgs/msg/TwistStamped", {})
        client.publish("/pfield/planning_goal_pose", "geometry_msgs/msg/PoseStamped",  # one of the manager's inputs
                       {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.4, "z": 0.5},
                                                                  "orientation": {"w": 1.0}}})
        states, twists = (client._publishers[topic] for topic in ("/joint_states", "/pfield_servo/delta_twist_cmds"))
        state_message = _message("sensor_msgs/msg/JointState", state)
        twist_message = _message("geometry_msgs/msg/TwistStamped", {"twist": {"linear": {"x": 0.02}}})
        deadline = time.monotonic() + 120.0  # the robot's first fit on a loaded machine
        k = 0
        while not commands.messages and time.monotonic() < deadline:
            if k % 2 == 0:
                states.publish(state_message)
            twists.publish(twist_message)
            k += 1
            time.sleep(0.01)
        results["command"] = commands.wait_for(lambda message: True, timeout=1.0)
    except Exception as error:  # the test prints it with the logs
        results["error"] = repr(error)
    finally:
        client.close()
    (Path(os.environ["ROS2_TEST_OUT"]) / "results.json").write_text(json.dumps(results))


if __name__ == "__main__":
    main()
