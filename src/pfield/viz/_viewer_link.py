"""The viewer's link to a running pfield node: WebSocket topic streams in, HTTP publishes and service calls out.

The link is a client of the node's HTTP/WebSocket API (DESIGN §3.2), in its own threads: the node never
waits for the viewer. Each streamed topic (``WS /ws/topic/<topic>``, latest message first) has one thread
that reconnects after a drop; publishes that may come in bursts (dragging the goal) go through a
one-slot mailbox so only the newest pose is sent.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import httpx

__all__ = ["NodeLink"]

_log = logging.getLogger(__name__)
RECONNECT_DELAY = 1.0
"""s between attempts to reopen a dropped topic stream."""


class NodeLink:
    """Streams ``topics`` of the node at ``url`` into ``on_message(topic, data)`` (decoded JSON)."""

    def __init__(self, url: str, topics: Sequence[str], on_message: Callable[[str, dict[str, Any]], None],
                 token: str | None = None, timeout: float = 10.0) -> None:
        self.url = url.rstrip("/")
        self._headers = {"Authorization": f"Bearer {token}"} if token else {}
        self._http = httpx.Client(base_url=self.url, headers=self._headers, timeout=timeout, trust_env=False)
        self._on_message = on_message
        self._topics = list(topics)
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._mail: dict[str, dict[str, Any]] = {}
        self._mail_ready = threading.Condition()
        self.connected: set[str] = set()
        """Topics whose stream is open now."""

    # ---- lifecycle ------------------------------------------------------------------------------------
    def start(self) -> NodeLink:
        for topic in self._topics:
            thread = threading.Thread(target=self._stream, args=(topic,), name=f"pfield-view{topic}", daemon=True)
            thread.start()
            self._threads.append(thread)
        sender = threading.Thread(target=self._send_mail, name="pfield-view-publish", daemon=True)
        sender.start()
        self._threads.append(sender)
        return self

    def close(self) -> None:
        self._stop.set()
        with self._mail_ready:
            self._mail_ready.notify_all()
        for thread in self._threads:
            thread.join(timeout=3.0)
        self._http.close()

    # ---- HTTP -----------------------------------------------------------------------------------------
    def get(self, path: str) -> Any:
        """``GET path`` as decoded JSON; raises ``httpx.HTTPError`` on failure."""
        response = self._http.get(path)
        response.raise_for_status()
        return response.json()

    def call(self, service: str, request: dict[str, Any], timeout: float = 600.0) -> dict[str, Any]:
        """``POST /srv<service>`` with ``request``; the response as a dict (raises on HTTP errors)."""
        response = self._http.post(f"/srv{service}", json=request, timeout=timeout)
        if response.status_code >= 400:
            raise RuntimeError(f"{service}: {response.json().get('error', response.text)}")
        result: dict[str, Any] = response.json()
        return result

    def publish(self, topic: str, message: dict[str, Any]) -> None:
        """``POST /topic<topic>`` now (raises on HTTP errors)."""
        response = self._http.post(f"/topic{topic}", json=message)
        if response.status_code >= 400:
            raise RuntimeError(f"{topic}: {response.json().get('error', response.text)}")

    def publish_latest(self, topic: str, message: dict[str, Any]) -> None:
        """Queue ``message`` for ``topic``, replacing one not yet sent (returns at once)."""
        with self._mail_ready:
            self._mail[topic] = message
            self._mail_ready.notify()

    def _send_mail(self) -> None:
        while not self._stop.is_set():
            with self._mail_ready:
                while not self._mail and not self._stop.is_set():
                    self._mail_ready.wait(0.5)
                mail, self._mail = self._mail, {}
            for topic, message in mail.items():
                try:
                    self.publish(topic, message)
                except (httpx.HTTPError, RuntimeError) as exc:
                    _log.warning("publishing %s failed: %s", topic, exc)

    # ---- streams --------------------------------------------------------------------------------------
    def _stream(self, topic: str) -> None:
        from websockets.exceptions import WebSocketException
        from websockets.sync.client import connect

        ws_url = "ws" + self.url[len("http"):] + "/ws/topic" + topic
        while not self._stop.is_set():
            try:
                with connect(ws_url, additional_headers=self._headers, open_timeout=5.0, proxy=None) as socket:
                    self.connected.add(topic)
                    while not self._stop.is_set():
                        try:
                            text = socket.recv(timeout=0.5)
                        except TimeoutError:
                            continue
                        self._deliver(topic, text)
            except (OSError, WebSocketException) as exc:
                _log.debug("stream %s: %s", topic, exc)
            self.connected.discard(topic)
            self._stop.wait(RECONNECT_DELAY)

    def _deliver(self, topic: str, text: str | bytes) -> None:
        try:
            data = json.loads(text)
        except ValueError:
            return
        if not isinstance(data, dict) or set(data) == {"error"}:
            return
        try:
            self._on_message(topic, data)
        except Exception:  # one bad message must not end the stream
            _log.exception("showing a %s message failed", topic)

    def wait_connected(self, timeout: float = 10.0) -> bool:
        """Wait until every stream is open; False after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.connected >= set(self._topics):
                return True
            time.sleep(0.05)
        return False
