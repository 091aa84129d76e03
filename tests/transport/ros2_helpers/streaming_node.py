"""Node of ``tests/transport/test_ros2_streaming.py``: ``/pfield_manager`` and ``/pfield_servo`` on one
:class:`~pfield.transport.ros2.Ros2Host`, as ``pfield ros2 node`` hosts them.

Records the threads in which the servo's twist handler, the manager's joint-state handler (which the servo's
``/joint_states`` subscription feeds) and the manager's goal handler ran, and every
subscription's QoS depth; writes them to ``$ROS2_TEST_OUT/host.json`` when SIGINT stops it.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.node.servo_node import ServoNode
from pfield.robot import RobotModel
from pfield.shared_control.servo_config import ServoConfig
from pfield.transport.ros2 import Ros2Host

OUT_TOPIC = "/arm_controller/joint_trajectory"


def main() -> None:
    robot = RobotModel.builtin("panda")
    manager = ManagerNode(Bus(), robot)
    servo = ServoNode(manager.bus, manager, ServoConfig(command_out_topic=OUT_TOPIC))
    threads: dict[str, set[str]] = {"servo": set(), "joint_states": set(), "manager": set()}

    def recorded(key: str, handler: Callable[[Any], None]) -> Callable[[Any], None]:
        def handle(message: Any) -> None:
            threads[key].add(threading.current_thread().name)
            handler(message)

        return handle

    servo.on_twist = recorded("servo", servo.on_twist)  # type: ignore[method-assign]
    manager.on_joint_states = recorded("joint_states", manager.on_joint_states)  # type: ignore[method-assign]
    manager.on_goal = recorded("manager", manager.on_goal)  # type: ignore[method-assign]
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    switch_before = sys.getswitchinterval()
    with Ros2Host([manager, servo]) as host:
        depths = {f"{adapter.node.name} {subscription.topic_name}": subscription.qos_profile.depth
                  for adapter in host._adapters for subscription in adapter.ros_node.subscriptions}
        switch_interval = sys.getswitchinterval()
        print("host up", flush=True)
        stop.wait()
    result = {"threads": {key: sorted(names) for key, names in threads.items()}, "depths": depths,
              "switch_interval": [switch_before, switch_interval, sys.getswitchinterval()]}
    (Path(os.environ["ROS2_TEST_OUT"]) / "host.json").write_text(json.dumps(result))


if __name__ == "__main__":
    main()
