"""Fan-out of bus messages to WebSocket connections, across the thread / event-loop boundary.

The :class:`~pfield.node.Bus` calls listeners from whichever thread publishes (a planner worker,
the tick task, a request handler). :class:`TopicFanout` serialises each message once, then hands the
text to every connection's :class:`Outbox` through ``loop.call_soon_threadsafe``. An outbox holds at most
``max_messages`` messages and ``max_bytes`` bytes of text; beyond either the oldest messages are dropped
(and counted), so a client that never reads costs bounded memory and never blocks a node.
"""

from __future__ import annotations

import asyncio
import threading
from collections import deque
from collections.abc import Sequence

from pfield.interfaces import RosMessage
from pfield.node import Bus

__all__ = ["Outbox", "TopicFanout"]


class Outbox:
    """A connection's bounded queue of JSON texts (drop oldest; the newest message is always kept)."""

    def __init__(self, max_messages: int, max_bytes: int) -> None:
        self.max_messages = max_messages
        self.max_bytes = max_bytes
        self.dropped = 0
        self._texts: deque[str] = deque()
        self._bytes = 0
        self._ready = asyncio.Event()

    def offer(self, text: str) -> int:
        """Queue ``text``; returns how many older messages were dropped to make room."""
        self._texts.append(text)
        self._bytes += len(text)
        dropped = 0
        while len(self._texts) > 1 and (len(self._texts) > self.max_messages or self._bytes > self.max_bytes):
            self._bytes -= len(self._texts.popleft())
            dropped += 1
        self.dropped += dropped
        self._ready.set()
        return dropped

    async def get(self) -> str:
        while not self._texts:
            self._ready.clear()
            await self._ready.wait()
        text = self._texts.popleft()
        self._bytes -= len(text)
        return text


class TopicFanout:
    """Bus listener forwarding JSON text of each topic's messages to subscribed outboxes.

    ``dropped`` counts the messages dropped over all connections since the start (``GET /health``).
    """

    def __init__(self, buses: Sequence[Bus], loop: asyncio.AbstractEventLoop, queue_size: int = 1000,
                 queue_bytes: int = 16_000_000) -> None:
        self._buses = list(buses)
        self._loop = loop
        self._queue_size = queue_size
        self._queue_bytes = queue_bytes
        self._lock = threading.Lock()
        self._outboxes: dict[str, list[Outbox]] = {}
        self.dropped = 0
        for bus in self._buses:
            bus.add_listener(self._on_publish)

    @property
    def connections(self) -> int:
        with self._lock:
            return sum(len(boxes) for boxes in self._outboxes.values())

    def subscribe(self, topic: str) -> Outbox:
        outbox = Outbox(self._queue_size, self._queue_bytes)
        with self._lock:
            self._outboxes.setdefault(topic, []).append(outbox)
        return outbox

    def unsubscribe(self, topic: str, outbox: Outbox) -> None:
        with self._lock:
            boxes = self._outboxes.get(topic, [])
            if outbox in boxes:
                boxes.remove(outbox)
            if not boxes:
                self._outboxes.pop(topic, None)  # topic names of closed sockets are not kept

    def close(self) -> None:
        for bus in self._buses:
            bus.remove_listener(self._on_publish)

    def _on_publish(self, topic: str, message: RosMessage) -> None:
        with self._lock:
            boxes = list(self._outboxes.get(topic, ()))
        if not boxes:
            return
        text = message.model_dump_json()
        for box in boxes:
            try:
                self._loop.call_soon_threadsafe(self._offer, box, text)
            except RuntimeError:  # loop closed during shutdown
                return

    def _offer(self, box: Outbox, text: str) -> None:
        self.dropped += box.offer(text)
