"""A physical arm on ROS 2 topics for the tests: a built-in robot in MuJoCo (:class:`pfield.sim.Simulation`) that
plays a ros2_control driver and its controllers.

* publishes ``/joint_states`` (``sensor_msgs/JointState``, the robot's joints) at ``--rate`` Hz from the simulation;
* follows the servo loop's commands on ``--command-topic``: ``trajectory_msgs/JointTrajectory`` (the first point's
  positions and velocities, joints by name) or ``std_msgs/Float64MultiArray`` (``--command-type positions`` or
  ``velocities``, the robot's joint order), each held as the servos' reference until the next one;
* serves ``control_msgs/action/FollowJointTrajectory`` on ``--action`` (the tests' server,
  ``tests/transport/ros2_helpers/trajectory_server.py``, whose advance step is this simulation).

Between commands the physics runs in real time (``1/--rate`` s of simulated time per tick) holding the last
reference, so the arm stands still, decelerates or drifts as a real one would. The ticks run on a thread of their own
at a fixed rate, as a driver's hardware loop does, not as an executor timer: rclpy's multi-threaded executor queues a
new handler for a timer that fires while its workers are busy and walks the whole queue at every wake-up, so a burst
of commands on a loaded machine made the timer's backlog grow until the arm stopped ticking for seconds. Ticks that
fall due while the process waits for a core are made up, so simulated time keeps up with the wall clock.

On SIGINT/SIGTERM it writes ``--out`` (JSON): the contact tally, the end-effector position over time, the commands
received and the final joints. Obstacles (``--sphere X,Y,Z,R``, repeatable) are placed in the simulation only;
the caller tells pfield's node about them.

Usage: ``python sim_arm.py ROBOT --out report.json [--q0 NAME] [--sphere X,Y,Z,R] [--command-topic T]
[--command-type trajectory|positions|velocities] [--action NAME] [--rate HZ]``
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "transport"))  # ros2_helpers

from ros2_helpers.trajectory_server import TrajectoryServer

from pfield import Obstacle, Pose, Sphere
from pfield.robot import RobotModel
from pfield.sim import JointState as SimState
from pfield.sim import Simulation


def _sphere(text: str, index: int) -> Obstacle:
    x, y, z, radius = (float(v) for v in text.split(","))
    return Obstacle(f"sphere{index}", Sphere(radius=radius), Pose(position=(x, y, z)))


CATCH_UP = 20
"""Most physics ticks made up at one wake-up of :meth:`SimArm.run` (0.2 s at 100 Hz)."""


class SimArm:
    """The simulation behind a lock, stepped by the servo commands, the action server or the idle clock."""

    def __init__(self, robot: RobotModel, simulation: Simulation, period: float) -> None:
        self.robot = robot
        self.sim = simulation
        self.period = period
        self.lock = threading.Lock()
        self.reference = np.array(simulation.state.positions)
        self.rate = np.zeros(robot.n_joints)
        self.last_action_step = -np.inf
        self.commands = 0
        self.trail: list[list[float]] = []  # [sim time, x, y, z] of the end effector, each tick
        self.server: TrajectoryServer | None = None  # its idea of where the arm stands follows the physics

    def command(self, positions: np.ndarray | None, velocities: np.ndarray | None) -> None:
        with self.lock:
            self.commands += 1
            if positions is not None:
                self.reference = np.clip(positions, self.robot.lower_limits, self.robot.upper_limits)
                self.rate = np.zeros(self.robot.n_joints) if velocities is None else velocities
            elif velocities is not None:  # a velocity command: the reference moves at that rate from where it is
                self.reference = np.array(self.sim.state.positions)
                self.rate = velocities

    def tick(self) -> SimState:
        """One idle period of physics (skipped while the action server drives the arm); the state after it."""
        with self.lock:
            if time.monotonic() - self.last_action_step < 5 * self.period:
                return self.sim.state
            if self.rate.any() and not np.any(np.isnan(self.rate)):
                state = self.sim.step(self.reference, self.rate, dt=self.period)
                self.reference = np.clip(self.reference + self.rate * self.period, self.robot.lower_limits,
                                         self.robot.upper_limits)
            else:
                state = self.sim.step(self.reference, dt=self.period)
            self._record(state.time, state.positions)
            if self.server is not None:
                self.server.positions = np.array(state.positions)
            return state

    def run(self, publish: Callable[[SimState], None], stop: threading.Event) -> None:
        """Tick every ``period`` on the wall clock until ``stop``, publishing the state after each wake-up. Ticks that
        fell due while this process waited for a core are made up (at most :data:`CATCH_UP` at once; beyond that
        the clock restarts from now), so that simulated time keeps up with the wall clock as a robot's does: the
        servo times its commands on the wall clock, and an arm whose physics ran late fell behind the positions it
        was sent, then kept moving toward them long after the servo had stopped."""
        due = time.monotonic()
        while not stop.is_set():
            state, ticks = None, 0
            while ticks < CATCH_UP and time.monotonic() >= due:
                state, ticks, due = self.tick(), ticks + 1, due + self.period
            if state is not None:
                publish(state)
            if time.monotonic() - due > CATCH_UP * self.period:
                due = time.monotonic()
            stop.wait(max(0.0, due - time.monotonic()))

    def advance(self, current: np.ndarray, desired: np.ndarray, dt: float) -> np.ndarray:
        """The action server's step (``trajectory_server.Advance``): hold ``desired`` for ``dt``."""
        with self.lock:
            self.last_action_step = time.monotonic()
            self.reference, self.rate = np.array(desired), np.zeros(self.robot.n_joints)
            state = self.sim.step(desired, dt=dt)
            self._record(state.time, state.positions)
            return np.array(state.positions)

    def _record(self, t: float, q: np.ndarray) -> None:
        # the physics may hold a joint a little past its limit (MuJoCo's limits are soft: panda_joint4 0.9 mrad below
        # its lower one after teleop pressed it there): a measured state, taken as pfield takes one
        measured = self.robot.check_measured_joint_angles(q, "positions")
        self.trail.append([t, *self.robot.forward_kinematics(measured).position.tolist()])

    def report(self) -> dict[str, Any]:
        with self.lock:
            tally = self.sim.contacts
            return {"obstacle_steps": tally.obstacle_steps, "obstacle_pairs": list(tally.obstacle_pairs),
                    "obstacle_penetration": tally.obstacle_penetration, "self_steps": tally.self_steps,
                    "commands": self.commands, "trail": self.trail,
                    "final_positions": np.asarray(self.sim.state.positions).tolist(),
                    "final_velocities": np.asarray(self.sim.state.velocities).tolist(),
                    "final_reference": self.reference.tolist()}


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot")
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--q0", default="ready")
    parser.add_argument("--sphere", action="append", default=[])
    parser.add_argument("--command-topic", default="/panda_arm_controller/joint_trajectory")
    parser.add_argument("--command-type", choices=("trajectory", "positions", "velocities"), default="trajectory")
    parser.add_argument("--action", default="/panda_arm_controller/follow_joint_trajectory")
    parser.add_argument("--rate", type=float, default=100.0)
    args = parser.parse_args(argv)

    robot = RobotModel.builtin(args.robot)
    obstacles = [_sphere(text, i) for i, text in enumerate(args.sphere)]
    arm = SimArm(robot, Simulation(robot, obstacles, q0=robot.named_configuration(args.q0)), 1.0 / args.rate)
    names = list(robot.joint_names)

    rclpy.init()
    node = Node("sim_arm")
    group = ReentrantCallbackGroup()
    states = node.create_publisher(JointState, "/joint_states", 10)

    def on_trajectory(message: JointTrajectory) -> None:
        if not message.points:
            return
        point, order = message.points[0], [list(message.joint_names).index(name) for name in names]
        positions = np.array([point.positions[i] for i in order]) if point.positions else None
        velocities = np.array([point.velocities[i] for i in order]) if point.velocities else None
        arm.command(positions, velocities)

    def on_array(message: Float64MultiArray) -> None:
        values = np.array(message.data, dtype=float)
        arm.command(values, None) if args.command_type == "positions" else arm.command(None, values)

    qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
    if args.command_type == "trajectory":
        node.create_subscription(JointTrajectory, args.command_topic, on_trajectory, qos, callback_group=group)
    else:
        node.create_subscription(Float64MultiArray, args.command_topic, on_array, qos, callback_group=group)
    arm.server = TrajectoryServer(node, args.action, names, arm.advance, initial=arm.reference, goal_tolerance=0.01)

    def publish_state(state: SimState) -> None:
        message = JointState(name=names, position=state.positions.tolist(), velocity=state.velocities.tolist())
        message.header.stamp = node.get_clock().now().to_msg()
        states.publish(message)

    executor = MultiThreadedExecutor(num_threads=3)
    executor.add_node(node)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    spinning = threading.Thread(target=executor.spin, daemon=True)
    ticking = threading.Thread(target=arm.run, args=(publish_state, stop), name="sim-arm-physics", daemon=True)
    spinning.start()
    ticking.start()
    print(f"sim arm {args.robot}: /joint_states, {args.command_topic}, {args.action}", flush=True)
    stop.wait()
    ticking.join(5.0)
    executor.shutdown(timeout_sec=5.0)
    spinning.join(5.0)
    args.out.write_text(json.dumps(arm.report()))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main(sys.argv[1:])
