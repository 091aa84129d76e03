"""A physics check of pfield's plans: the robot in MuJoCo (Todorov et al., "MuJoCo", IROS 2012), driven by servos.

``Simulation(robot, obstacles)`` compiles the model of :mod:`pfield.sim.model`. Two ways to drive it:

* :meth:`Simulation.execute` plays a :class:`~pfield.planning.PlannedPath`'s retimed joint trajectory (what a
  ros2_control ``joint_trajectory_controller`` receives) at the simulation rate: between the trajectory's points the
  reference is the cubic Hermite interpolant of their positions and velocities (the controller's spline with
  position and velocity), and each servo gets u = q_ref + (kv/kp)·q̇_ref, so that its law is the PD with velocity
  feed-forward τ = kp·(q_ref − q) + kv·(q̇_ref − q̇) (:mod:`pfield.sim.gains`). After the last point the final
  reference is held for ``settle`` seconds. The :class:`~pfield.sim.report.ExecutionReport` gives the tracking
  error, the end effector's final error against the goal pose (pfield's forward kinematics of the simulated joints),
  the contacts and the time.
* :meth:`Simulation.step` holds one command (positions, velocities, or both) for ``dt`` and returns the
  :class:`~pfield.sim.report.JointState`: what a servo loop or a ``FollowJointTrajectory`` action server calls each
  cycle. A velocity command alone moves the reference at that velocity (a velocity interface through the position
  servo).

Contacts are counted after every step (:class:`~pfield.sim.report.ContactTally`), robot–obstacle and robot–robot
apart. Refused input (wrong joint count, NaN, a path of another robot, angles beyond the limits) raises
:class:`~pfield.errors.InvalidInput` and changes nothing.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._validation import as_vector, nonnegative, positive
from pfield.errors import InvalidInput
from pfield.geometry import Obstacle
from pfield.planning.result import PlannedPath
from pfield.planning.retime import TimedJointTrajectory
from pfield.robot import RobotModel
from pfield.robot.model import LIMIT_TOLERANCE
from pfield.sim.gains import ServoGains
from pfield.sim.model import DEFAULT_TIMESTEP, GEOM_OBSTACLE, GEOM_ROBOT, SimModel, build_model, mujoco
from pfield.sim.report import ContactTally, ExecutionReport, JointState
from pfield.spatial import Pose

__all__ = ["DEFAULT_SETTLE", "MAX_STEP_DURATION", "MAX_TIMESTEP", "Simulation", "hermite_reference"]

MAX_TIMESTEP = 0.01
"""s: the longest physics step a Simulation takes (100 Hz; the default is 1 ms, see pfield.sim.model)."""
MAX_STEP_DURATION = 60.0
"""s: the longest one :meth:`Simulation.step` holds a command (a minute of simulated time, under a second of CPU at
1 ms): a call returns in bounded time whatever dt it is given."""
DEFAULT_SETTLE = 0.5
"""s: how long :meth:`Simulation.execute` holds the final point after the trajectory (the servos settle)."""


def hermite_reference(trajectory: TimedJointTrajectory, times: ArrayLike) -> tuple[NDArray[np.float64],
                                                                                NDArray[np.float64]]:
    """Positions and velocities (K, n) of the cubic Hermite interpolant of ``trajectory`` at ``times`` (K,), s.

    On [t_i, t_{i+1}], h = t_{i+1} − t_i, s = (t − t_i)/h:
    q = h00·q_i + h10·h·v_i + h01·q_{i+1} + h11·h·v_{i+1}, with h00 = 2s³ − 3s² + 1, h10 = s³ − 2s² + s,
    h01 = −2s³ + 3s², h11 = s³ − s²; q̇ is its derivative. Before the first point and after the last the
    reference rests there.
    """
    t_knots, q, v = trajectory.times, trajectory.positions, trajectory.velocities
    t = np.clip(np.asarray(times, dtype=np.float64), t_knots[0], t_knots[-1])
    if len(t_knots) == 1:
        return np.repeat(q[:1], len(t), axis=0), np.zeros((len(t), q.shape[1]))
    i = np.clip(np.searchsorted(t_knots, t, side="right") - 1, 0, len(t_knots) - 2)
    h = (t_knots[i + 1] - t_knots[i])[:, None]
    s = ((t - t_knots[i])[:, None]) / h
    s2, s3 = s * s, s * s * s
    positions = ((2 * s3 - 3 * s2 + 1) * q[i] + (s3 - 2 * s2 + s) * h * v[i] + (-2 * s3 + 3 * s2) * q[i + 1]
                 + (s3 - s2) * h * v[i + 1])
    velocities = ((6 * s2 - 6 * s) * q[i] / h + (3 * s2 - 4 * s + 1) * v[i] + (-6 * s2 + 6 * s) * q[i + 1] / h
                  + (3 * s2 - 2 * s) * v[i + 1])
    return positions, velocities



def _at_most(field: str, value: float, limit: float, why: str) -> float:
    if value > limit:
        raise InvalidInput(field, value, f"must be <= {limit:g} s: {why}")
    return value

class _Counter:
    """Running contact tally of one run (reset with the simulation)."""

    def __init__(self) -> None:
        self.steps = [0, 0]
        self.pairs: list[set[str]] = [set(), set()]
        self.depth = [0.0, 0.0]

    def tally(self) -> ContactTally:
        return ContactTally(self.steps[0], tuple(sorted(self.pairs[0])), self.depth[0],
                            self.steps[1], tuple(sorted(self.pairs[1])), self.depth[1])


class Simulation:
    """The robot among obstacles in MuJoCo, with position servos (module docstring).

    ``gains`` default to Menagerie's for the robot (else the documented rule); ``timestep`` is the physics step
    (s, default 2 ms); ``gravity_compensation`` as in :func:`~pfield.sim.model.build_model`. The robot starts at rest
    at ``q0`` (default: the middle of its joint ranges).
    """

    def __init__(self, robot: RobotModel, obstacles: Sequence[Obstacle] = (), *, gains: ServoGains | None = None,
                 timestep: float = DEFAULT_TIMESTEP, gravity_compensation: bool = True,
                 q0: ArrayLike | None = None) -> None:
        self.robot = robot
        step = _at_most("timestep", positive("timestep", timestep), MAX_TIMESTEP,
                        "longer physics steps make a stiff arm unstable")
        self.sim_model: SimModel = build_model(robot, obstacles, gains=gains, timestep=step,
                                               gravity_compensation=gravity_compensation)
        self.model = self.sim_model.model
        self.data = mujoco.MjData(self.model)
        gains = self.sim_model.gains
        self._feedforward = np.asarray(gains.kv) / np.asarray(gains.kp)
        kind = self.sim_model.geom_kind
        self._robot_geom = kind == GEOM_ROBOT
        self._obstacle_geom = kind == GEOM_OBSTACLE
        self._geom_body = np.asarray(self.model.geom_bodyid)
        self._counter = _Counter()
        self._reference = np.zeros(robot.n_joints)
        self.reset(robot.mid_configuration if q0 is None else q0)
        self.base_overlaps = self._base_overlaps()

    # ---- state -------------------------------------------------------------------------------------------------
    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    @property
    def contacts(self) -> ContactTally:
        """Contacts counted since the last :meth:`reset`."""
        return self._counter.tally()

    @property
    def state(self) -> JointState:
        d = self.data
        return JointState(float(d.time), np.array(d.qpos), np.array(d.qvel), np.array(d.actuator_force))

    def reset(self, q: ArrayLike) -> JointState:
        """Put the robot at rest at joint angles ``q`` (validated as every pfield entry point does), time 0, and
        clear the contact tally."""
        values = self.robot.check_joint_angles(q, "q")
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = values
        self.data.ctrl[:] = values
        mujoco.mj_forward(self.model, self.data)
        self._reference = values.copy()
        self._counter = _Counter()
        return self.state

    # ---- stepping ----------------------------------------------------------------------------------------------
    def step(self, positions: ArrayLike | None = None, velocities: ArrayLike | None = None,
             dt: float | None = None) -> JointState:
        """Hold a command for ``dt`` seconds (rounded to whole physics steps, at least one; default one step).

        ``positions`` (n,) is the servo reference (rad or m, within the limits); ``velocities`` (n,) its
        velocity (feed-forward), or, given alone, the rate at which the reference moves from where it is.
        """
        if positions is None and velocities is None:
            raise InvalidInput("command", None, "give positions, velocities or both")
        n = self.robot.n_joints
        target = None if positions is None else self.robot.check_joint_angles(positions, "positions")
        rate = np.zeros(n) if velocities is None else np.array(as_vector("velocities", velocities, n))
        count = 1 if dt is None else max(1, round(_at_most("dt", positive("dt", dt), MAX_STEP_DURATION,
                                                           "hold longer commands over several calls") / self.timestep))
        h = self.timestep
        for k in range(count):
            if target is None:
                reference = np.clip(self._reference + rate * h * (k + 1), self.robot.lower_limits,
                                    self.robot.upper_limits)
            else:
                reference = target
            self._advance(reference, rate)
        self._reference = reference
        return self.state

    def _advance(self, reference: NDArray[np.float64], rate: NDArray[np.float64]) -> None:
        self.data.ctrl[:] = reference + self._feedforward * rate
        mujoco.mj_step(self.model, self.data)
        if self.data.ncon:
            self._count_contacts()

    def _count_contacts(self) -> None:
        contact = self.data.contact
        geoms, depth = np.asarray(contact.geom), -np.asarray(contact.dist)
        robot_a, robot_b = self._robot_geom[geoms[:, 0]], self._robot_geom[geoms[:, 1]]
        obstacle = (robot_a & self._obstacle_geom[geoms[:, 1]]) | (robot_b & self._obstacle_geom[geoms[:, 0]])
        own = robot_a & robot_b
        for kind, mask in enumerate((obstacle, own)):
            if not mask.any():
                continue
            self._counter.steps[kind] += 1
            self._counter.depth[kind] = max(self._counter.depth[kind], float(depth[mask].max()))
            for a, b in geoms[mask]:
                first, second = (b, a) if self._obstacle_geom[a] else (a, b)  # the robot's link first
                self._counter.pairs[kind].add(f"{self._geom_owner(first)}/{self._geom_owner(second)}")

    def _geom_owner(self, geom: int) -> str:
        if self._obstacle_geom[geom]:
            return self.sim_model.obstacle_ids[int(self.sim_model.geom_obstacle[geom])]
        return self.sim_model.body_links[int(self._geom_body[geom])]

    def _base_overlaps(self) -> tuple[str, ...]:
        """Pairs of base geometry (welded to the world) and obstacles closer than 0: MuJoCo never collides two
        geoms of the world body, so these are measured once (``mj_geomDistance``)."""
        base = np.flatnonzero(self._robot_geom & (self._geom_body == 0))
        found, fromto = set(), np.zeros(6)
        for g in base:
            for o in np.flatnonzero(self._obstacle_geom):
                if mujoco.mj_geomDistance(self.model, self.data, int(g), int(o), 0.01, fromto) < 0.0:
                    found.add(f"{self._geom_owner(int(g))}/{self._geom_owner(int(o))}")
        return tuple(sorted(found))

    # ---- trajectories ------------------------------------------------------------------------------------------
    def _checked_trajectory(self, path: PlannedPath) -> TimedJointTrajectory:
        if not isinstance(path, PlannedPath):
            raise InvalidInput("path", path, "expected a pfield PlannedPath")
        trajectory = path.trajectory
        if trajectory is None:
            raise InvalidInput("path.trajectory", None, "the path has no joint trajectory (a task-space plan): plan "
                               "whole-body or attach one with pfield.planning.joint_trajectory.attach_joint_trajectory")
        if tuple(trajectory.joint_names) != self.robot.joint_names:
            raise InvalidInput("path.trajectory.joint_names", list(trajectory.joint_names),
                               f"a trajectory of other joints; this simulation's robot {self.robot.name!r} has "
                               f"{list(self.robot.joint_names)}")
        for name in ("times", "positions", "velocities"):
            if not np.all(np.isfinite(getattr(trajectory, name))):
                raise InvalidInput(f"path.trajectory.{name}", "array", "must be finite (no NaN or inf)")
        beyond = (trajectory.positions < self.robot.lower_limits - LIMIT_TOLERANCE) | \
                 (trajectory.positions > self.robot.upper_limits + LIMIT_TOLERANCE)
        if beyond.any():
            i, j = (int(x) for x in np.argwhere(beyond)[0])
            raise InvalidInput(f"path.trajectory.positions[{i}][{j}]", float(trajectory.positions[i, j]),
                               f"outside the limits of {self.robot.joint_names[j]}")
        if len(trajectory.times) > 1 and not np.all(np.diff(trajectory.times) > 0):
            raise InvalidInput("path.trajectory.times", "array", "must be strictly increasing")
        return trajectory

    def execute(self, path: PlannedPath, goal: Pose | None = None, *,
                settle: float = DEFAULT_SETTLE) -> ExecutionReport:
        """Play ``path``'s retimed joint trajectory from rest at its first point (module docstring).

        ``goal`` is the pose the end effector should reach (default: the plan's last waypoint); ``settle`` (s, ≥ 0)
        how long the final point is held before the final errors are measured.
        """
        trajectory = self._checked_trajectory(path)
        if goal is not None and not isinstance(goal, Pose):
            raise InvalidInput("goal", goal, "expected a pfield Pose")
        hold = nonnegative("settle", settle)
        target = goal if goal is not None else Pose(path.positions[-1], path.orientations[-1])
        begin = time.perf_counter()
        self.reset(trajectory.positions[0])
        h = self.timestep
        playing = int(np.ceil(trajectory.duration / h))
        count = playing + int(np.ceil(hold / h))
        references, rates = hermite_reference(trajectory, (np.arange(count) + 1) * h)
        rates[playing:] = 0.0
        worst, worst_joint = 0.0, 0
        for k in range(count):
            self._advance(references[k], rates[k])
            if k < playing:
                error = np.abs(self.data.qpos - references[k])
                j = int(np.argmax(error))
                if error[j] > worst:
                    worst, worst_joint = float(error[j]), j
        self._reference = references[-1].copy()
        final = np.array(self.data.qpos)
        reached = self.robot.forward_kinematics(np.clip(final, self.robot.lower_limits, self.robot.upper_limits))
        return ExecutionReport(
            duration=trajectory.duration, simulated_time=float(self.data.time), wall_time=time.perf_counter() - begin,
            steps=count, max_tracking_error=worst, max_tracking_joint=self.robot.joint_names[worst_joint],
            final_tracking_error=float(np.max(np.abs(final - trajectory.positions[-1]))),
            final_position_error=reached.translation_distance(target),
            final_rotation_error=reached.rotation_distance(target), contacts=self.contacts,
            base_overlaps=self.base_overlaps, final_positions=final, final_pose=reached)
