"""Client of the trajectory-client test: pfield's FollowJointTrajectory client (Python API and ``pfield ros2
execute``) against ``trajectory_server.py`` (run as the session's node with the joints ``joint1``–``joint3``).

Writes ``$ROS2_TEST_OUT/results.json``; ``tests/transport/test_trajectory_client.py`` asserts on it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import traceback
from pathlib import Path
from typing import Any

import numpy as np

from pfield.interfaces.std_msgs import Duration
from pfield.planning.retime import retime_joint_path
from pfield.transport.trajectory_client import (
    ExecutionOptions,
    ServerUnavailable,
    TrajectoryClient,
    TrajectoryResult,
)

OUT = Path(os.environ["ROS2_TEST_OUT"])
JOINTS = ["joint1", "joint2", "joint3"]
SLOW = "/slow_controller/follow_joint_trajectory"
PFIELD = str(Path(sys.executable).with_name("pfield"))


def trajectory(names: list[str], start: list[float], end: list[float]) -> Any:
    """A real retimed trajectory (pfield's retimer, 1 rad/s and 2 rad/s² limits) along a straight joint path."""
    path = np.linspace(start, end, 25)
    return retime_joint_path(names, path, np.full(len(names), 1.0), np.full(len(names), 2.0), 0.05)


def summary(result: TrajectoryResult) -> dict[str, Any]:
    return {"outcome": result.outcome.name, "error_code": None if result.error_code is None else int(result.error_code),
            "error_code_name": str(result.error_code), "error_string": result.error_string, "success": result.success,
            "feedback_count": result.feedback_count}


def cli(*args: str) -> dict[str, Any]:
    done = subprocess.run([PFIELD, "ros2", "execute", *args], capture_output=True, text=True, timeout=120,
                          check=False)
    return {"returncode": done.returncode, "stderr": done.stderr[-2000:]}


def simulated() -> dict[str, Any]:
    """A retimed xArm7 move within its URDF velocity limits on the MuJoCo arm (``--sim xarm7``)."""
    from pfield.robot import RobotModel

    robot = RobotModel.builtin("xarm7")
    start = robot.mid_configuration
    end = start + np.array([0.3, -0.2, 0.2, 0.3, -0.2, 0.2, 0.3])
    timed = retime_joint_path(robot.joint_names, np.linspace(start, end, 30), robot.velocity_limits,
                              robot.acceleration_limits, 0.05)
    errors: list[float] = []
    with TrajectoryClient("/sim_controller/follow_joint_trajectory") as client:
        result = client.execute(timed, ExecutionOptions(server_timeout=60.0),
                                feedback=lambda f: errors.append(float(np.abs(f.error).max())))
    return summary(result) | {"max_tracking_error": max(errors), "duration": timed.duration}


def main() -> dict[str, Any]:
    results: dict[str, Any] = {}
    forward = trajectory(JOINTS, [0.0, 0.0, 0.0], [0.6, -0.4, 0.3])
    back = trajectory(JOINTS, [0.6, -0.4, 0.3], [0.0, 0.0, 0.0])
    with TrajectoryClient() as client:
        feedback: list[Any] = []
        result = client.execute(forward, ExecutionOptions(server_timeout=60.0), feedback=feedback.append)
        results["success"] = summary(result) | {
            "duration": forward.duration, "feedback_times": [f.time_from_start for f in feedback],
            "final_actual": feedback[-1].actual.tolist(), "target": forward.positions[-1].tolist(),
            "feedback_joints": list(feedback[-1].joint_names)}
        renamed = trajectory(["joint1", "joint2", "elbow"], [0.6, -0.4, 0.3], [0.0, 0.0, 0.0])
        results["invalid_joints"] = summary(client.execute(renamed))
        first = threading.Event()
        seen: list[float] = []

        def cancel_after_start(value: Any) -> None:
            seen.append(value.time_from_start)
            if value.time_from_start > 0.3 * back.duration:
                first.set()

        execution = client.send(back, feedback=cancel_after_start)
        first.wait(60.0)
        execution.cancel()
        cancelled = execution.result()
        results["cancel"] = summary(cancelled) | {"duration": back.duration,
                                                  "last_feedback": execution.latest_feedback.time_from_start}
        # finish the way back (the arm stopped where it was cancelled; this goal starts there)
        results["after_cancel"] = summary(client.execute(back))
    with TrajectoryClient(SLOW) as slow:
        tolerance = ExecutionOptions(path_tolerance={"joint1": 0.05}, server_timeout=60.0)
        results["path_tolerance"] = summary(slow.execute(forward, tolerance))
        late = ExecutionOptions(goal_time_tolerance=0.1, server_timeout=60.0)
        results["goal_tolerance"] = summary(slow.execute(forward, late))
    results["simulated"] = simulated()
    with TrajectoryClient("/absent_controller/follow_joint_trajectory") as absent:
        try:
            absent.execute(forward, ExecutionOptions(server_timeout=1.0))
            results["absent"] = {"raised": None}
        except ServerUnavailable as error:
            results["absent"] = {"raised": type(error).__name__, "message": str(error)}
    # the CLI: a PlanPath-response-shaped YAML file, a bad one, an absent server
    points = [{"positions": p.tolist(), "velocities": v.tolist(), "accelerations": a.tolist(),
               "time_from_start": Duration.from_seconds(float(t)).model_dump()}
              for p, v, a, t in zip(forward.positions, forward.velocities, forward.accelerations, forward.times,
                                    strict=True)]
    plan_file = OUT / "plan.json"
    plan_file.write_text(json.dumps({"success": True, "joint_trajectory": {"joint_names": JOINTS, "points": points}}))
    results["cli_success"] = cli(str(plan_file), "--path-tolerance", "joint1=0.5")
    wrong = OUT / "wrong.json"
    wrong.write_text(json.dumps({"joint_names": ["a", "b", "c"], "points": points}))
    results["cli_invalid_joints"] = cli(str(wrong))
    unordered = OUT / "unordered.json"
    unordered.write_text(json.dumps({"joint_names": JOINTS, "points": [points[1], points[0]]}))
    results["cli_bad_file"] = cli(str(unordered))
    results["cli_absent"] = cli(str(plan_file), "--action", "/absent_controller/follow_joint_trajectory",
                                "--server-timeout", "1")
    return results


if __name__ == "__main__":
    try:
        payload = main()
    except Exception:
        payload = {"error": traceback.format_exc()}
    (OUT / "results.json").write_text(json.dumps(payload))
