"""ROS 2 transport: round trips of ``/pfield/compute_autonomy_vector`` and ``/pfield/compute_assistance``
over rclpy (Fast DDS).

``run`` starts a private network namespace (``unshare -n``, loopback only, localhost discovery, UDPv4
transport as in the tests) in which this module runs again with ``--inner``: it starts ``pfield ros2
node`` (the real ``/pfield_manager``, xArm7, the seed's goal) as one process and times, from this
second process, blocking ``Client.call`` round trips of the seed's task-space and whole-body requests and
of a task-space ``ComputeAssistance`` request with an operator command.
The figure includes both conversions (rclpy <-> pydantic), the handler and Fast DDS on loopback. The
issue's target is p50 ≤ 2 ms; the C++ original has no comparable figure. Without ``unshare`` or the
``ros2`` extra the rows are skipped with a note.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from benchmarks._common import BenchRow, ros2_session

SECTION = "ros2"
TARGET_P50_MS = 2.0
"""Both services' p50 target (ms)."""
_POSE = {"position": {"x": 0.3, "y": 0.1, "z": 0.35}, "orientation": {"x": 0.707, "y": 0.0, "z": 0.707, "w": 0.0}}
_GOAL = {"header": {"frame_id": "world"},
         "pose": {"position": {"x": 0.5, "y": 0.2, "z": 0.4}, "orientation": _POSE["orientation"]}}
REQUESTS = {  # the seed document's two ComputeAutonomyVector examples
    "task_space": {"query_pose": {"header": {"frame_id": "world"}, "pose": _POSE}, "delta_time": 0.02,
                   "planning_method": "task_space"},
    "whole_body": {"query_pose": {"header": {"frame_id": "world"}, "pose": _POSE},
                   "joint_angles": [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], "prev_joint_velocities": [0.0] * 7,
                   "delta_time": 0.02, "planning_method": "whole_body"},
}
ASSISTANCE = {"query_pose": {"header": {"frame_id": "world"}, "pose": _POSE}, "delta_time": 0.02,
              "user_command": {"twist": {"linear": {"x": 0.02}}}}
SERVICES = {name: ("ComputeAutonomyVector", "/pfield/compute_autonomy_vector", request)
            for name, request in REQUESTS.items()}
SERVICES["assistance"] = ("ComputeAssistance", "/pfield/compute_assistance", ASSISTANCE)
ENVIRONMENT = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": "58",
               "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4", "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"}


def _measure(calls: int) -> dict[str, list[float]]:
    """Inside the namespace: start the node, time ``calls`` round trips per request, stop the node."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node as RclpyNode

    import pfield.interfaces.all  # noqa: F401
    from pfield.interfaces import lookup_type
    from pfield.transport._ros2_convert import interface_class, to_ros

    pfield_cli = str(Path(sys.executable).with_name("pfield"))
    node = subprocess.Popen([pfield_cli, "ros2", "node", "--log-level", "warning"], stdout=subprocess.DEVNULL)
    context = Context()
    rclpy.init(context=context)
    client_node = RclpyNode("pfield_bench_client", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(client_node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    samples: dict[str, list[float]] = {}
    try:
        goal_class = interface_class("geometry_msgs/msg/PoseStamped")
        goal = to_ros(lookup_type("geometry_msgs/msg/PoseStamped").model_validate(_GOAL), goal_class)
        publisher = client_node.create_publisher(goal_class, "/pfield/planning_goal_pose", 10)
        clients = {}
        for kind, service_name, _ in SERVICES.values():
            service = f"potential_fields_interfaces/srv/{kind}"
            clients[kind] = client_node.create_client(interface_class(service), service_name)
            if not clients[kind].wait_for_service(timeout_sec=120.0):
                raise RuntimeError("pfield ros2 node did not come up")
        while publisher.get_subscription_count() == 0:
            time.sleep(0.01)
        publisher.publish(goal)
        for name, (kind, _, request) in SERVICES.items():
            service, client = f"potential_fields_interfaces/srv/{kind}", clients[kind]
            message = to_ros(lookup_type(f"{service}_Request").model_validate(request),
                             interface_class(f"{service}_Request"))
            for _ in range(20):  # warm-up: compiled kernels, discovery, first allocations
                answer = client.call(message, timeout_sec=30.0)
            # a refused request answers the default response (empty frame): then this times the error path
            samples[f"{name}:answered" if answer.autonomy_vector.header.frame_id else f"{name}:refused"] = []
            samples[name] = []
            for _ in range(calls):
                start = time.perf_counter()
                client.call(message, timeout_sec=30.0)
                samples[name].append(time.perf_counter() - start)
    finally:
        executor.shutdown()
        spinner.join()
        client_node.destroy_node()
        rclpy.shutdown(context=context)
        node.send_signal(signal.SIGINT)
        node.wait(30)
    return samples


def _unavailable(reason: str) -> list[BenchRow]:
    return [BenchRow(SECTION, f"{_service(name)} rclpy round trip ({name}) p50", float("nan"), "ms",
                     target=TARGET_P50_MS, note=f"not measured: {reason}") for name in SERVICES]


def _service(name: str) -> str:
    return SERVICES[name][1].rsplit("/", 1)[-1]


def run(quick: bool) -> list[BenchRow]:
    """p50 and p99 of the rclpy round trip for both seed requests (ms)."""
    calls = 200 if quick else 2000
    session = ros2_session("benchmarks.bench_ros2", ["--inner", str(calls)], ENVIRONMENT, 600)
    if isinstance(session, str):
        return _unavailable(session)
    samples: dict[str, list[float]] = session
    repo = Path(__file__).resolve().parents[1]
    http = _http_figures(repo / "benchmarks" / "results" / "bench_http.json")
    rows = []
    for name, values in samples.items():
        if ":" in name:
            continue
        note = f"{len(values)} calls, seed request, Fast DDS UDPv4 loopback, node in another process"
        if f"{name}:refused" in samples:
            note += "; the node REFUSED this request (error path timed, see node log)"
        for quantile, fraction in (("p50", 0.5), ("p99", 0.99)):
            shown = quantile in http and name in REQUESTS  # bench_http times the autonomy request
            http_note = f"; HTTP {quantile} {http[quantile]:.3g} ms (bench_http)" if shown else ""
            rows.append(BenchRow(SECTION, f"{_service(name)} rclpy round trip ({name}) {quantile}",
                                 1e3 * float(np.percentile(values, 100 * fraction)), "ms",
                                 target=TARGET_P50_MS if quantile == "p50" else None, note=note + http_note))
    return rows + _trajectory_rows(quick)


# ---- trajectories out: pfield's FollowJointTrajectory client against the test action server ----------------
TRAJECTORY_SERVER = Path(__file__).resolve().parents[1] / "tests/transport/ros2_helpers/trajectory_server.py"
"""The rclpy FollowJointTrajectory server of the tests (a kinematic arm sampled every 10 ms)."""


def _measure_trajectories(goals: int) -> dict[str, list[float]]:
    """Inside the namespace: ``goals`` short goals (0.2 s) for the time from sending to accepted, and one 2 s goal
    for the feedback rate (messages received per second, first to last arrival)."""
    import numpy as np

    from pfield.planning.retime import TimedJointTrajectory
    from pfield.transport.trajectory_client import ExecutionOptions, TrajectoryClient

    joints = ("joint1", "joint2", "joint3")
    server = subprocess.Popen([sys.executable, str(TRAJECTORY_SERVER), *joints], stdout=subprocess.DEVNULL)

    def line(duration: float) -> TimedJointTrajectory:
        times = np.linspace(0.0, duration, 11)
        positions = np.outer(times / duration, [0.2, -0.1, 0.1])
        zeros = np.zeros_like(positions)
        return TimedJointTrajectory(joints, times, positions, zeros, zeros, np.ones(3), np.ones(3))

    try:
        with TrajectoryClient() as client:
            client.execute(line(0.2), ExecutionOptions(server_timeout=60.0))  # discovery, first allocations
            accepted = [client.execute(line(0.2)).accepted_after for _ in range(goals)]
            arrivals: list[float] = []
            client.execute(line(2.0), feedback=lambda f: arrivals.append(f.received))
    finally:
        server.send_signal(signal.SIGINT)
        server.wait(30)
    return {"accepted": accepted, "feedback_rate": [(len(arrivals) - 1) / (arrivals[-1] - arrivals[0])]}


def _trajectory_rows(quick: bool) -> list[BenchRow]:
    name = "FollowJointTrajectory goal sent -> accepted p50"
    samples = ros2_session("benchmarks.bench_ros2", ["--inner-trajectory", "20" if quick else "100"], ENVIRONMENT,
                           600)
    if isinstance(samples, str):
        return [BenchRow(SECTION, name, float("nan"), "ms", note=f"not measured: {samples}")]
    accepted = 1e3 * np.array(samples["accepted"])
    return [BenchRow(SECTION, name, float(np.percentile(accepted, 50)), "ms",
                     note=f"{len(accepted)} goals of 11 points, p99 {np.percentile(accepted, 99):.3g} ms; pfield's "
                          "TrajectoryClient to the tests' rclpy action server (another process), Fast DDS UDPv4"),
            BenchRow(SECTION, "FollowJointTrajectory feedback rate", samples["feedback_rate"][0], "Hz",
                     higher_is_better=True, note="feedback messages received per second during a 2 s goal (first "
                                                 "to last arrival); the test server publishes one per 10 ms sample "
                                                 "(sleep-paced, so below 100 Hz by its own work)")]


def _http_figures(path: Path) -> dict[str, float]:
    """The HTTP round trip of the same ``make bench`` run (bench_http runs first), to show side by side."""
    try:
        rows = json.loads(path.read_text())["rows"]
    except (OSError, ValueError, KeyError):
        return {}
    figures = {}
    for row in rows:
        for quantile in ("p50", "p99"):
            if "HTTP round trip" in row.get("name", "") and row["name"].endswith(quantile):
                figures[quantile] = float(row["value"])
    return figures


def _main(argv: list[str]) -> None:
    if argv[:1] == ["--inner-trajectory"]:
        print(json.dumps(_measure_trajectories(int(argv[1]))))
    elif argv[:1] == ["--inner"]:
        print(json.dumps(_measure(int(argv[1]))))
    else:
        for row in run(quick="--quick" in argv):
            print(row)


if __name__ == "__main__":
    _main(sys.argv[1:])
