"""The transport-free node contract shared by every pfield node and both transports (HTTP, ROS 2).

A node owns state and message handlers and knows nothing of sockets. It declares what it serves as
:class:`ServiceSpec`, :class:`SubscriptionSpec` and :class:`PublicationSpec` lists using ROS names and
types; a transport (``pfield.transport.http`` or ``pfield.transport.ros2``) exposes those and forwards
decoded requests to the handlers. Outgoing messages go through a :class:`Bus`, which keeps the latest
message per topic and notifies listeners (the transports) on every publish.

Error contract: handlers raise :class:`~pfield.errors.PfieldError` subclasses (usually ``InvalidInput``)
for bad input *before* changing any state; services whose response has ``success``/``error_message``
report planner failures there instead of raising.
"""

from __future__ import annotations

import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pfield.interfaces import RosMessage

__all__ = ["Bus", "Node", "PublicationSpec", "ServiceSpec", "SubscriptionSpec", "distinct_buses"]


@dataclass(frozen=True)
class ServiceSpec:
    """A service a node serves: ``name`` (``/pfield/plan_path``), ROS ``type_name`` and the handler."""

    name: str
    type_name: str
    request: type[RosMessage]
    response: type[RosMessage]
    handler: Callable[[Any], RosMessage]
    long_running: bool = False
    """True when a call may take long (planning): transports run it off their event loop / in its own
    callback group so that short calls keep answering."""
    cancellable: bool = False
    """True when the handler accepts ``cancel=`` a :class:`~pfield.planning.CancelToken`; transports pass
    one per call and cancel it when the caller goes away (HTTP client disconnected, ROS request dropped)."""
    quick: Callable[[Any], bool] | None = None
    """Given a decoded request: True when the node knows this call to be cheap now (the same kind of call,
    on the same derived state, answered within the node's bound a moment ago). A transport may then run it
    on its event loop instead of handing it to a thread (HTTP: a control-loop call saves two thread
    hand-offs); anything else, or a call it cannot judge, goes to the thread as usual."""


@dataclass(frozen=True)
class SubscriptionSpec:
    """A topic a node listens to, with the handler called for every message."""

    topic: str
    type_name: str
    model: type[RosMessage]
    handler: Callable[[Any], None]


@dataclass(frozen=True)
class PublicationSpec:
    """A topic a node publishes (through its :class:`Bus`)."""

    topic: str
    type_name: str
    model: type[RosMessage]
    latched: bool = True
    """Late subscribers get the last message (ROS: transient local). False for streamed commands (the servo's), which
    a controller that connects later must never receive stale."""


Listener = Callable[[str, RosMessage], None]


class Bus:
    """In-process topic bus: the latest message per topic plus listeners called on every publish.

    Topics published with ``declare=True`` (the default: what nodes publish, and the topics they subscribe to)
    keep their latest message. Topics published with ``declare=False`` (a transport relaying a client's
    message on a topic no node declared) reach the listeners, and only the ``max_undeclared`` most recently
    published of them keep a latest message; older ones are forgotten, so junk topic names cost bounded
    memory. Thread-safe. Listeners must not block (transports enqueue and return).
    """

    def __init__(self, max_undeclared: int = 16) -> None:
        self.max_undeclared = max_undeclared
        self._lock = threading.Lock()
        self._latest: dict[str, RosMessage] = {}
        self._declared: set[str] = set()
        self._undeclared: dict[str, None] = {}  # insertion order = publication order (oldest first)
        self._listeners: list[Listener] = []

    def declare(self, *topics: str) -> None:
        """Keep the latest message of ``topics`` whoever publishes on them."""
        with self._lock:
            self._declared.update(topics)
            for topic in topics:
                self._undeclared.pop(topic, None)

    def publish(self, topic: str, message: RosMessage, *, declare: bool = True) -> None:
        with self._lock:
            if declare:
                self._declared.add(topic)
                self._undeclared.pop(topic, None)
            elif topic not in self._declared:
                self._undeclared.pop(topic, None)
                self._undeclared[topic] = None
                while len(self._undeclared) > self.max_undeclared:
                    oldest = next(iter(self._undeclared))
                    del self._undeclared[oldest]
                    self._latest.pop(oldest, None)
            self._latest[topic] = message
            listeners = list(self._listeners)
        for listener in listeners:
            listener(topic, message)

    def latest(self, topic: str) -> RosMessage | None:
        with self._lock:
            return self._latest.get(topic)

    def topics(self) -> list[str]:
        with self._lock:
            return sorted(self._latest)

    def add_listener(self, listener: Listener) -> None:
        with self._lock:
            self._listeners.append(listener)

    def remove_listener(self, listener: Listener) -> None:
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)


class Node(ABC):
    """Base of the transport-free nodes (``/pfield_manager``, ``/costmap``, ``/base_controller``)."""

    name: str = ""
    """ROS node name with leading slash; parameters are addressed by it (``pfield param get /costmap``)."""
    tick_period: float | None = None
    """Seconds between :meth:`tick` calls made by the transport, or None for no periodic work."""

    def __init__(self, bus: Bus) -> None:
        self.bus = bus
        self.stamp_clock: Callable[[], float] = time.time
        """The clock of header stamps, those read and those written (s since the epoch): this machine's wall clock, or
        the rclpy node's (ROS time, which follows ``use_sim_time``) once a ROS 2 transport serves the node."""

    def stamp_age(self, stamp: Any) -> float | None:
        """Seconds since a message's ``header.stamp`` (a ``builtin_interfaces/Time``) on :attr:`stamp_clock`; None for
        a zero stamp (the publisher did not date it). Negative for a stamp ahead of that clock."""
        if not (stamp.sec or stamp.nanosec):
            return None
        return float(self.stamp_clock() - stamp.to_seconds())

    @abstractmethod
    def services(self) -> list[ServiceSpec]: ...

    @abstractmethod
    def subscriptions(self) -> list[SubscriptionSpec]: ...

    @abstractmethod
    def publications(self) -> list[PublicationSpec]: ...

    @abstractmethod
    def get_parameters(self) -> dict[str, Any]:
        """Current parameter values by ROS parameter name (JSON-compatible values)."""

    @abstractmethod
    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """Validate all ``values`` first, then apply them together; raise ``InvalidInput`` naming the first
        bad parameter and change nothing in that case. Returns the new full parameter dict."""

    def describe_parameters(self) -> dict[str, dict[str, Any]]:
        """Each parameter's ``{"type", "description", "range", "unit", "default", "read_only", "positive"}``: its
        row of the node's :class:`~pfield.node._params.ParameterTable` (``ros2 param describe``)."""
        return {}

    def tick(self, now: float) -> None:
        """Periodic work (expiring obstacles, controller output); ``now`` is monotonic seconds."""

    def close(self) -> None:
        """Release resources (threads) at shutdown."""


def distinct_buses(nodes: Sequence[Node]) -> list[Bus]:
    """Each distinct bus of ``nodes`` once (the nodes of one process usually share one)."""
    return list({id(node.bus): node.bus for node in nodes}.values())
