"""A test ``control_msgs/action/FollowJointTrajectory`` server in rclpy: a kinematic stand-in for ros2_control's
``joint_trajectory_controller``.

Goal handling follows FollowJointTrajectory.action (control_msgs, Jazzy) and what joint_trajectory_controller
does: a goal without points is rejected; one whose ``joint_names`` are not exactly the arm's joints (any order)
is accepted and aborted with ``INVALID_JOINTS`` (the action's documented code); the reference is the trajectory
interpolated linearly in time from the arm's current positions (at t = 0, when the first point comes later),
sampled every ``period`` s; each sample is handed to the arm's **advance step** — ``advance(positions, desired,
dt) -> positions`` — and the result compared with the reference: beyond a joint's ``path_tolerance`` (position)
the goal aborts with ``PATH_TOLERANCE_VIOLATED``; after the last point the arm must be within ``goal_tolerance``
by ``goal_time_tolerance``, else ``GOAL_TOLERANCE_VIOLATED``. A cancel request ends the goal CANCELED where the
arm stands. Feedback (desired, actual, error = desired − actual) is published every sample.

The advance step is the only part that moves the arm: :func:`kinematic` (the arm is where it is told) and
:func:`rate_limited` (each joint at most ``v`` rad/s: it lags, so path tolerances can be violated) are the two
stand-ins; a physics simulation (MuJoCo) plugs in with the same signature.

Run as a process: ``python trajectory_server.py JOINT[=INITIAL] ...`` serves
``/joint_trajectory_controller/follow_joint_trajectory`` (kinematic) and
``/slow_controller/follow_joint_trajectory`` (:func:`rate_limited`, 0.2 rad/s) until SIGINT; with
``--sim ROBOT`` also ``/sim_controller/follow_joint_trajectory`` (:func:`simulated`: the built-in robot in MuJoCo).
"""

from __future__ import annotations

import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import rclpy
from control_msgs.action import FollowJointTrajectory
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from trajectory_msgs.msg import JointTrajectoryPoint

from pfield.interfaces.std_msgs import Duration

Advance = Callable[[np.ndarray, np.ndarray, float], np.ndarray]
"""(current positions, desired positions, dt s) -> new positions, in the server's joint order."""

Result = FollowJointTrajectory.Result


def kinematic(current: np.ndarray, desired: np.ndarray, dt: float) -> np.ndarray:
    """The arm is exactly where it is told to be."""
    return desired.copy()


def rate_limited(max_velocity: float) -> Advance:
    """Each joint moves toward the reference at most ``max_velocity`` rad/s (or m/s)."""
    def advance(current: np.ndarray, desired: np.ndarray, dt: float) -> np.ndarray:
        step = max_velocity * dt
        return current + np.clip(desired - current, -step, step)
    return advance


def simulated(simulation: Any) -> Advance:
    """A physical arm: :class:`pfield.sim.Simulation` (MuJoCo, position servos; joints in the robot's order, which
    must be the server's) holds each sample as its servo reference for ``dt`` and reports where the arm got."""
    def advance(current: np.ndarray, desired: np.ndarray, dt: float) -> np.ndarray:
        return np.array(simulation.step(desired, dt=dt).positions)
    return advance


def _seconds(duration: Any) -> float:
    return float(duration.sec) + 1e-9 * float(duration.nanosec)


def _tolerance(rows: Sequence[Any], joints: Sequence[str], default: float) -> np.ndarray:
    """Position tolerances per joint: 0 keeps ``default``, −1 (or any negative) means no limit."""
    values = np.full(len(joints), default)
    for row in rows:
        if row.name in joints:
            i = list(joints).index(row.name)
            values[i] = np.inf if row.position < 0 else (row.position or default)
    return values


class TrajectoryServer:
    """One FollowJointTrajectory action on ``node`` moving an arm of ``joints`` through ``advance``.

    ``positions``: the arm's state (rad or m), shared across goals; ``period``: s between samples;
    ``goal_tolerance`` (rad) applies to joints the goal gives no goal tolerance for and ``goal_time`` (s) when the
    goal's ``goal_time_tolerance`` is 0; path tolerance is off unless the goal sets one (as
    joint_trajectory_controller's defaults). One goal at a time: a new goal
    preempts the running one (it ends ABORTED), as joint_trajectory_controller does.
    """

    def __init__(self, node: Node, action_name: str, joints: Sequence[str], advance: Advance = kinematic, *,
                 initial: Sequence[float] | None = None, period: float = 0.01, goal_tolerance: float = 1e-3,
                 goal_time: float = 1.0) -> None:
        self.joints = list(joints)
        self.positions = np.zeros(len(self.joints)) if initial is None else np.array(initial, dtype=float)
        self.advance = advance
        self.period = period
        self.goal_tolerance = goal_tolerance
        self.goal_time = goal_time
        self.goals = 0
        self._lock = threading.Lock()
        self._active: Any = None
        self._server = ActionServer(node, FollowJointTrajectory, action_name, self._execute,
                                    goal_callback=self._on_goal, cancel_callback=lambda _h: CancelResponse.ACCEPT,
                                    callback_group=ReentrantCallbackGroup())

    def _on_goal(self, goal: Any) -> GoalResponse:
        return GoalResponse.ACCEPT if goal.trajectory.points else GoalResponse.REJECT

    def _execute(self, handle: Any) -> Any:
        with self._lock:
            self.goals += 1
            self._active = handle
        goal = handle.request
        names = list(goal.trajectory.joint_names)
        if sorted(names) != sorted(self.joints) or len(set(names)) != len(names):
            handle.abort()
            return Result(error_code=Result.INVALID_JOINTS,
                          error_string=f"goal joints {names} are not the controller's joints {self.joints}")
        order = [names.index(joint) for joint in self.joints]
        times = np.array([_seconds(p.time_from_start) for p in goal.trajectory.points])
        points = np.array([[p.positions[i] for i in order] for p in goal.trajectory.points])
        if times[0] > 0:
            times, points = np.concatenate([[0.0], times]), np.vstack([self.positions, points])
        path_tol = _tolerance(goal.path_tolerance, self.joints, np.inf)
        goal_tol = _tolerance(goal.goal_tolerance, self.joints, self.goal_tolerance)
        end = times[-1] + (_seconds(goal.goal_time_tolerance) or self.goal_time)
        t = 0.0
        while True:
            if handle.is_cancel_requested:
                handle.canceled()
                return Result(error_code=Result.SUCCESSFUL, error_string="canceled")
            if self._active is not handle:
                handle.abort()
                return Result(error_code=Result.INVALID_GOAL, error_string="preempted by a newer goal")
            t += self.period
            desired = np.array([np.interp(min(t, times[-1]), times, points[:, j]) for j in range(len(self.joints))])
            self.positions = self.advance(self.positions, desired, self.period)
            error = desired - self.positions
            self._feedback(handle, min(t, times[-1]), desired, error)
            beyond = np.abs(error) > path_tol
            if t <= times[-1] and beyond.any():
                j = int(np.argmax(beyond))
                handle.abort()
                return Result(error_code=Result.PATH_TOLERANCE_VIOLATED,
                              error_string=f"{self.joints[j]}: position error {error[j]:.4g} beyond the path "
                                           f"tolerance {path_tol[j]:.4g} at t = {t:.3f} s")
            if t >= times[-1]:
                final = np.abs(points[-1] - self.positions)
                if (final <= goal_tol).all():
                    handle.succeed()
                    return Result(error_code=Result.SUCCESSFUL, error_string="")
                if t >= end:
                    j = int(np.argmax(final - goal_tol))
                    handle.abort()
                    return Result(error_code=Result.GOAL_TOLERANCE_VIOLATED,
                                  error_string=f"{self.joints[j]}: final error {final[j]:.4g} beyond the goal "
                                               f"tolerance {goal_tol[j]:.4g}")
            time.sleep(self.period)

    def _feedback(self, handle: Any, t: float, desired: np.ndarray, error: np.ndarray) -> None:
        feedback = FollowJointTrajectory.Feedback()
        feedback.header.frame_id = ""
        feedback.joint_names = self.joints
        stamp = JointTrajectoryPoint(positions=desired.tolist())
        split = Duration.from_seconds(t)
        stamp.time_from_start.sec, stamp.time_from_start.nanosec = split.sec, split.nanosec
        feedback.desired = stamp
        feedback.actual = JointTrajectoryPoint(positions=self.positions.tolist())
        feedback.error = JointTrajectoryPoint(positions=error.tolist())
        handle.publish_feedback(feedback)


def main(argv: Sequence[str]) -> None:
    """``[--sim ROBOT] JOINT[=INITIAL] ...``: the arm's joints and their initial positions (default 0); with
    ``--sim``, also ``/sim_controller/follow_joint_trajectory`` driving the built-in ROBOT in MuJoCo (from the
    middle of its joint ranges)."""
    argv = list(argv)
    sim_robot = None
    if argv[:1] == ["--sim"]:
        sim_robot, argv = argv[1], argv[2:]
    joints = [item.partition("=")[0] for item in argv]
    initial = [float(item.partition("=")[2] or 0.0) for item in argv]
    rclpy.init()
    node = Node("trajectory_test_server")
    servers = [TrajectoryServer(node, "/joint_trajectory_controller/follow_joint_trajectory", joints, initial=initial),
               TrajectoryServer(node, "/slow_controller/follow_joint_trajectory", joints, rate_limited(0.2),
                                initial=initial)]
    if sim_robot is not None:
        from pfield.robot import RobotModel
        from pfield.sim import Simulation

        robot = RobotModel.builtin(sim_robot)
        simulation = Simulation(robot)
        servers.append(TrajectoryServer(node, "/sim_controller/follow_joint_trajectory", robot.joint_names,
                                        simulated(simulation), initial=simulation.state.positions,
                                        goal_tolerance=0.01))
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    print(f"serving FollowJointTrajectory for {joints}", flush=True)
    stop.wait()
    executor.shutdown(timeout_sec=5.0)
    thread.join(5.0)
    print(f"goals: {[server.goals for server in servers]}", flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main(sys.argv[1:])
