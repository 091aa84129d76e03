"""Trajectories out: a ``control_msgs/action/FollowJointTrajectory`` client for ros2_control controllers.

A plan's time-parameterised joint trajectory (:attr:`PlannedPath.trajectory <pfield.planning.PlannedPath>`,
:func:`pfield.planning.retime.retime_joint_path`) goes to a ``joint_trajectory_controller`` as one goal:
``trajectory.joint_names`` and one ``JointTrajectoryPoint`` per sample (positions rad or m, velocities rad/s
or m/s, accelerations rad/s² or m/s², ``time_from_start`` s), plus the optional ``path_tolerance``,
``goal_tolerance`` (per joint: position, velocity, acceleration; 0 = the controller's default, −1 = no limit)
and ``goal_time_tolerance`` (s). The message definitions are control_msgs' (Jazzy, 5.8.0), built by
``make ros2-interfaces`` from ``ros/control_msgs`` (NOTICE.md there).

:class:`TrajectoryClient` sends it and waits in the *caller's* thread (never in an executor callback):

* standalone (Python API, ``pfield execute``): it owns an rclpy context, a node and a single-threaded
  executor spinning in a daemon thread;
* on a node that is already spinning on a multi-threaded executor (``pfield ros2 node``): pass ``node=``; the
  action client gets its own reentrant callback group, and the wait is a ``threading.Event``, so the node's
  other services keep answering while a trajectory runs.

Outcome (:class:`TrajectoryResult`): :class:`TrajectoryOutcome` says what happened to the goal (the action's
terminal status: SUCCEEDED, ABORTED, CANCELED; REJECTED when the server refused it), and
:class:`TrajectoryErrorCode` the controller's ``error_code`` by name (FollowJointTrajectory.Result's constants),
with its ``error_string``. Waiting that cannot end is an error, raised with what to check next:
:class:`ServerUnavailable` (no server at the name within ``server_timeout``), :class:`GoalNotAccepted`
(no accept/reject answer within ``accept_timeout``) and :class:`ResultTimeout` (no result within the
trajectory's duration + ``goal_time_tolerance`` + ``result_margin``; the goal is cancelled then).

Each goal carries its own id (a UUID4), so a goal whose accept answer was lost by DDS (a server answering before
it has discovered this client's reader) is still followed once its feedback arrives, and a goal never answered is
cancelled by its id before :class:`GoalNotAccepted` is raised.
"""

from __future__ import annotations

import itertools
import logging
import math
import os
import threading
import time
import uuid
from collections.abc import Callable, Mapping, Sequence
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

__all__ = ["DEFAULT_ACTION", "ExecutionOptions", "GoalNotAccepted", "ResultTimeout", "ServerUnavailable",
           "TrajectoryClient", "TrajectoryErrorCode", "TrajectoryExecution", "TrajectoryExecutionError",
           "TrajectoryFeedback", "TrajectoryOutcome", "TrajectoryResult", "as_timed_trajectory", "build_goal"]

_LOG = logging.getLogger(__name__)

DEFAULT_ACTION = "/joint_trajectory_controller/follow_joint_trajectory"
"""The action a ros2_control ``joint_trajectory_controller`` named ``joint_trajectory_controller`` serves."""

_STATUS_SUCCEEDED, _STATUS_CANCELED, _STATUS_ABORTED = 4, 5, 6
"""action_msgs/msg/GoalStatus values of the terminal states."""
_POLL = 0.02
"""s: how often a waiting caller looks at its cancel request."""
_SEQUENCE = itertools.count()


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


def _error_code(value: int) -> TrajectoryErrorCode | int:
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


def _feedback_value(message: Any, received: float) -> TrajectoryFeedback:
    stamp = message.desired.time_from_start
    return TrajectoryFeedback(tuple(message.joint_names), float(stamp.sec) + 1e-9 * float(stamp.nanosec),
                              np.array(message.desired.positions, dtype=float),
                              np.array(message.actual.positions, dtype=float),
                              np.array(message.error.positions, dtype=float), received)


# ---- one goal in flight ---------------------------------------------------------------------------------
class TrajectoryExecution:
    """A goal sent by :meth:`TrajectoryClient.send`: :meth:`cancel` it, read :attr:`latest_feedback`, wait for
    :meth:`result`. Thread-safe; the waiting happens in the caller's thread."""

    def __init__(self, action_name: str, goal: Any, options: ExecutionOptions,
                 feedback: Callable[[TrajectoryFeedback], None] | None, client: Any = None,
                 goal_id: Any = None) -> None:
        self.action_name = action_name
        self._client = client
        self.goal_id = goal_id
        self.options = options
        self.duration = goal_duration(goal)
        self._user_feedback = feedback
        self._lock = threading.Lock()
        self._answered = threading.Event()
        self._finished = threading.Event()
        self._cancel_requested = threading.Event()
        self._handle: Any = None
        self._accepted: bool | None = None
        self._raw_result: Any = None
        self._sent = time.monotonic()
        self._accepted_at = math.nan
        self._feedback_count = 0
        self.latest_feedback: TrajectoryFeedback | None = None

    # callbacks (executor thread)
    def _on_feedback(self, message: Any) -> None:
        if not self._answered.is_set():
            self._adopt()
        value = _feedback_value(message.feedback, time.monotonic())
        with self._lock:
            self._feedback_count += 1
            self.latest_feedback = value
        if self._user_feedback is not None:
            try:
                self._user_feedback(value)
            except Exception:  # a user's callback must not stop the executor
                _LOG.exception("%s: feedback callback failed", self.action_name)

    def _on_goal_response(self, future: Any) -> None:
        handle = future.result()
        with self._lock:
            if self._answered.is_set():  # already adopted from its feedback (_adopt)
                return
            self._handle = handle
            self._accepted = bool(handle.accepted)
            self._accepted_at = time.monotonic()
        self._answered.set()
        if not handle.accepted:
            self._finished.set()
            return
        handle.get_result_async().add_done_callback(self._on_result)
        if self._cancel_requested.is_set():
            handle.cancel_goal_async()

    def _standalone_handle(self) -> Any:
        """A client-side handle of this goal id, for a goal whose accept answer never came."""
        from rclpy.action.client import ClientGoalHandle

        response = self._client._action_type.Impl.SendGoalService.Response(accepted=True)
        return ClientGoalHandle(self._client, self.goal_id, response)

    def _adopt(self) -> None:
        """Feedback of this goal arrived before the accept answer: the server executes it. This happens when the
        server received the goal before its DDS discovery of this client finished, so its answer was dropped
        ("failed to send response"); the goal is then followed by its id (feedback, result, cancel)."""
        if self._client is None or self.goal_id is None:
            return
        with self._lock:
            if self._answered.is_set():
                return
            handle = self._handle = self._standalone_handle()
            self._accepted = True
            self._accepted_at = time.monotonic()
        _LOG.info("%s: the goal's accept answer was lost; following it by its feedback", self.action_name)
        self._answered.set()
        handle.get_result_async().add_done_callback(self._on_result)
        if self._cancel_requested.is_set():
            handle.cancel_goal_async()

    def _on_result(self, future: Any) -> None:
        self._raw_result = future.result()
        self._finished.set()

    # caller's side
    @property
    def done(self) -> bool:
        return self._finished.is_set()

    def cancel(self) -> None:
        """Ask the controller to stop this goal (it then ends CANCELED); harmless after the end."""
        self._cancel_requested.set()
        with self._lock:
            handle = self._handle if self._accepted else None
        if handle is not None and not self._finished.is_set():
            handle.cancel_goal_async()

    def result(self, cancel: Any = None) -> TrajectoryResult:
        """Wait for the outcome. ``cancel``: an object with a ``cancelled`` attribute (e.g. a
        :class:`~pfield.planning.CancelToken`) polled while waiting; when it turns true the goal is cancelled.

        Raises :class:`GoalNotAccepted` or :class:`ResultTimeout` (see the module docstring)."""
        options = self.options
        if not self._wait(self._answered, self._sent + options.accept_timeout, cancel):
            self.cancel()  # should the answer come late, the goal is cancelled at once
            if self._client is not None and self.goal_id is not None:  # and should it run unanswered, now
                self._standalone_handle().cancel_goal_async()
            raise GoalNotAccepted(f"{self.action_name}: the action server did not accept or reject the goal within "
                                  f"accept_timeout={options.accept_timeout:g} s (a cancel request for it was sent): "
                                  "is the controller active and its executor spinning?")
        deadline = self._accepted_at + self.duration + options.goal_time_tolerance + options.result_margin
        if self._accepted and not self._wait(self._finished, deadline, cancel):
            self.cancel()
            if not self._finished.wait(options.cancel_timeout):
                raise ResultTimeout(f"{self.action_name}: no result {deadline - self._accepted_at:.3g} s after the "
                                    f"goal was accepted (trajectory {self.duration:.3g} s + goal_time_tolerance "
                                    f"{options.goal_time_tolerance:g} s + result_margin {options.result_margin:g} s)"
                                    "; the goal was cancelled. Is the controller still running?")
        return self._outcome()

    def _wait(self, event: threading.Event, deadline: float, cancel: Any) -> bool:
        while not event.is_set():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return event.is_set()
            if cancel is not None and getattr(cancel, "cancelled", False) and not self._cancel_requested.is_set():
                self.cancel()
                deadline = min(deadline, time.monotonic() + self.options.cancel_timeout)
            event.wait(min(_POLL, remaining))
        return True

    def _outcome(self) -> TrajectoryResult:
        now = time.monotonic()
        with self._lock:
            count = self._feedback_count
        accepted_after = self._accepted_at - self._sent
        if not self._accepted:
            return TrajectoryResult(TrajectoryOutcome.REJECTED, None, "the action server rejected the goal",
                                    accepted_after, now - self._sent, count)
        raw = self._raw_result
        status, result = int(raw.status), raw.result
        outcome = {_STATUS_SUCCEEDED: TrajectoryOutcome.SUCCEEDED,
                   _STATUS_CANCELED: TrajectoryOutcome.CANCELED}.get(status, TrajectoryOutcome.ABORTED)
        return TrajectoryResult(outcome, _error_code(int(result.error_code)), str(result.error_string),
                                accepted_after, now - self._sent, count)


# ---- the client -------------------------------------------------------------------------------------------
class TrajectoryClient:
    """A FollowJointTrajectory action client (see the module docstring).

    ``action_name``: the controller's action (default :data:`DEFAULT_ACTION`). ``node``: an rclpy node spinning
    on a multi-threaded executor to attach to; None makes a private context, node and executor thread (use as
    a context manager, or :meth:`close`). ``args``: ROS arguments of the private context.
    """

    def __init__(self, action_name: str = DEFAULT_ACTION, *, node: Any = None, args: Sequence[str] = ()) -> None:
        from control_msgs.action import FollowJointTrajectory
        from rclpy.action import ActionClient
        from rclpy.callback_groups import ReentrantCallbackGroup

        self.action_name = _action_name(action_name)
        self._own: tuple[Any, Any, threading.Thread] | None = None
        if node is None:
            node = self._start_private(args)
        self.node = node
        self._client = ActionClient(node, FollowJointTrajectory, self.action_name,
                                    callback_group=ReentrantCallbackGroup())

    def _start_private(self, args: Sequence[str]) -> Any:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node

        context = Context()
        rclpy.init(args=["pfield", *args], context=context)
        node = Node(f"pfield_trajectory_client_{os.getpid()}_{next(_SEQUENCE)}", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        thread = threading.Thread(target=executor.spin, name="pfield-trajectory-client", daemon=True)
        thread.start()
        self._own = (context, executor, thread)
        return node

    def wait_for_server(self, timeout: float) -> bool:
        """True when the action server is there within ``timeout`` s."""
        timeout = _validation.in_range("server_timeout", timeout, 0.0, 86400.0, "s")
        return bool(self._client.wait_for_server(timeout_sec=timeout))

    def send(self, trajectory: Any, options: ExecutionOptions | None = None,
             feedback: Callable[[TrajectoryFeedback], None] | None = None) -> TrajectoryExecution:
        """Validate ``trajectory`` (:func:`build_goal`), wait for the server, send the goal and return at once.

        Raises :class:`InvalidInput` (nothing is sent) or :class:`ServerUnavailable`."""
        options = options or ExecutionOptions()
        goal = build_goal(trajectory, options)
        if not self.wait_for_server(options.server_timeout):
            raise ServerUnavailable(f"no FollowJointTrajectory action server at {self.action_name!r} within "
                                    f"server_timeout={options.server_timeout:g} s: is the joint_trajectory_controller "
                                    "loaded and active, and is this the action name it serves "
                                    "(<controller name>/follow_joint_trajectory)?")
        from unique_identifier_msgs.msg import UUID

        goal_id = UUID(uuid=list(uuid.uuid4().bytes))
        execution = TrajectoryExecution(self.action_name, goal, options, feedback, self._client, goal_id)
        future = self._client.send_goal_async(goal, feedback_callback=execution._on_feedback, goal_uuid=goal_id)
        future.add_done_callback(execution._on_goal_response)
        return execution

    def execute(self, trajectory: Any, options: ExecutionOptions | None = None,
                feedback: Callable[[TrajectoryFeedback], None] | None = None, cancel: Any = None) -> TrajectoryResult:
        """:meth:`send` and wait for the :class:`TrajectoryResult` (``cancel``: see
        :meth:`TrajectoryExecution.result`)."""
        return self.send(trajectory, options, feedback).result(cancel)

    def close(self) -> None:
        """Destroy the action client (and the private node, executor and context, in the order rclpy needs)."""
        self._client.destroy()
        if self._own is not None:
            import rclpy

            context, executor, thread = self._own
            self._own = None
            executor.shutdown(timeout_sec=5.0)
            thread.join(5.0)
            self.node.destroy_node()
            if context.ok():
                rclpy.shutdown(context=context)

    def __enter__(self) -> TrajectoryClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _action_name(name: Any) -> str:
    text = _validation.text("controller_action", name)
    if not text or not all(part and (part[0].isalpha() or part[0] == "_") and
                           all(c.isalnum() or c == "_" for c in part) for part in text.lstrip("/").split("/")):
        raise InvalidInput("controller_action", name, "expected a ROS name such as "
                           f"{DEFAULT_ACTION!r} (letters, digits, '_' and '/')")
    return text


class NodeTrajectoryExecutor:
    """The manager's ``trajectory_executor`` on the ROS 2 transport: one :class:`TrajectoryClient` per action
    name on the host's rclpy ``node`` (spinning on its multi-threaded executor), the service's answer built from
    the :class:`TrajectoryResult`. Errors of waiting (:class:`TrajectoryExecutionError`) become ``success: false``
    with the reason; bad input raises :class:`InvalidInput` (the transport answers it as a refused request)."""

    def __init__(self, node: Any) -> None:
        self.node = node
        self._clients: dict[str, TrajectoryClient] = {}
        self._lock = threading.Lock()

    def client(self, action_name: str) -> TrajectoryClient:
        name = _action_name(action_name)
        with self._lock:
            if name not in self._clients:
                self._clients[name] = TrajectoryClient(name, node=self.node)
            return self._clients[name]

    def __call__(self, trajectory: Any, action_name: str, goal_time_tolerance: float, cancel: Any) -> Any:
        from pfield.interfaces.potential_fields_interfaces import ExecuteTrajectory_Response

        options = ExecutionOptions(goal_time_tolerance=goal_time_tolerance)
        build_goal(trajectory, options)  # refuse bad input before a client is made
        client = self.client(action_name)
        try:
            result = client.execute(trajectory, options, cancel=cancel)
        except TrajectoryExecutionError as error:
            _LOG.warning("execute_trajectory: %s", error)
            return ExecuteTrajectory_Response(success=False, error_message=str(error))
        code = 0 if result.error_code is None else int(result.error_code)
        message = result.error_string if result.error_code is not None else result.describe()
        return ExecuteTrajectory_Response(success=result.success, outcome=result.outcome.name, error_code=code,
                                          error_message=message)

    def close(self) -> None:
        with self._lock:
            clients, self._clients = list(self._clients.values()), {}
        for client in clients:
            client.close()
