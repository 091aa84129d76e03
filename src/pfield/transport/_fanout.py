"""Fan-out of bus messages to WebSocket connections, across the thread / event-loop boundary.

The :class:`~pfield.node._base.Bus` calls listeners from whichever thread publishes (a planner worker,
the tick task, a request handler). :class:`TopicFanout` serialises each message once, then hands the
text to every connection's bounded queue through ``loop.call_soon_threadsafe``; when a slow client's
queue is full the oldest message is dropped, so a stalled viewer never blocks a node.
"""

from __future__ import annotations

import asyncio
import threading
from collections import defaultdict
from collections.abc import Sequence

from pfield.interfaces._base import RosMessage
from pfield.node._base import Bus

__all__ = ["TopicFanout"]


class TopicFanout:
    """Bus listener forwarding JSON text of each topic's messages to subscribed asyncio queues."""

    def __init__(self, buses: Sequence[Bus], loop: asyncio.AbstractEventLoop, queue_size: int = 1000) -> None:
        self._buses = list(buses)
        self._loop = loop
        self._queue_size = queue_size
        self._lock = threading.Lock()
        self._queues: dict[str, list[asyncio.Queue[str]]] = defaultdict(list)
        for bus in self._buses:
            bus.add_listener(self._on_publish)

    def subscribe(self, topic: str) -> asyncio.Queue[str]:
        queue: asyncio.Queue[str] = asyncio.Queue(self._queue_size)
        with self._lock:
            self._queues[topic].append(queue)
        return queue

    def unsubscribe(self, topic: str, queue: asyncio.Queue[str]) -> None:
        with self._lock:
            if queue in self._queues.get(topic, []):
                self._queues[topic].remove(queue)

    def close(self) -> None:
        for bus in self._buses:
            bus.remove_listener(self._on_publish)

    def _on_publish(self, topic: str, message: RosMessage) -> None:
        with self._lock:
            queues = list(self._queues.get(topic, ()))
        if not queues:
            return
        text = message.model_dump_json()
        for queue in queues:
            try:
                self._loop.call_soon_threadsafe(self._offer, queue, text)
            except RuntimeError:  # loop closed during shutdown
                return

    @staticmethod
    def _offer(queue: asyncio.Queue[str], text: str) -> None:
        if queue.full():
            queue.get_nowait()
        queue.put_nowait(text)
