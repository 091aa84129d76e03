"""pfield's nodes as a real ROS 2 node process (rclpy), beside the HTTP transport.

:class:`Ros2Host` hosts the same transport-free node objects the HTTP server hosts (the manager, the
base controller and the costmap server when configured), one rclpy node per pfield node, named as the
pfield node (``/pfield_manager`` …). It is thin: it decodes an rclpy message into the node's pydantic
model (:mod:`pfield.transport._ros2_convert`), calls the node's handler and encodes the answer. It
exposes, from each node's :class:`~pfield.node.ServiceSpec`/``SubscriptionSpec``/``PublicationSpec``
lists:

* **services** — a handler's ``PfieldError`` (bad input) becomes ``success: false`` with the reason in
  ``error_message``/``message`` when the response has such fields, ``state: LETHAL`` for FindValidPose
  (mbf's "nothing found"); otherwise (``ComputeAutonomyVector``) the default response (a zero twist: no
  autonomy) is returned. The reason is always logged. Long-running
  services (``plan_path``) run in their own callback group on a multi-threaded executor, so that
  ``compute_autonomy_vector`` keeps answering during a plan;
* **subscriptions** — a bad message is logged and dropped; the node's state is unchanged (the node
  validates before changing anything) and it keeps serving. Sensor topics (``sensor_msgs/*``, e.g.
  ``/scan``) use the sensor-data QoS (best effort), others reliable, depth 10; a node that streams commands
  (the servo) keeps depth 1: it acts on the latest command, and a backlog of older ones would only delay it;
* **publications** — what a node publishes on its :class:`~pfield.node.Bus` is converted and
  published by one publisher thread (the latest message per topic, so a slow subscriber never slows a
  handler). Publishers are reliable and transient-local ("latched"): RViz or a late subscriber gets
  the last ``/pfield/planned_path`` and ``/pfield/markers``;
* **parameters** — every node parameter as a ROS parameter (:mod:`pfield.transport._ros2_params`);
* **ticks** — a timer per node with a ``tick_period``;
* **executors** — one multi-threaded executor for the nodes, except that a node that streams commands (a
  ``PublicationSpec`` with ``latched=False``: the servo) and serves nothing long-running spins on a
  single-threaded executor of its own
  (:class:`_Executors`), so a command never waits for another node's callbacks or the shared executor's dispatch;
  while it runs, the GIL changes hands within :data:`STREAMING_SWITCH_INTERVAL`.

Shutdown order matters with rclpy 7.1: stop the executor, join its thread, wait for callbacks still
running, then destroy the nodes and shut the context down; otherwise the process can abort and leave
Fast DDS shared-memory segments in ``/dev/shm`` (docs/ros2.md).
"""

from __future__ import annotations

import logging
import math
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import rclpy
from pydantic import ValidationError
from rclpy.callback_groups import CallbackGroup, MutuallyExclusiveCallbackGroup
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node as RclpyNode
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from pfield.errors import PfieldError
from pfield.interfaces import RosMessage
from pfield.node import Node, PublicationSpec, ServiceSpec, SubscriptionSpec, distinct_buses
from pfield.transport._ros2_convert import from_ros, interface_class, to_ros
from pfield.transport._ros2_params import declare_parameters
from pfield.transport._ros2_publisher import BusPublisher

__all__ = ["LATCHED_QOS", "Ros2Host", "run"]

_LOG = logging.getLogger(__name__)

LATCHED_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""QoS of pfield's publications: reliable, transient local (late subscribers get the last message)."""
_INPUT_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
_LATEST_INPUT_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
_LATEST_SENSOR_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT,
                                durability=DurabilityPolicy.VOLATILE)
_BAD_INPUT = (PfieldError, ValidationError, ValueError, TypeError)


_FAILURE_VALUES: dict[str, dict[str, Any]] = {
    # mbf_msgs' contract: LETHAL (2) when no valid pose is found; never answer FREE to a refused request
    "potential_fields_interfaces/srv/FindValidPose_Response": {"state": 2},
}


def _failure_response(response: type[RosMessage], reason: str) -> RosMessage:
    """The response a service returns for bad input: ``success: false`` plus the reason when the type has
    those fields (PlanPath, RemoveObstacles, std_srvs/Trigger), FindValidPose's ``state: LETHAL``, else
    the default response."""
    fields = response.model_fields
    values: dict[str, Any] = dict(_FAILURE_VALUES.get(response.ros_type, {}))
    if "success" in fields:
        values["success"] = False
    for name in ("error_message", "message"):
        if name in fields:
            values[name] = reason
            break
    return response(**values)


def subscription_class(spec: SubscriptionSpec) -> type | None:
    """The rclpy class of a subscription's type, or None (logged) when its interface package is not built or lacks
    the type — a ``control_msgs`` built before it had JointJog, or none at all: the node's other inputs still work."""
    try:
        return interface_class(spec.type_name)
    except (ModuleNotFoundError, AttributeError) as error:
        _LOG.warning("%s: %s is not available (%s; `make ros2-interfaces` builds pfield's interfaces): not subscribed",
                     spec.topic, spec.type_name, error)
        return None


def _publication_qos(spec: PublicationSpec) -> QoSProfile:
    """:data:`LATCHED_QOS`, or for a stream of commands (``latched=False``: the servo's joint commands) reliable and
    volatile, depth 1 (MoveIt Servo's outgoing commands are volatile too): a controller that connects late must not
    execute an old command, and only the newest one matters."""
    return LATCHED_QOS if spec.latched else STREAM_QOS


STREAM_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
"""QoS of streamed commands (:func:`_publication_qos`)."""


STREAMING_SWITCH_INTERVAL = 0.0005
"""Seconds a thread may hold the GIL while another waits for it (``sys.setswitchinterval``; Python's default 5 ms),
while a node that streams commands runs in the process. The servo's command thread otherwise waits up to 5 ms for
each hand-over from whichever thread runs Python (the publisher, the other nodes' callbacks): ``bench_servo``'s
command-in to command-out p99 12–20 ms and max 22–47 ms with 5, 2 or 1 ms (9 runs), 5.7–7.3 ms and 10–21 ms with
0.5 ms (5 runs); p50 1.3–2.1 and 1.95–3.0 ms (docs/servo.md)."""


_SWITCH_LOCK = threading.Lock()
_streaming_hosts = 0  # hosts with a command-streaming node running in this process
_switch_before = 0.005  # the interpreter's switch interval before the first of them started


def _streaming_started() -> None:
    """The first running host with a command-streaming node lowers the switch interval; others count."""
    global _streaming_hosts, _switch_before
    with _SWITCH_LOCK:
        if _streaming_hosts == 0:
            _switch_before = sys.getswitchinterval()
            sys.setswitchinterval(min(_switch_before, STREAMING_SWITCH_INTERVAL))
        _streaming_hosts += 1


def _streaming_stopped() -> None:
    """The last of them to stop restores the interval it found."""
    global _streaming_hosts
    with _SWITCH_LOCK:
        _streaming_hosts -= 1
        if _streaming_hosts == 0:
            sys.setswitchinterval(_switch_before)


DROP_LOG_PERIOD = 5.0
"""s between two warnings of one kind of a topic's dropped messages (:class:`DropLog`)."""
_DROP_KINDS = 64  # kinds of refusal a DropLog remembers


class DropLog:
    """The warnings of a topic's refused messages: each kind of refusal (its field and reason) at most once per
    :data:`DROP_LOG_PERIOD` s, the first at once, then with how many more of that kind were dropped (a 500 Hz driver
    naming a joint wrongly wrote 500 lines a second). Thread-safe."""

    def __init__(self, topic: str) -> None:
        self.topic = topic
        self._lock = threading.Lock()
        self._kinds: dict[str, tuple[float, int]] = {}  # kind -> (when last warned, dropped since)

    def dropped(self, error: object, now: float | None = None) -> None:
        now = time.monotonic() if now is None else now
        # the same refusal again (one field, one reason: what a flood repeats), whatever its value
        kind = f"{type(error).__name__}:{getattr(error, 'field', '')}:{getattr(error, 'reason', error)}"
        with self._lock:
            logged, since = self._kinds.get(kind, (-math.inf, 0))
            if now - logged < DROP_LOG_PERIOD:
                self._kinds[kind] = (logged, since + 1)
                return
            if len(self._kinds) >= _DROP_KINDS:  # a bounded table: the oldest kinds go
                self._kinds = dict(sorted(self._kinds.items(), key=lambda item: item[1][0])[_DROP_KINDS // 2:])
            self._kinds[kind] = (now, 0)
        _LOG.warning("%s: dropped message: %s%s", self.topic, error,
                     f" ({since} more like it dropped since the last warning)" if since else "")


def _subscription_qos(spec: SubscriptionSpec, latest_only: bool) -> QoSProfile:
    """Sensor topics (``sensor_msgs/*``) best effort, others reliable; depth 10, or 1 with ``latest_only`` (a node
    that streams commands: only the newest input matters, older queued ones are dropped by the middleware)."""
    if spec.type_name.startswith("sensor_msgs/"):
        return _LATEST_SENSOR_QOS if latest_only else qos_profile_sensor_data
    return _LATEST_INPUT_QOS if latest_only else _INPUT_QOS


class _StreamPublisher:
    """Bus listener that publishes streamed commands (``PublicationSpec.latched`` False) in the thread that computed
    them: a servo's joint command goes out at once, without the hand-off to the publisher thread that latched topics
    take (command-in to command-out latency). Conversion errors are logged, never raised into the node."""

    def __init__(self) -> None:
        self._targets: dict[str, tuple[type, Callable[[Any], None]]] = {}

    def register(self, topic: str, message_class: type, publish: Callable[[Any], None]) -> None:
        self._targets[topic] = (message_class, publish)

    def __call__(self, topic: str, message: RosMessage) -> None:
        target = self._targets.get(topic)
        if target is None:
            return
        try:
            target[1](to_ros(message, target[0]))
        except Exception:  # a bad message must not reach the node's handler
            _LOG.exception("%s: could not publish", topic)


def _attach_trajectory_executor(node: Node, ros_node: RclpyNode) -> Any:
    """A node with a ``trajectory_executor`` slot (the manager's ``/pfield/execute_trajectory``) gets a
    FollowJointTrajectory client on its rclpy node (:mod:`pfield.transport.trajectory_client`); None otherwise."""
    if not hasattr(node, "trajectory_executor"):
        return None
    from pfield.transport.trajectory_client import NodeTrajectoryExecutor

    executor = NodeTrajectoryExecutor(ros_node)
    node.trajectory_executor = executor
    return executor


class _InFlight:
    """Counts callbacks running in executor threads so shutdown can wait for them."""

    def __init__(self) -> None:
        self._count = 0
        self._idle = threading.Condition()

    @contextmanager
    def track(self) -> Iterator[None]:
        with self._idle:
            self._count += 1
        try:
            yield
        finally:
            with self._idle:
                self._count -= 1
                self._idle.notify_all()

    def wait_idle(self, timeout: float) -> bool:
        with self._idle:
            return self._idle.wait_for(lambda: self._count == 0, timeout)


class _NodeAdapter:
    """One pfield node on one rclpy node: its services, subscriptions, publishers, parameters, timer."""

    def __init__(self, node: Node, context: Context, in_flight: _InFlight, publisher: BusPublisher,
                 streams: _StreamPublisher | None = None) -> None:
        self.node = node
        self._streams = streams
        self._in_flight = in_flight
        self.ros_node = RclpyNode(node.name.lstrip("/") or "pfield", context=context)
        clock = self.ros_node.get_clock()
        node.stamp_clock = lambda: clock.now().nanoseconds * 1e-9  # ROS time: header stamps are read against it
        self._short = MutuallyExclusiveCallbackGroup()
        self.streams_commands = any(not spec.latched for spec in node.publications())
        """The node streams commands: it spins on an executor of its own and keeps only its latest inputs."""
        self.long_running_groups = 0
        for service in node.services():
            self._add_service(service)
        for subscription in node.subscriptions():
            self._add_subscription(subscription)
        for publication in node.publications():
            self._add_publication(publication, publisher)
        declare_parameters(self.ros_node, node)
        self.trajectory_executor = _attach_trajectory_executor(node, self.ros_node)
        if node.tick_period:
            self.ros_node.create_timer(node.tick_period, self._tick, callback_group=self._short)

    def _add_service(self, spec: ServiceSpec) -> None:
        group: CallbackGroup = self._short
        if spec.long_running:
            group = MutuallyExclusiveCallbackGroup()
            self.long_running_groups += 1
        service_class = interface_class(spec.type_name)
        callback = self._service_callback(spec, service_class.Response)  # type: ignore[attr-defined]
        self.ros_node.create_service(service_class, spec.name, callback, callback_group=group)

    def _service_callback(self, spec: ServiceSpec, response_class: type) -> Callable[[Any, Any], Any]:
        def serve(request: Any, _response: Any) -> Any:
            with self._in_flight.track():
                try:
                    answer = spec.handler(from_ros(request, spec.request))
                except _BAD_INPUT as error:
                    _LOG.warning("%s: refused request: %s", spec.name, error)
                    answer = _failure_response(spec.response, str(error))
                except Exception as error:  # a bug must not take the node down
                    _LOG.exception("%s: handler failed", spec.name)
                    answer = _failure_response(spec.response, f"internal error: {error}")
                return to_ros(answer, response_class)

        return serve

    def _add_subscription(self, spec: SubscriptionSpec) -> None:
        qos = _subscription_qos(spec, self.streams_commands)

        drops = DropLog(spec.topic)

        def receive(message: Any) -> None:
            with self._in_flight.track():
                try:
                    spec.handler(from_ros(message, spec.model))
                except _BAD_INPUT as error:
                    drops.dropped(error)
                except Exception:  # a bug must not take the node down
                    _LOG.exception("%s: handler failed", spec.topic)

        message_class = subscription_class(spec)
        if message_class is not None:
            self.ros_node.create_subscription(message_class, spec.topic, receive, qos, callback_group=self._short)

    def _add_publication(self, spec: PublicationSpec, publisher: BusPublisher) -> None:
        message_class = interface_class(spec.type_name)
        ros_publisher = self.ros_node.create_publisher(message_class, spec.topic, _publication_qos(spec))
        if not spec.latched and self._streams is not None:
            self._streams.register(spec.topic, message_class, ros_publisher.publish)
            return
        publisher.register(spec.topic, message_class, ros_publisher.publish)

    def _tick(self) -> None:
        with self._in_flight.track():
            try:
                self.node.tick(time.monotonic())
            except Exception:  # periodic work must not stop the node
                _LOG.exception("%s: tick failed", self.node.name)


class _Executors:
    """The host's executors, driven as one by :class:`Ros2Host` (``add_node``, ``spin``, ``shutdown``): a shared
    multi-threaded executor, and a single-threaded executor of its own for each node that streams commands.

    Such a node's command is stepped and published in its own executor's thread: it does not wait for the shared
    executor to rebuild the wait set of every node's services and timers, dispatch to a worker thread, or run
    another node's callbacks first (the servo's command-in to command-out latency, ``benchmarks/bench_servo.py``).
    Its own callbacks (inputs, tick, parameter services) still run one at a time, as in its one callback group."""

    def __init__(self, shared: MultiThreadedExecutor) -> None:
        self.shared = shared
        self._own: list[tuple[SingleThreadedExecutor, threading.Thread]] = []

    def add_node(self, ros_node: RclpyNode, own: bool = False) -> None:
        """Spin ``ros_node`` on the shared executor, or with ``own`` on an executor of its own."""
        if not own:
            self.shared.add_node(ros_node)
            return
        executor = SingleThreadedExecutor(context=ros_node.context)
        executor.add_node(ros_node)
        name = f"pfield-ros2-{ros_node.get_name()}"
        self._own.append((executor, threading.Thread(target=executor.spin, name=name, daemon=True)))

    def spin(self) -> None:
        """Start each own executor's thread, then spin the shared executor in this thread until shutdown."""
        for _, thread in self._own:
            thread.start()
        self.shared.spin()

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        """Stop every executor (the own ones first, joining their threads); True when all stopped in time."""
        stopped = True
        for executor, thread in self._own:
            stopped = executor.shutdown(timeout_sec) and stopped
            if thread.ident is not None:
                thread.join(timeout_sec)
                stopped = stopped and not thread.is_alive()
        return self.shared.shutdown(timeout_sec) and stopped


class Ros2Host:
    """Runs pfield nodes as rclpy nodes on a multi-threaded executor in a background thread (a node that streams
    commands on a single-threaded executor of its own: :class:`_Executors`).

    ``args`` are ROS command-line arguments (``["--ros-args", "-p", "influence_distance:=0.2"]``).
    Use as a context manager, or call :meth:`start` and :meth:`shutdown`. The caller owns the nodes
    (and calls their ``close``); the host only attaches to them.
    """

    def __init__(self, nodes: Sequence[Node], args: Sequence[str] = ()) -> None:
        if not nodes:
            raise ValueError("Ros2Host needs at least one node")
        self.nodes = list(nodes)
        self._context = Context()
        rclpy.init(args=["pfield", *args], context=self._context)
        self._in_flight = _InFlight()
        self._publisher = BusPublisher()
        self._streams = _StreamPublisher()
        self._adapters: list[_NodeAdapter] = []
        try:
            for node in self.nodes:
                self._adapters.append(_NodeAdapter(node, self._context, self._in_flight, self._publisher,
                                                   self._streams))
        except BaseException:
            self._destroy()
            raise
        long_running = sum(adapter.long_running_groups for adapter in self._adapters)
        # one thread per long-running group, plus short callbacks and the parameter services
        self._executor = _Executors(MultiThreadedExecutor(num_threads=max(4, long_running + 3),
                                                          context=self._context))
        for adapter in self._adapters:
            # a node with long-running services keeps the shared executor's threads whatever it publishes: on a
            # single-threaded executor a plan would hold up its every other callback
            self._executor.add_node(adapter.ros_node,
                                    own=adapter.streams_commands and not adapter.long_running_groups)
        self._spin_thread: threading.Thread | None = None
        self._streaming = False  # hosting a node that streams commands (STREAMING_SWITCH_INTERVAL)

    def start(self) -> None:
        """Start publishing and spinning (returns at once)."""
        for bus in distinct_buses(self.nodes):
            bus.add_listener(self._publisher.enqueue)
            bus.add_listener(self._streams)
        self._publisher.start()
        if any(adapter.streams_commands for adapter in self._adapters):
            _streaming_started()
            self._streaming = True
        self._spin_thread = threading.Thread(target=self._executor.spin, name="pfield-ros2-executor", daemon=True)
        self._spin_thread.start()
        _LOG.info("ROS 2 nodes up: %s", ", ".join(node.name for node in self.nodes))

    def shutdown(self, timeout: float = 10.0) -> None:
        """Stop in the order rclpy needs: executor, its thread, running callbacks, nodes, context."""
        for bus in distinct_buses(self.nodes):
            bus.remove_listener(self._publisher.enqueue)
            bus.remove_listener(self._streams)
        self._executor.shutdown(timeout_sec=timeout)
        if self._spin_thread is not None:
            self._spin_thread.join(timeout)
        if not self._in_flight.wait_idle(timeout):
            _LOG.warning("callbacks still running after %.0f s at shutdown", timeout)
        self._publisher.stop(timeout)
        if self._streaming:
            _streaming_stopped()
            self._streaming = False
        self._destroy()

    def _destroy(self) -> None:
        for adapter in self._adapters:
            if adapter.trajectory_executor is not None:
                adapter.trajectory_executor.close()
            adapter.ros_node.destroy_node()
        self._adapters.clear()
        if self._context.ok():
            rclpy.shutdown(context=self._context)

    def __enter__(self) -> Ros2Host:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()


def run(nodes: Sequence[Node], args: Sequence[str] = (), stop: threading.Event | None = None,
        on_ready: Callable[[], None] | None = None) -> None:
    """Serve ``nodes`` over ROS 2 until ``stop`` is set (or SIGINT/SIGTERM when ``stop`` is None).

    ``on_ready()`` is called once the nodes are up and the signal handlers are in place, so that a caller who
    announces readiness there can be stopped by a signal from then on with a clean exit."""
    event = stop or threading.Event()
    if stop is None:
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, lambda *_: event.set())
    with Ros2Host(nodes, args):
        if on_ready is not None:
            on_ready()
        while not event.wait(0.5):
            pass
    _LOG.info("ROS 2 nodes stopped")
