"""The servo loop (``/pfield_servo``): its cycle time in process at 500 Hz, and command-in to command-out over ROS 2.

* **In process, 500 Hz** — the Panda, whole body, 10 sphere obstacles around the workspace and a goal (so each cycle
  runs the field's whole-body step, the assistance with its dampers, the singularity check, the limits, the
  look-ahead near obstacles, and builds the JointTrajectory message): :meth:`ServoNode.step` paced at 2 ms with an
  operator twist renewed every cycle, in the node's own process (no transport). Figures: p50 / p99 / max of the
  cycle's wall time and the cycles that took longer than the 2 ms period, and the cycle's thread CPU time (on a shared
  machine the wall time also counts the time other processes held the core). Target (issue 35): p99 ≤ 1 ms.
* **Over ROS 2, 100 Hz** — ``pfield ros2 node --robot panda`` with a MoveIt Servo section (``publish_period``
  0.01) in a private network namespace (Fast DDS, UDPv4 loopback), a second process publishing ``/joint_states`` at
  50 Hz and a TwistStamped at 100 Hz on ``~/delta_twist_cmds``, timing from each publish to the arrival of the
  JointTrajectory on ``command_out_topic`` in the same process, once the node's warm-up has ended
  (:func:`_wait_for_warmup`). Every command is paired: its twist turns by 1/16 of a turn from the previous one, so
  each command out says by its end-effector velocity J(q) q̇ which command it was computed from (:func:`attribute`);
  a command's latency runs to the first command out computed from it or from a later command (one superseded before
  a step read it waits for its successor's; the note counts them). Figures
  p50 / p95 / p99 / max; targets p50 ≤ 2 ms, p99 ≤ 10 ms. Beside them, the floor: the same client against a bare
  rclpy node (:func:`_echo`) that answers each twist with a JointTrajectory, measured in the same namespace just
  before (the transport's share of the figure on this machine).

Without ``unshare`` or the ``ros2`` extra the ROS 2 rows are skipped with a note.
"""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks._common import BenchRow, ros2_session

SECTION = "servo"
PERIOD = 0.002
TARGET_P99_MS = 1.0
ROS_TARGETS = {"p50": 2.0, "p99": 10.0}
ENVIRONMENT = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": "59",
               "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4", "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"}
OUT_TOPIC = "/arm_controller/joint_trajectory"
SERVO_PARAMETERS = {"publish_period": 0.01, "incoming_command_timeout": 0.1, "command_out_topic": OUT_TOPIC,
                    "command_out_type": "trajectory_msgs/JointTrajectory", "use_smoothing": True}


def _scene(manager: Any, robot: Any) -> None:
    """10 spheres around the Panda's workspace, clear of its ready pose, and a goal ahead of it."""
    from pfield.interfaces import message_from_data
    from pfield.interfaces import potential_fields_interfaces as pfi
    from pfield.interfaces.geometry_msgs import PoseStamped

    rng = np.random.default_rng(35)
    tip = robot.forward_kinematics(robot.named_configuration("ready")).position
    obstacles = []
    while len(obstacles) < 10:
        centre = rng.uniform([0.1, -0.6, 0.0], [0.8, 0.6, 0.9])
        if np.linalg.norm(centre - tip) > 0.25 and np.linalg.norm(centre[:2]) > 0.3:
            obstacles.append({"frame_id": f"ball{len(obstacles)}", "type": "Sphere", "group": "Static", "radius": 0.05,
                              "pose": {"position": dict(zip("xyz", centre.tolist(), strict=True))}})
    manager.on_obstacles(message_from_data(pfi.ObstacleArray, {"obstacles": obstacles}))
    goal = {"pose": {"position": {"x": float(tip[0]) + 0.1, "y": float(tip[1]) + 0.1, "z": float(tip[2])}}}
    manager.on_goal(message_from_data(PoseStamped, goal))


def in_process(cycles: int) -> dict[str, float]:
    """Cycle times (ms) of the servo node paced at 500 Hz."""
    from pfield.interfaces import geometry_msgs as gm
    from pfield.interfaces.sensor_msgs import JointState
    from pfield.node._base import Bus
    from pfield.node.manager import ManagerNode
    from pfield.node.servo_node import ServoNode
    from pfield.robot import RobotModel
    from pfield.shared_control.servo_config import ServoConfig

    robot = RobotModel.builtin("panda")
    manager = ManagerNode(Bus(), robot)
    _scene(manager, robot)
    servo = ServoNode(manager.bus, manager, ServoConfig(publish_period=PERIOD))
    ready = robot.named_configuration("ready").tolist()
    manager.on_joint_states(JointState(name=list(robot.joint_names), position=ready))
    twist = gm.TwistStamped.model_validate({"twist": {"linear": {"x": 0.02, "y": -0.01}}})
    for _ in range(200):  # warm-up: the field, the compiled workspaces, first allocations
        servo.servo.command(manager.operator_twist(twist, manager.state), time.monotonic())
        servo.step(time.monotonic())
    servo.servo.reset()
    samples, cpu, overruns = [], [], 0
    start = time.perf_counter()
    for k in range(cycles):
        deadline = start + (k + 1) * PERIOD
        began, began_cpu = time.perf_counter(), time.thread_time()
        if k % 50 == 0:
            manager.on_joint_states(JointState(name=list(robot.joint_names), position=ready))  # a driver's state
        servo.servo.command(manager.operator_twist(twist, manager.state), time.monotonic())
        servo.step(time.monotonic())
        ended = time.perf_counter()
        cpu.append(time.thread_time() - began_cpu)
        samples.append(ended - began)
        overruns += ended - began > PERIOD  # the cycle itself took longer than its period
        while time.perf_counter() < deadline:  # pace at 500 Hz (a short sleep, then spin the last 0.3 ms)
            remaining = deadline - time.perf_counter()
            if remaining > 3e-4:
                time.sleep(remaining - 3e-4)
    values, cpu_values = 1e3 * np.array(samples), 1e3 * np.array(cpu)
    return {"p50": float(np.percentile(values, 50)), "p99": float(np.percentile(values, 99)),
            "max": float(values.max()), "overruns": float(overruns), "cycles": float(cycles),
            "cpu_p50": float(np.percentile(cpu_values, 50)), "cpu_p99": float(np.percentile(cpu_values, 99))}


DIRECTIONS = 16
"""The operator's twist turns by 2π/16 in the horizontal plane at every command (at :data:`SPEED` the joints follow
each turn within their acceleration limits; the tip circles ~0.05 mm): each command out carries the direction of the
command it was computed from, so every command is paired with the first command out that reflects it
(:func:`attribute`)."""
SPEED = 0.002
"""m/s: the operator's speed."""


def _twists(interface_class: Any, tagged: bool) -> list[Any]:
    """The :data:`DIRECTIONS` TwistStamped messages; ``tagged`` (for the echo node, which returns it): index k's
    header stamp ``sec`` = k. The servo's are not stamped (it would date them by a stamp; it answers the direction)."""
    twist_class = interface_class("geometry_msgs/msg/TwistStamped")
    messages = []
    for k in range(DIRECTIONS):
        message = twist_class()
        message.header.stamp.sec = k if tagged else 0
        message.twist.linear.x = SPEED * math.cos(2 * math.pi * k / DIRECTIONS)
        message.twist.linear.y = SPEED * math.sin(2 * math.pi * k / DIRECTIONS)
        messages.append(message)
    return messages


def _echo(out_topic: str) -> None:
    """The floor: a bare rclpy node (one subscription, one publisher, a single-threaded executor) that answers each
    twist on the servo's command topic with a 7-joint JointTrajectory carrying the twist's stamp, until SIGINT."""
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.node import Node as RclpyNode

    from pfield.transport._ros2_convert import interface_class
    from pfield.transport.ros2 import STREAM_QOS

    rclpy.init()
    node = RclpyNode("pfield_servo_echo")
    trajectory = interface_class("trajectory_msgs/msg/JointTrajectory")
    point = interface_class("trajectory_msgs/msg/JointTrajectoryPoint")
    publisher = node.create_publisher(trajectory, out_topic, STREAM_QOS)
    names = [f"joint{i}" for i in range(1, 8)]

    def answer(twist: Any) -> None:
        message = trajectory()
        message.header.stamp = twist.header.stamp
        message.joint_names = names
        message.points = [point(positions=[0.0] * 7, velocities=[twist.twist.linear.x] * 7)]
        publisher.publish(message)

    node.create_subscription(interface_class("geometry_msgs/msg/TwistStamped"), "/pfield_servo/delta_twist_cmds",
                             answer, 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


WARMED_UP = ("link model", "self-check")
"""Words of the node's log (INFO, :mod:`pfield.warmup`) that say its background link-model fit and self-check have
ended, passed or failed."""


def _wait_for_warmup(log: Path, node: subprocess.Popen[bytes], deadline: float) -> None:
    """Until the node's log says both warm-up threads ended (:data:`WARMED_UP`): while they run they hold the GIL in
    turns with the servo's thread (0.3–0.8 s without a command out seen at the start of some runs), and the figures are
    of a node at work, not of one starting."""
    while time.monotonic() < deadline and node.poll() is None:
        text = log.read_text(errors="replace")
        if all(words in text for words in WARMED_UP):
            return
        time.sleep(0.1)


def _measure_ros(commands: int, target: str) -> dict[str, Any]:
    """Inside the namespace: ``target`` (``pfield``: the node; ``echo``: :func:`_echo`), then ``commands`` twists at
    100 Hz (joint states at 50 Hz); every command out is recorded with its arrival time."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node as RclpyNode
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    import pfield.interfaces.all  # noqa: F401
    from pfield.interfaces import lookup_type
    from pfield.robot import RobotModel
    from pfield.transport._ros2_convert import interface_class, to_ros

    robot = RobotModel.builtin("panda")
    folder = tempfile.mkdtemp(prefix="bench_servo_")
    params = Path(folder) / "servo.yaml"
    params.write_text(json.dumps({"servo_node": {"ros__parameters": {"moveit_servo": SERVO_PARAMETERS}}}))
    cli = str(Path(sys.executable).with_name("pfield"))
    command = [cli, "ros2", "node", "--robot", "panda", "--params", str(params), "--log-level", "info"]
    if target == "echo":
        command = [sys.executable, "-m", "benchmarks.bench_servo", "--echo", OUT_TOPIC]
    log = Path(folder) / f"{target}.log"
    with log.open("wb") as out:
        node = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, cwd=Path(__file__).resolve().parents[1])
    context = Context()
    rclpy.init(context=context)
    client = RclpyNode("pfield_bench_servo", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(client)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    arrivals: list[tuple[float, Any]] = []
    try:
        state = to_ros(lookup_type("sensor_msgs/msg/JointState").model_validate(
            {"name": list(robot.joint_names), "position": robot.named_configuration("ready").tolist()}),
            interface_class("sensor_msgs/msg/JointState"))
        twist = _twists(interface_class, tagged=target == "echo")
        states = client.create_publisher(interface_class("sensor_msgs/msg/JointState"), "/joint_states", 10)
        twists = client.create_publisher(interface_class("geometry_msgs/msg/TwistStamped"),
                                         "/pfield_servo/delta_twist_cmds", 10)
        client.create_subscription(interface_class("trajectory_msgs/msg/JointTrajectory"), OUT_TOPIC,
                                   lambda message: arrivals.append((time.perf_counter(), message)),
                                   QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
        deadline = time.monotonic() + 120.0
        while twists.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        if target == "pfield":
            _wait_for_warmup(log, node, deadline + 180.0)
        k = 0
        while (not arrivals or k < 100) and time.monotonic() < deadline:  # warm-up: fit, discovery, the kernels
            states.publish(state)
            twists.publish(twist[k % DIRECTIONS])
            k += 1
            time.sleep(0.01)
        time.sleep(0.5)  # the warm-up stream stops: the servo decelerates, then idles
        arrivals.clear()
        sent: list[float] = []
        start = time.perf_counter()
        for k in range(commands):
            due = start + k * 0.01
            while time.perf_counter() < due:
                time.sleep(max(0.0, min(due - time.perf_counter() - 2e-4, 0.005)))
            if k % 2 == 0:
                states.publish(state)  # 50 Hz
            sent.append(time.perf_counter())
            twists.publish(twist[k % DIRECTIONS])
        time.sleep(0.3)
    finally:
        executor.shutdown()
        spinner.join()
        client.destroy_node()
        rclpy.shutdown(context=context)
        node.send_signal(signal.SIGINT)
        node.wait(30)
    if target == "echo":
        return {"sent": sent, "out": [[t, message.header.stamp.sec] for t, message in arrivals]}
    points = [(t, message.points[0]) for t, message in arrivals if message.points]
    return {"sent": sent, "out": [[t, list(point.positions), list(point.velocities)] for t, point in points]}


def direction_index(robot: Any, positions: Any, velocities: Any) -> int:
    """The :data:`DIRECTIONS` index of a command out: the direction of its end-effector velocity J(q) q̇ in the
    horizontal plane, or -1 when it has (almost) none (a stop) or points elsewhere than the commands."""
    linear = robot.jacobian(np.asarray(positions, dtype=np.float64))[:3] @ np.asarray(velocities, dtype=np.float64)
    if len(velocities) != robot.n_joints or np.linalg.norm(linear[:2]) < 0.1 * SPEED or \
            abs(linear[2]) > 0.5 * np.linalg.norm(linear[:2]):
        return -1
    turns = math.atan2(linear[1], linear[0]) / (2 * math.pi) * DIRECTIONS
    if abs(turns - round(turns)) > 0.25:  # more than a quarter step off every command's direction: not decoded
        return -1
    return round(turns) % DIRECTIONS


def attribute(sent: list[float], out: list[tuple[float, int]]) -> tuple[list[float], int, int]:
    """Each command's latency (s): from its publish to the first command out computed from it or from a later
    command. A command out with direction index j (-1: undecoded, skipped) comes from the latest command k ≡ j
    (mod :data:`DIRECTIONS`) published before it arrived (exact while latencies stay under DIRECTIONS periods).
    Returns the latencies of the commands that have such an output, how many of those came from the command itself
    (the others were superseded: the next command arrived before a step read it), and how many outputs were
    undecoded."""
    times = np.asarray(sent)
    source = []
    for arrival, index in sorted(out):
        if index < 0:
            continue
        last = int(np.searchsorted(times, arrival, side="right")) - 1  # the latest command published before it
        k = last - (last - index) % DIRECTIONS
        if k >= 0:
            source.append((arrival, k))
    latencies, own, cursor = [], 0, 0
    for k, begin in enumerate(sent):
        while cursor < len(source) and source[cursor][0] < begin:
            cursor += 1
        first = next(((arrival, origin) for arrival, origin in source[cursor:] if origin >= k), None)
        if first is not None:
            latencies.append(first[0] - begin)
            own += first[1] == k
    return latencies, own, sum(index < 0 for _, index in out)


def _ros_session(commands: int) -> dict[str, Any] | str:
    """Both sessions (the echo floor, then pfield) in a private network namespace; a reason when not possible."""
    result: dict[str, Any] | str = ros2_session("benchmarks.bench_servo", ["--inner", str(commands)],
                                                    ENVIRONMENT, 900)
    return result


def _ros_rows(quick: bool) -> list[BenchRow]:
    from pfield.robot import RobotModel

    commands = 300 if quick else 2000
    data = _ros_session(commands)
    name = "ROS 2 command-in → command-out at 100 Hz"
    if isinstance(data, str):
        return [BenchRow(SECTION, f"{name} {q}", float("nan"), "ms", target=target, note=f"not measured: {data}")
                for q, target in ROS_TARGETS.items()]
    robot = RobotModel.builtin("panda")
    session = data["pfield"]
    out = [(t, direction_index(robot, q, v)) for t, q, v in session["out"]]
    latencies, own, undecoded = attribute(session["sent"], out)
    echo = data["echo"]
    floor, _, _ = attribute(echo["sent"], [(t, k % DIRECTIONS) for t, k in echo["out"]])
    sent = len(session["sent"])
    note = (f"{len(latencies)} of {sent} commands paired ({own} with their own command out, {len(latencies) - own} "
            f"with a later command's: superseded before a step read them; {len(session['out'])} commands out, "
            f"{undecoded} undecoded); Panda, no obstacles; Fast DDS UDPv4 loopback, node in another process")
    floor_note = (f"{len(floor)} of {len(echo['sent'])} paired; a bare rclpy node (single-threaded executor) "
                  "answering each twist with a JointTrajectory: the transport's floor on this machine")
    rows = []
    for q in ("p50", "p95", "p99", "max"):
        values = 1e3 * np.asarray(latencies)
        value = float(np.percentile(values, float(q[1:]) if q != "max" else 100.0)) if len(values) else float("nan")
        rows.append(BenchRow(SECTION, f"{name} {q}", value, "ms", target=ROS_TARGETS.get(q), note=note))
    for q in ("p50", "p99"):
        values = 1e3 * np.asarray(floor)
        value = float(np.percentile(values, float(q[1:]))) if len(values) else float("nan")
        rows.append(BenchRow(SECTION, f"ROS 2 bare rclpy echo at 100 Hz {q}", value, "ms", note=floor_note))
    return rows


def run(quick: bool) -> list[BenchRow]:
    cycles = 1500 if quick else 10000
    figures = in_process(cycles)
    note = (f"{int(figures['cycles'])} cycles paced at 500 Hz; Panda whole body, 10 spheres, a goal; "
            f"{int(figures['overruns'])} took longer than 2 ms")
    rows = [BenchRow(SECTION, "servo cycle in process at 500 Hz p50", figures["p50"], "ms", note=note),
            BenchRow(SECTION, "servo cycle in process at 500 Hz p99", figures["p99"], "ms", target=TARGET_P99_MS,
                     note=note),
            BenchRow(SECTION, "servo cycle in process at 500 Hz max", figures["max"], "ms", note=note),
            BenchRow(SECTION, "servo cycle CPU time p50", figures["cpu_p50"], "ms",
                     note="the same cycles' thread CPU time: what the cycle costs when the machine is shared"),
            BenchRow(SECTION, "servo cycle CPU time p99", figures["cpu_p99"], "ms", target=TARGET_P99_MS,
                     note="the same cycles' thread CPU time: what the cycle costs when the machine is shared")]
    return rows + _ros_rows(quick)


def _main(argv: list[str]) -> None:
    if argv[:1] == ["--inner"]:
        print(json.dumps({target: _measure_ros(int(argv[1]), target) for target in ("echo", "pfield")}))
    elif argv[:1] == ["--echo"]:
        _echo(argv[1])
    else:
        for row in run(quick="--quick" in argv):
            print(row)


if __name__ == "__main__":
    _main(sys.argv[1:])
