"""HTTP node: round trip of ``compute_autonomy_vector`` and WebSocket throughput.

* Round trip: a persistent HTTP/1.1 client (httpx) posts the seed's task-space ComputeAutonomyVector
  request to ``/srv/pfield/compute_autonomy_vector`` of an in-process uvicorn server (127.0.0.1) whose
  manager holds the seed's five primitive obstacles and goal; p50 and p99 over many calls. Target: p50 ≤ 2 ms.
* The same with the seed's whole-body request (xArm7 joint angles).
* WebSocket: the node publishes a burst of TwistStamped messages on its bus; one client on
  ``/ws/topic/pfield/autonomy_vector`` counts them; messages per second from first to last. Target ≥ 1000.
* Quick calls: a control-loop call that the node knows to be cheap is answered on the event loop, the
  others on the calls thread; the assistance round trip below is also measured with every call on the thread.
* Under load: 8 keep-alive connections (lean ``http.client`` loops) post the autonomy request while another
  asks for plans at the iteration cap (200 000 iterations, a slow approach that uses them all), every client
  in a process of its own (as a robot's control loops are; clients in the server's process would share its
  GIL). Each connection is a 100 Hz control loop (paced): p50/p99 of the autonomy calls sent between the
  first plan request and the last plan answer (target p99 ≤ 5 ms; calls made while the callers' own
  interpreters start are not counted), and the plans' wall time. Then the same with the 8 connections calling
  back to back (saturation: the calls thread serves them one at a time, so p99 there is a queue of 8, and the
  note gives the throughput).
* ``compute_assistance``: the round trip of a task-space request with an operator command (seed goal, no
  obstacles) from a lean keep-alive client in its own process (as a robot's control loop calls the node),
  target p50 ≤ 1 ms; and from httpx in the server's process (the client then shares the server's GIL).
* Plan response: time to write the JSON of a 200 000-waypoint whole-body-sized response from the plan's arrays,
  and (before) through one validated pydantic object per waypoint (``model_validate`` + ``model_dump_json``).
* Memory: RSS growth of the server process under 300 junk topic names of 300 kB messages, and under a
  WebSocket client that never reads 200 such messages.

The C++ original has no HTTP interface (no reference figure).
"""

from __future__ import annotations

import contextlib
import json
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

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


ASSISTANCE = {"query_pose": {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.3, "y": 0.0, "z": 0.5}}},
              "user_command": {"twist": {"linear": {"x": 0.02}}}}


def _assistance_round_trip(url: str, calls: int) -> tuple[float, float]:
    """p50, p99 (ms) of ``compute_assistance`` with the seed's goal and no obstacles (a separate node)."""
    with httpx.Client(base_url=url, timeout=300.0) as client:
        client.post("/topic/pfield/planning_goal_pose", json={"pose": {"position": {"x": 0.6, "y": 0.3, "z": 0.3}}})
        for _ in range(50):
            client.post("/srv/pfield/compute_assistance", json=ASSISTANCE).raise_for_status()
        samples = []
        for _ in range(calls):
            start = time.perf_counter()
            client.post("/srv/pfield/compute_assistance", json=ASSISTANCE).raise_for_status()
            samples.append(time.perf_counter() - start)
    return _percentiles(samples)


CALLER_MODES = {"autonomy": ("/srv/pfield/compute_autonomy_vector", QUERY),
                "assistance": ("/srv/pfield/compute_assistance", ASSISTANCE)}
"""The calls of a lean control-loop client (:func:`_client_main`): route and body."""


def _lean_round_trip(url: str, mode: str, calls: int) -> tuple[float, float]:
    """p50, p99 (ms) of ``calls`` back-to-back calls of ``mode`` from a lean client in its own process (as a
    robot's control loop calls the node), after 50 unmeasured ones."""
    warm = _client_process(url, mode, 50, 0.0)
    warm.communicate()
    caller = _client_process(url, mode, calls, 0.0)
    return _percentiles([seconds for _, seconds in json.loads(caller.communicate()[0])])


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


SLOW_APPROACH = {"max_linear_velocity": 0.0002, "stagnation_progress": 1e-6}
CAPPED_PLAN = {"start": {"position": {"x": 0.227, "y": 0.0, "z": 0.294}},
               "goal": {"position": {"x": 0.3, "y": 0.3, "z": 0.45}},
               "delta_time": 0.02, "goal_tolerance": 0.001, "max_iterations": 200_000, "planning_method": "task_space"}


def _percentiles(samples: list[float]) -> tuple[float, float]:
    data = np.asarray(samples) * 1e3
    return float(np.percentile(data, 50)), float(np.percentile(data, 99))


CONTROL_RATE_HZ = 100.0
"""Rate of each paced connection under load (a control loop)."""


def _client_process(url: str, mode: str, count: int, rate: float) -> subprocess.Popen[str]:
    """This module as a client in its own process (see :func:`_client_main`)."""
    return subprocess.Popen([sys.executable, "-m", "benchmarks.bench_http", "--client", url, mode, str(count),
                             str(rate)], stdout=subprocess.PIPE, text=True, cwd=Path(__file__).resolve().parents[1])


def _client_main(url: str, mode: str, count: int, rate: float) -> None:
    """``plan``: ``count`` capped plans, then print their wall times. ``autonomy`` (``assistance``): call
    ``compute_autonomy_vector`` with :data:`QUERY` (``compute_assistance`` with :data:`ASSISTANCE`) until the
    file ``<url hash>.stop`` appears (or ``count`` calls), at ``rate`` Hz (0: back to back); print the latencies.

    The autonomy caller is a lean control loop: one keep-alive ``http.client`` connection and a body
    encoded once, so that its own CPU time (httpx costs several times more per call) does not crowd the
    2-core machine that the server shares with eight of them.
    """
    samples: list[tuple[float, float]] = []  # (start, seconds); perf_counter is one clock for every process
    if mode == "plan":
        with httpx.Client(base_url=url, timeout=600) as client:
            for _ in range(count):
                start = time.perf_counter()
                client.post("/srv/pfield/plan_path", json=CAPPED_PLAN).raise_for_status()
                samples.append((start, time.perf_counter() - start))
        print(json.dumps(samples))
        return
    import http.client

    host, port = url.removeprefix("http://").rsplit(":", 1)
    connection = http.client.HTTPConnection(host, int(port), timeout=600)
    path, query = CALLER_MODES[mode]
    body, headers = json.dumps(query).encode(), {"Content-Type": "application/json"}
    period = 1.0 / rate if rate > 0 else 0.0
    stop = Path(tempfile.gettempdir()) / f"pfield-bench-{port}.stop"
    next_call = time.perf_counter()
    while len(samples) < count and not stop.exists():
        start = time.perf_counter()
        connection.request("POST", path, body, headers)
        response = connection.getresponse()
        response.read()
        if response.status != 200:
            raise RuntimeError(f"{mode} call answered {response.status}")
        samples.append((start, time.perf_counter() - start))
        next_call += period
        time.sleep(max(0.0, next_call - time.perf_counter()))
    connection.close()
    print(json.dumps(samples))


def _autonomy_while_planning(url: str, plans: int, rate: float,
                             clients: int = 8) -> tuple[float, float, float, int, float]:
    """p50, p99 (ms) of the autonomy calls from ``clients`` connections (each its own process, ``rate`` Hz, 0:
    back to back) sent while ``plans`` capped plans run one after another (from the first plan request to the
    last answer: the callers' own start-up, eight interpreters on two cores, is not the plans' load); also the
    mean plan wall time (s), the number of those calls and their rate (calls/s)."""
    stop = Path(tempfile.gettempdir()) / f"pfield-bench-{url.rsplit(':', 1)[-1]}.stop"
    stop.unlink(missing_ok=True)
    callers = [_client_process(url, "autonomy", 10**9, rate) for _ in range(clients)]
    time.sleep(1.0)  # the callers' interpreters start and connect
    planner = _client_process(url, "plan", plans, 0.0)
    plan_calls = json.loads(planner.communicate()[0])
    stop.touch()
    first, last = plan_calls[0][0], plan_calls[-1][0] + plan_calls[-1][1]
    samples = [seconds for caller in callers for start, seconds in json.loads(caller.communicate()[0])
               if first <= start <= last]
    stop.unlink(missing_ok=True)
    p50, p99 = _percentiles(samples)
    return p50, p99, float(np.mean([s for _, s in plan_calls])), len(samples), len(samples) / (last - first)


def _plan_response_times(waypoints: int) -> tuple[float, float, float]:
    """Seconds to write a plan response's JSON from the arrays (now), through validated pydantic objects
    (before), and its size in MB; a whole-body-sized plan (7 joints) of ``waypoints`` waypoints."""
    from pfield.interfaces.convert import plan_response
    from pfield.interfaces.potential_fields_interfaces import PlanPath_Response
    from pfield.planning.result import PlannedPath

    rng = np.random.default_rng(0)
    quaternions = rng.normal(size=(waypoints, 4))
    quaternions /= np.linalg.norm(quaternions, axis=1, keepdims=True)
    path = PlannedPath(True, "", np.arange(waypoints) * 0.02, rng.normal(size=(waypoints, 3)), quaternions,
                       rng.normal(size=(waypoints, 6)), np.full(waypoints, np.inf), waypoints - 1,
                       tuple(f"joint{i}" for i in range(7)), rng.normal(size=(waypoints, 7)),
                       rng.normal(size=(waypoints, 7)))
    start = time.perf_counter()
    text = plan_response(path, "world").model_dump_json()
    fast = time.perf_counter() - start
    data = json.loads(text)
    start = time.perf_counter()
    PlanPath_Response.model_validate(data).model_dump_json()  # one pydantic object per waypoint, as before
    slow = time.perf_counter() - start
    return fast, slow, len(text) / 1e6


def _rss() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    return 0


def _memory_under_floods(url: str) -> tuple[float, float]:
    """RSS growth (MB) of this process (the server's) under 300 junk topics and under a never-reading socket."""
    scan = json.dumps({"ranges": [1.25] * 60_000}).encode()
    headers = {"content-type": "application/json"}
    params = {"type": "sensor_msgs/msg/LaserScan"}
    with httpx.Client(base_url=url, timeout=120, headers=headers) as client:
        for i in range(20):
            client.post(f"/topic/warmup/{i}", params=params, content=scan).raise_for_status()
        before = _rss()
        for i in range(300):
            client.post(f"/topic/junk/{i}", params=params, content=scan).raise_for_status()
        junk = (_rss() - before) / 1e6
        before = _rss()
        with connect(url.replace("http", "ws", 1) + "/ws/topic/slow/reader", open_timeout=30, max_size=None):
            for _ in range(200):
                client.post("/topic/slow/reader", params=params, content=scan).raise_for_status()
            reader = (_rss() - before) / 1e6
    return junk, reader


@contextlib.contextmanager
def _every_call_on_the_calls_thread() -> Iterator[None]:
    """No call counts as quick (the manager's bound at 0 s): every call is handed to the calls thread, as
    before quick calls were answered on the event loop."""
    from pfield.node import manager

    bound = manager.QUICK_CALL_SECONDS
    manager.QUICK_CALL_SECONDS = 0.0
    try:
        yield
    finally:
        manager.QUICK_CALL_SECONDS = bound


def run(quick: bool) -> list[BenchRow]:
    from pfield.node.manager import ManagerNode
    from pfield.robot import RobotModel
    from pfield.transport.http import ServerThread, create_app

    calls, burst, plans, waypoints = (300, 2000, 1, 20_000) if quick else (2000, 20000, 6, 200_000)
    bus = Bus()
    node = ManagerNode(bus, RobotModel.builtin("xarm7"))
    with ServerThread(create_app([node], ws_queue_size=burst + 10)) as server:
        p50, p99 = _round_trip(server.url, calls, QUERY)
        wb50, wb99 = _round_trip(server.url, calls, WHOLE_BODY_QUERY)
        rate = _websocket_rate(server.url, bus, burst)
        httpx.put(f"{server.url}/param/pfield_manager", json=SLOW_APPROACH).raise_for_status()
        load50, load99, plan_s, load_calls, _ = _autonomy_while_planning(server.url, plans, CONTROL_RATE_HZ)
        sat50, sat99, _, sat_calls, sat_rate = _autonomy_while_planning(server.url, plans, 0.0)
        junk_mb, reader_mb = _memory_under_floods(server.url)
    with ServerThread(create_app([ManagerNode(Bus(), RobotModel.builtin("xarm7"))])) as server:
        assist50, assist99 = _assistance_round_trip(server.url, calls)
        lean50, lean99 = _lean_round_trip(server.url, "assistance", calls)
        with _every_call_on_the_calls_thread():
            thread50, thread99 = _lean_round_trip(server.url, "assistance", calls)
    fast_s, slow_s, megabytes = _plan_response_times(waypoints)
    return [
        BenchRow(SECTION, "compute_autonomy_vector HTTP round trip p50", p50, "ms", target=2.0,
                 note=f"{calls} calls, 5 obstacles, keep-alive client"),
        BenchRow(SECTION, "compute_autonomy_vector HTTP round trip p99", p99, "ms", note=f"{calls} calls"),
        BenchRow(SECTION, "whole-body compute_autonomy_vector HTTP round trip p50", wb50, "ms", target=2.0,
                 note=f"xArm7, {calls} calls; p99 {wb99:.2f} ms"),
        BenchRow(SECTION, "WebSocket TwistStamped stream", rate, "messages/s", target=1000.0,
                 higher_is_better=True, note=f"burst of {burst}, one client"),
        BenchRow(SECTION, "autonomy round trip p99 while capped plans run", load99, "ms", target=5.0,
                 note=f"8 connections at {CONTROL_RATE_HZ:.0f} Hz, each its own process, {load_calls} calls "
                      f"sent while the plans ran, "
                      f"p50 {load50:.2f} ms; {plans} plan(s) of 200 000 iterations, {plan_s:.1f} s each"),
        BenchRow(SECTION, "autonomy round trip p99 while capped plans run, back to back", sat99, "ms",
                 note=f"8 connections calling without pause: {sat_rate:.0f} calls/s, {sat_calls} calls, "
                      f"p50 {sat50:.2f} ms"),
        BenchRow(SECTION, "compute_assistance HTTP round trip p50", lean50, "ms", target=1.0,
                 note=f"{calls} calls from a lean client in its own process, task space with an operator command, "
                      f"no obstacles; p99 {lean99:.2f} ms; every call on the calls thread (before): p50 "
                      f"{thread50:.2f}, p99 {thread99:.2f} ms"),
        BenchRow(SECTION, "compute_assistance HTTP round trip p50, httpx client in the server's process",
                 assist50, "ms", note=f"the client shares the server's GIL; p99 {assist99:.2f} ms"),
        BenchRow(SECTION, "plan response JSON from the arrays", fast_s, "s",
                 note=f"{waypoints} waypoints with 7 joints, {megabytes:.0f} MB"),
        BenchRow(SECTION, "plan response JSON through per-waypoint pydantic objects (before)", slow_s, "s",
                 note=f"same plan; {slow_s / fast_s:.1f}x the time of the array path"),
        BenchRow(SECTION, "RSS growth under 300 junk topics", junk_mb, "MB", target=100.0,
                 note="300 kB LaserScan each; 16 undeclared topics keep a latest message"),
        BenchRow(SECTION, "RSS growth under a WebSocket client that never reads", reader_mb, "MB", target=100.0,
                 note="200 messages of 300 kB; the outbox keeps at most 16 MB, oldest dropped"),
    ]


if __name__ == "__main__":
    if sys.argv[1:2] == ["--client"]:
        _client_main(sys.argv[2], sys.argv[3], int(sys.argv[4]), float(sys.argv[5]))
    else:
        for row in run(quick="--quick" in sys.argv):
            print(row)
