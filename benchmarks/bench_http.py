"""HTTP node: round trip of ``compute_autonomy_vector`` and WebSocket throughput.

* Round trip: a persistent HTTP/1.1 client (httpx) posts the seed's task-space ComputeAutonomyVector
  request to ``/srv/pfield/compute_autonomy_vector`` of an in-process uvicorn server (127.0.0.1) whose
  manager holds the seed's five primitive obstacles and goal; p50 and p99 over many calls. Target: p50 ≤ 2 ms.
* The same with the seed's whole-body request (xArm7 joint angles).
* WebSocket: the node publishes a burst of TwistStamped messages on its bus; one client on
  ``/ws/topic/pfield/autonomy_vector`` counts them; messages per second from first to last. Target ≥ 1000.

The C++ original has no HTTP interface (no reference figure).
"""

from __future__ import annotations

import threading
import time

import httpx
import numpy as np
from websockets.sync.client import connect

from benchmarks._common import BenchRow
from pfield.node._base import Bus

SECTION = "http node"
OBSTACLES = {
    "header": {"frame_id": "world"},
    "obstacles": [
        {"frame_id": "ball", "type": "Sphere", "group": "Static", "radius": 0.1,
         "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.1}}},
        {"frame_id": "table", "type": "Box", "group": "Static", "length": 0.15, "width": 0.7, "height": 0.6,
         "pose": {"position": {"x": 0.66, "y": 0.0, "z": 0.3}}},
        {"frame_id": "pitcher", "type": "Cylinder", "group": "Static", "radius": 0.09, "height": 0.3,
         "pose": {"position": {"x": 0.51, "y": 0.0, "z": 0.15}}},
        {"frame_id": "ellipsoid_obs", "type": "Ellipsoid", "group": "Static", "semi_x": 0.08, "semi_y": 0.05,
         "semi_z": 0.12, "pose": {"position": {"x": 0.5, "y": 0.1, "z": 0.2}}},
        {"frame_id": "capsule_obs", "type": "Capsule", "group": "Static", "radius": 0.05, "height": 0.2,
         "pose": {"position": {"x": 0.45, "y": 0.0, "z": 0.2}}},
    ],
}
ORIENTATION = {"x": 0.707, "y": 0.0, "z": 0.707, "w": 0.0}
GOAL = {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.5, "y": 0.2, "z": 0.4},
                                                  "orientation": ORIENTATION}}
QUERY = {"query_pose": {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.3, "y": 0.1, "z": 0.35},
                                                                   "orientation": ORIENTATION}},
         "delta_time": 0.02, "planning_method": "task_space"}


WHOLE_BODY_QUERY = QUERY | {"joint_angles": [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0],
                            "prev_joint_velocities": [0.0] * 7, "planning_method": "whole_body"}


def _round_trip(url: str, calls: int, query: dict[str, object]) -> tuple[float, float]:
    with httpx.Client(base_url=url, timeout=300.0) as client:  # the first calls may compile kernels
        client.post("/topic/pfield/obstacles", json=OBSTACLES).raise_for_status()
        client.post("/topic/pfield/planning_goal_pose", json=GOAL).raise_for_status()
        for _ in range(50):
            client.post("/srv/pfield/compute_autonomy_vector", json=query).raise_for_status()
        samples = np.empty(calls)
        for i in range(calls):
            start = time.perf_counter()
            client.post("/srv/pfield/compute_autonomy_vector", json=query).raise_for_status()
            samples[i] = time.perf_counter() - start
    return float(np.percentile(samples, 50)) * 1e3, float(np.percentile(samples, 99)) * 1e3


def _websocket_rate(url: str, bus: Bus, count: int) -> float:
    from pfield.interfaces.geometry_msgs import TwistStamped

    message = TwistStamped()
    message.twist.linear.x = 0.01
    bus.publish("/pfield/autonomy_vector", message)  # the latest message is sent first: proves the subscription

    def publish_burst() -> None:
        for _ in range(count):
            bus.publish("/pfield/autonomy_vector", message)

    with connect(url.replace("http", "ws", 1) + "/ws/topic/pfield/autonomy_vector") as socket:
        socket.recv(timeout=30)
        publisher = threading.Thread(target=publish_burst)
        start = time.perf_counter()
        publisher.start()
        for _ in range(count):
            socket.recv(timeout=30)
        elapsed = time.perf_counter() - start
        publisher.join()
    return count / elapsed


def run(quick: bool) -> list[BenchRow]:
    from pfield.node.manager import ManagerNode
    from pfield.robot import RobotModel
    from pfield.transport.http import ServerThread, create_app

    calls, burst = (300, 2000) if quick else (2000, 20000)
    bus = Bus()
    node = ManagerNode(bus, RobotModel.builtin("xarm7"))
    with ServerThread(create_app([node], ws_queue_size=burst + 10)) as server:
        p50, p99 = _round_trip(server.url, calls, QUERY)
        wb50, wb99 = _round_trip(server.url, calls, WHOLE_BODY_QUERY)
        rate = _websocket_rate(server.url, bus, burst)
    return [
        BenchRow(SECTION, "compute_autonomy_vector HTTP round trip p50", p50, "ms", target=2.0,
                 note=f"{calls} calls, 5 obstacles, keep-alive client"),
        BenchRow(SECTION, "compute_autonomy_vector HTTP round trip p99", p99, "ms", note=f"{calls} calls"),
        BenchRow(SECTION, "whole-body compute_autonomy_vector HTTP round trip p50", wb50, "ms", target=2.0,
                 note=f"xArm7, {calls} calls; p99 {wb99:.2f} ms"),
        BenchRow(SECTION, "WebSocket TwistStamped stream", rate, "messages/s", target=1000.0,
                 higher_is_better=True, note=f"burst of {burst}, one client"),
    ]
