"""Client of the node's execute test: ``/pfield/execute_trajectory`` of the real ``/pfield_manager``
(``pfield ros2 node --robot xarm7``) sends a whole-body plan's trajectory to ``trajectory_server.py``, which this
client starts (inside the same network namespace) with the xArm7's joints at the plan's start.

Writes ``$ROS2_TEST_OUT/results.json``; ``tests/transport/test_ros2_execute.py`` asserts on it.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import traceback
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # ros2_helpers
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the seed examples of all tests

import seed_examples as seed
from ros2_helpers.client import BlockingClient
from ros2_helpers.scenario import AUTONOMY, NODE, PLAN

OUT = Path(os.environ["ROS2_TEST_OUT"])
EXECUTE = ("/pfield/execute_trajectory", "potential_fields_interfaces/srv/ExecuteTrajectory")
JOINTS = [f"joint{i}" for i in range(1, 8)]


def main(client: BlockingClient) -> dict[str, Any]:
    results: dict[str, Any] = {}
    results["default_action"] = client.get_parameters(NODE, ["trajectory_controller_action"])
    plan = client.call(*PLAN, seed.parse(seed.PLAN_WHOLE_BODY), timeout=300.0)
    trajectory = plan["joint_trajectory"]
    last = trajectory["points"][-1]
    results["plan"] = {"success": plan["success"], "points": len(trajectory["points"]),
                       "joint_names": trajectory["joint_names"], "last_positions": last["positions"],
                       "duration": last["time_from_start"]["sec"] + 1e-9 * last["time_from_start"]["nanosec"]}
    answer: dict[str, Any] = {}
    in_flight = threading.Event()

    def execute() -> None:
        in_flight.set()
        answer.update(client.call(*EXECUTE, {"trajectory": trajectory}, timeout=120.0))
        in_flight.clear()

    worker = threading.Thread(target=execute)
    worker.start()
    in_flight.wait()
    autonomy = client.call(*AUTONOMY, seed.parse(seed.AUTONOMY_WHOLE_BODY))
    results["autonomy_during_execution"] = {"answered": bool(autonomy["autonomy_vector"]["header"]["frame_id"]),
                                            "execution_still_running": in_flight.is_set()}
    worker.join()
    results["execute"] = answer
    renamed = dict(trajectory, joint_names=[*JOINTS[:-1], "gripper"])
    results["invalid_joints"] = client.call(*EXECUTE, {"trajectory": renamed}, timeout=120.0)
    results["absent"] = client.call(*EXECUTE, {"trajectory": trajectory,
                                              "controller_action": "/absent_controller/follow_joint_trajectory"},
                                    timeout=120.0)
    backwards = dict(trajectory, points=list(reversed(trajectory["points"])))
    results["bad_trajectory"] = client.call(*EXECUTE, {"trajectory": backwards}, timeout=120.0)
    return results


if __name__ == "__main__":
    start = seed.parse(seed.PLAN_WHOLE_BODY)["starting_joint_angles"]
    server = subprocess.Popen([sys.executable, str(Path(__file__).with_name("trajectory_server.py")),
                               *(f"{name}={value}" for name, value in zip(JOINTS, start, strict=True))])
    client = BlockingClient("pfield_execute_test_client")
    try:
        payload = main(client)
    except Exception:
        payload = {"error": traceback.format_exc()}
    finally:
        client.close()
        server.send_signal(signal.SIGINT)
        payload_server = server.wait(30)
    payload["server_returncode"] = payload_server
    (OUT / "results.json").write_text(json.dumps(payload))
