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
from collections.abc import Callable, Sequence
from typing import Any

from pfield import _validation
from pfield.errors import InvalidInput
from pfield.transport._trajectory_goal import (
    ExecutionOptions,
    GoalNotAccepted,
    ResultTimeout,
    ServerUnavailable,
    TrajectoryErrorCode,
    TrajectoryExecutionError,
    TrajectoryFeedback,
    TrajectoryOutcome,
    TrajectoryResult,
    as_timed_trajectory,
    build_goal,
    controller_error_code,
    feedback_value,
    goal_duration,
)

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
        value = feedback_value(message.feedback, time.monotonic())
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
        return TrajectoryResult(outcome, controller_error_code(int(result.error_code)), str(result.error_string),
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
