"""The values of a trajectory's execution and the FollowJointTrajectory goal built from a plan (the client is
:mod:`pfield.transport.trajectory_client`, whose docstring describes both).

Outcomes are values: :class:`TrajectoryOutcome` (the goal's terminal state), :class:`TrajectoryErrorCode` (the
controller's ``error_code`` by the names FollowJointTrajectory.Result defines), :class:`TrajectoryResult` and
:class:`TrajectoryFeedback`; :class:`ExecutionOptions` the tolerances and time-outs; :func:`build_goal` checks a
trajectory and makes the goal message (control_msgs' Jazzy definitions, built by ``make ros2-interfaces``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield import _validation
from pfield._enums import NamedIntEnum
from pfield.errors import InvalidInput, PfieldError
from pfield.interfaces.std_msgs import Duration
from pfield.planning.result import PlannedPath
from pfield.planning.retime import TimedJointTrajectory

__all__ = ["ExecutionOptions", "GoalNotAccepted", "ResultTimeout", "ServerUnavailable", "TrajectoryErrorCode",
           "TrajectoryExecutionError", "TrajectoryFeedback", "TrajectoryOutcome", "TrajectoryResult",
           "as_timed_trajectory", "build_goal", "controller_error_code", "feedback_value", "goal_duration"]


class TrajectoryErrorCode(NamedIntEnum):
    """``control_msgs/action/FollowJointTrajectory`` Result ``error_code`` constants (the controller's code)."""

    SUCCESSFUL = 0
    INVALID_GOAL = -1
    INVALID_JOINTS = -2
    OLD_HEADER_TIMESTAMP = -3
    PATH_TOLERANCE_VIOLATED = -4
    GOAL_TOLERANCE_VIOLATED = -5


class TrajectoryOutcome(NamedIntEnum):
    """What became of a goal: the action's terminal status, or REJECTED when the server refused the goal."""

    SUCCEEDED = 0
    ABORTED = 1
    CANCELED = 2
    REJECTED = 3


class TrajectoryExecutionError(PfieldError):
    """A trajectory could not be executed because waiting for the action server could not end."""


class ServerUnavailable(TrajectoryExecutionError, TimeoutError):
    """No FollowJointTrajectory server answered at the action name within ``server_timeout``."""


class GoalNotAccepted(TrajectoryExecutionError, TimeoutError):
    """The server neither accepted nor rejected the goal within ``accept_timeout``."""


class ResultTimeout(TrajectoryExecutionError, TimeoutError):
    """No result arrived within the trajectory's duration plus the margins (the goal was cancelled)."""


JointToleranceValue = float | tuple[float, float, float]
"""A joint's tolerance: position only (rad or m), or (position, velocity, acceleration)."""


@dataclass(frozen=True)
class ExecutionOptions:
    """How a goal is sent and waited for.

    Attributes:
        path_tolerance, goal_tolerance: ``{joint: position}`` or ``{joint: (position, velocity, acceleration)}``
            (rad, rad/s, rad/s² or m, m/s, m/s²); 0 leaves the controller's default, −1 removes the limit.
        goal_time_tolerance: s after the trajectory's end within which the goal tolerance must be met
            (0: the controller's default).
        server_timeout: s to wait for the action server; accept_timeout: s for the accept/reject answer;
        result_margin: s beyond duration + goal_time_tolerance before :class:`ResultTimeout`.
        cancel_timeout: s to wait for the result after a cancel request.
    """

    path_tolerance: Mapping[str, JointToleranceValue] = field(default_factory=dict)
    goal_tolerance: Mapping[str, JointToleranceValue] = field(default_factory=dict)
    goal_time_tolerance: float = 0.0
    server_timeout: float = 5.0
    accept_timeout: float = 5.0
    result_margin: float = 10.0
    cancel_timeout: float = 5.0

    def __post_init__(self) -> None:
        for name in ("path_tolerance", "goal_tolerance"):
            object.__setattr__(self, name, _tolerances(name, getattr(self, name)))
        object.__setattr__(self, "goal_time_tolerance",
                           _validation.in_range("goal_time_tolerance", self.goal_time_tolerance, 0.0, 3600.0, "s"))
        for name in ("server_timeout", "accept_timeout", "result_margin", "cancel_timeout"):
            object.__setattr__(self, name, _validation.in_range(name, getattr(self, name), 0.0, 86400.0, "s"))


def _tolerances(name: str, values: Any) -> dict[str, tuple[float, float, float]]:
    if not isinstance(values, Mapping):
        raise InvalidInput(name, values, "expected a mapping {joint name: tolerance}")
    checked: dict[str, tuple[float, float, float]] = {}
    for joint, value in values.items():
        label = f"{name}[{joint!r}]"
        _validation.text(label, joint)
        triple = (value, 0.0, 0.0) if not isinstance(value, tuple | list) else tuple(value)
        if len(triple) != 3:
            raise InvalidInput(label, value, "expected a position tolerance or (position, velocity, acceleration)")
        numbers = tuple(_validation.finite(label, v) for v in triple)
        if any(v < 0 and v != -1 for v in numbers):
            raise InvalidInput(label, value, "each tolerance must be >= 0 (0: the controller's default) or -1 "
                               "(no limit)")
        checked[str(joint)] = (numbers[0], numbers[1], numbers[2])
    return checked


@dataclass(frozen=True)
class TrajectoryFeedback:
    """One feedback message of the controller, as arrays in ``joint_names`` order.

    ``time_from_start``: s, of the desired (reference) sample; ``desired``/``actual``/``error``: positions (rad
    or m; error = desired − actual as control_msgs defines it); ``received``: monotonic s of arrival.
    """

    joint_names: tuple[str, ...]
    time_from_start: float
    desired: NDArray[np.float64]
    actual: NDArray[np.float64]
    error: NDArray[np.float64]
    received: float


@dataclass(frozen=True)
class TrajectoryResult:
    """What became of one trajectory goal.

    ``error_code`` is the controller's code by name (a plain int when the controller sent a code control_msgs
    does not define; None when the goal was rejected, so no result exists), ``error_string`` its text;
    ``accepted_after``: s from sending to the accept/reject answer; ``duration``: s from sending to the result;
    ``feedback_count``: feedback messages received.
    """

    outcome: TrajectoryOutcome
    error_code: TrajectoryErrorCode | int | None
    error_string: str
    accepted_after: float
    duration: float
    feedback_count: int

    @property
    def success(self) -> bool:
        """Succeeded and the controller's code is SUCCESSFUL."""
        return self.outcome is TrajectoryOutcome.SUCCEEDED and self.error_code == TrajectoryErrorCode.SUCCESSFUL

    def describe(self) -> str:
        """One line for a user: the outcome, the code by name and the controller's text."""
        code = "" if self.error_code is None else f" ({self.error_code})"
        text = f": {self.error_string}" if self.error_string else ""
        return f"{self.outcome}{code}{text}"


def controller_error_code(value: int) -> TrajectoryErrorCode | int:
    try:
        return TrajectoryErrorCode(value)
    except ValueError:
        return int(value)


# ---- the goal ---------------------------------------------------------------------------------------------
def as_timed_trajectory(trajectory: Any) -> TimedJointTrajectory:
    """``trajectory`` as a checked :class:`TimedJointTrajectory`.

    Accepts a :class:`PlannedPath` (its retimed :attr:`~pfield.planning.PlannedPath.trajectory`), a
    :class:`TimedJointTrajectory`, or a ``trajectory_msgs/JointTrajectory`` (pfield's pydantic model, or any
    object with ``joint_names`` and ``points``): velocities and accelerations may be empty (sent as empty, the
    controller then interpolates positions), otherwise one value per joint.
    """
    return _goal_trajectory(trajectory)[0]


def _goal_trajectory(trajectory: Any) -> tuple[TimedJointTrajectory, bool, bool]:
    """(checked trajectory, velocities given, accelerations given)."""
    if isinstance(trajectory, PlannedPath):
        if trajectory.trajectory is None:
            raise InvalidInput("path.trajectory", None, "the plan has no time-parameterised joint trajectory: plan "
                               "with a robot (whole_body, or task_space with starting joint angles) so that it has "
                               "one")
        return _checked(trajectory.trajectory, "path.trajectory"), True, True
    if isinstance(trajectory, TimedJointTrajectory):
        return _checked(trajectory, "trajectory"), True, True
    if hasattr(trajectory, "joint_names") and hasattr(trajectory, "points"):
        return _from_message(trajectory)
    raise InvalidInput("trajectory", trajectory, "expected a PlannedPath, a TimedJointTrajectory or a "
                       "trajectory_msgs/JointTrajectory")


def _from_message(message: Any) -> tuple[TimedJointTrajectory, bool, bool]:
    names = list(message.joint_names)
    points = list(message.points)
    if not points:
        raise InvalidInput("trajectory.points", [], "a trajectory needs at least one point")
    count = len(names)
    times: list[float] = []
    positions: list[NDArray[np.float64]] = []
    velocities: list[NDArray[np.float64] | None] = []
    accelerations: list[NDArray[np.float64] | None] = []
    for i, point in enumerate(points):
        stamp = point.time_from_start
        times.append(float(stamp.sec) + 1e-9 * float(stamp.nanosec))
        positions.append(_validation.as_vector(f"trajectory.points[{i}].positions", list(point.positions), count))
        for label, given, into in (("velocities", point.velocities, velocities),
                                   ("accelerations", point.accelerations, accelerations)):
            values = list(given)
            into.append(None if not values else
                        _validation.as_vector(f"trajectory.points[{i}].{label}", values, count))
    empty = np.zeros((len(points), count))

    def stack(label: str, rows: list[Any]) -> NDArray[np.float64]:
        given = [row is not None for row in rows]
        if any(given) and not all(given):
            first = given.index(not given[0])
            raise InvalidInput(f"trajectory.points[{first}].{label}", "", "give them at every point or at none")
        return np.array(rows) if all(given) else empty

    timed = TimedJointTrajectory(tuple(names), np.array(times), np.array(positions),
                                 stack("velocities", velocities), stack("accelerations", accelerations),
                                 np.full(count, np.inf), np.full(count, np.inf))
    return (_checked(timed, "trajectory"), all(v is not None for v in velocities),
            all(a is not None for a in accelerations))


def _checked(timed: TimedJointTrajectory, label: str) -> TimedJointTrajectory:
    names = timed.joint_names
    if not names:
        raise InvalidInput(f"{label}.joint_names", [], "a trajectory needs at least one joint name")
    for i, name in enumerate(names):
        _validation.text(f"{label}.joint_names[{i}]", name)
        if not name:
            raise InvalidInput(f"{label}.joint_names[{i}]", name, "joint names must not be empty")
    if len(set(names)) != len(names):
        duplicate = next(name for name in names if names.count(name) > 1)
        raise InvalidInput(f"{label}.joint_names", list(names), f"joint {duplicate!r} appears twice")
    times = timed.times
    if times.ndim != 1 or len(times) == 0 or not np.all(np.isfinite(times)) or times[0] < 0:
        raise InvalidInput(f"{label}.times", times.tolist()[:4], "expected finite times_from_start >= 0 s")
    steps = np.diff(times)
    if np.any(steps <= 0):
        bad = int(np.argmax(steps <= 0)) + 1
        raise InvalidInput(f"{label}.points[{bad}].time_from_start", float(times[bad]),
                           f"must be later than the previous point's ({float(times[bad - 1])} s): a controller "
                           "refuses times that do not strictly increase")
    if times[-1] >= 2**31 - 1:
        raise InvalidInput(f"{label}.times", float(times[-1]), "beyond builtin_interfaces/Duration (int32 s)")
    shape = (len(times), len(names))
    for part in ("positions", "velocities", "accelerations"):
        values = getattr(timed, part)
        if values.shape != shape:
            raise InvalidInput(f"{label}.{part}", values.shape, f"expected shape {shape} (points, joints)")
        if not np.all(np.isfinite(values)):
            row, col = np.argwhere(~np.isfinite(values))[0]
            raise InvalidInput(f"{label}.points[{row}].{part}[{col}]", float(values[row, col]), "must be finite")
    return timed


def build_goal(trajectory: Any, options: ExecutionOptions | None = None) -> Any:
    """The ``FollowJointTrajectory.Goal`` for ``trajectory`` (see :func:`as_timed_trajectory`) and ``options``.

    The header stamp is left at 0 ("start now", as joint_trajectory_controller reads it), every point's
    ``time_from_start`` is the trajectory's time (s, split into int32 s and uint32 ns), and the tolerances name
    joints of the trajectory only (another name raises :class:`InvalidInput`).
    """
    from builtin_interfaces.msg import Duration as RosDuration
    from control_msgs.action import FollowJointTrajectory
    from control_msgs.msg import JointTolerance
    from trajectory_msgs.msg import JointTrajectoryPoint

    options = options or ExecutionOptions()
    timed, with_velocities, with_accelerations = _goal_trajectory(trajectory)
    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = list(timed.joint_names)
    points = []
    for i, t in enumerate(timed.times):
        point = JointTrajectoryPoint()
        point.positions = timed.positions[i].tolist()
        if with_velocities:
            point.velocities = timed.velocities[i].tolist()
        if with_accelerations:
            point.accelerations = timed.accelerations[i].tolist()
        point.time_from_start = _duration(RosDuration, float(t))
        points.append(point)
    goal.trajectory.points = points
    for name in ("path_tolerance", "goal_tolerance"):
        rows = []
        for joint, (position, velocity, acceleration) in getattr(options, name).items():
            if joint not in timed.joint_names:
                raise InvalidInput(f"{name}[{joint!r}]", joint, f"not a joint of the trajectory "
                                   f"{list(timed.joint_names)}")
            rows.append(JointTolerance(name=joint, position=position, velocity=velocity, acceleration=acceleration))
        setattr(goal, name, rows)
    goal.goal_time_tolerance = _duration(RosDuration, options.goal_time_tolerance)
    return goal


def _duration(duration_class: Any, seconds: float) -> Any:
    """An rclpy ``builtin_interfaces/Duration`` of ``seconds``, split as pfield's model splits it."""
    split = Duration.from_seconds(seconds)
    return duration_class(sec=split.sec, nanosec=split.nanosec)


def goal_duration(goal: Any) -> float:
    """s: the last point's ``time_from_start`` of a goal."""
    points = goal.trajectory.points
    if not points:
        return 0.0
    stamp = points[-1].time_from_start
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def feedback_value(message: Any, received: float) -> TrajectoryFeedback:
    stamp = message.desired.time_from_start
    return TrajectoryFeedback(tuple(message.joint_names), float(stamp.sec) + 1e-9 * float(stamp.nanosec),
                              np.array(message.desired.positions, dtype=float),
                              np.array(message.actual.positions, dtype=float),
                              np.array(message.error.positions, dtype=float), received)


# ---- one goal in flight ---------------------------------------------------------------------------------
