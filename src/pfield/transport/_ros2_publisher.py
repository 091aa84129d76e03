"""Forwards what pfield nodes publish on their :class:`~pfield.node.Bus` to rclpy publishers.

Bus listeners must not block, so the listener only records the message as the topic's pending one;
a single thread converts it to the rclpy class and publishes it. When a topic is published faster
than it can be converted, only its latest message is sent (the semantics of a keep-last topic).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

from pfield.interfaces import RosMessage
from pfield.transport._ros2_convert import to_ros

__all__ = ["BusPublisher"]

_LOG = logging.getLogger(__name__)


class BusPublisher:
    """Topic -> (rclpy class, publish function); :meth:`enqueue` is the Bus listener."""

    def __init__(self) -> None:
        self._targets: dict[str, tuple[type, Callable[[Any], None]]] = {}
        self._pending: dict[str, RosMessage] = {}
        self._wake = threading.Condition()
        self._stopping = False
        self._thread: threading.Thread | None = None

    def register(self, topic: str, message_class: type, publish: Callable[[Any], None]) -> None:
        """Publish bus messages on ``topic`` as ``message_class`` through ``publish``."""
        self._targets[topic] = (message_class, publish)

    def enqueue(self, topic: str, message: RosMessage) -> None:
        """Bus listener: remember ``message`` as the topic's next one to publish (never blocks for long)."""
        if topic not in self._targets:
            return
        with self._wake:
            self._pending[topic] = message
            self._wake.notify()

    def start(self) -> None:
        self._thread = threading.Thread(target=self._loop, name="pfield-ros2-publisher", daemon=True)
        self._thread.start()

    def stop(self, timeout: float) -> None:
        """Publish what is pending, then stop the thread."""
        with self._wake:
            self._stopping = True
            self._wake.notify()
        if self._thread is not None:
            self._thread.join(timeout)

    def _loop(self) -> None:
        while True:
            with self._wake:
                self._wake.wait_for(lambda: bool(self._pending) or self._stopping)
                batch, self._pending = self._pending, {}
                stopping = self._stopping
            for topic, message in batch.items():
                self._publish(topic, message)
            if stopping:
                return

    def _publish(self, topic: str, message: RosMessage) -> None:
        message_class, publish = self._targets[topic]
        try:
            publish(to_ros(message, message_class))
        except Exception:  # one bad message must not stop the publisher thread
            _LOG.exception("%s: could not publish", topic)
