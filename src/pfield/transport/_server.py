"""The uvicorn server of the HTTP transport with pfield's connection caps (``pfield serve`` and ServerThread).

uvicorn bounds idle keep-alive connections (``timeout_keep_alive``), but not the size of a request head with
its httptools parser, the time a client may take to send a request head or body (a "slowloris" client holds
its connection by sending one byte at a time, or a head announcing a body that never comes), the number of
open connections (``limit_concurrency`` counts only requests whose head has arrived), nor WebSockets apart
from HTTP. :func:`_guarded_protocol` adds:

* **head size**: a request head over :attr:`ServerLimits.max_header_bytes` is answered 400 and closed;
* **deadlines**: a connection that waits on its client, for a request head (:attr:`ServerLimits.header_timeout`
  after it opened or after the previous answer) or for the rest of a body (:attr:`ServerLimits.body_timeout`
  after the head), is closed when its deadline passes; a half-sent body is answered 408 first;
* **HTTP slots**: at most :attr:`ServerLimits.max_connections` HTTP connections. A new connection beyond the
  cap takes the slot of the connection that has waited longest on its client (an idle keep-alive connection,
  a half-sent head or body), so connections that wait on a client never lock another client out; it is
  answered 429 only when every connection has a request in progress;
* **WebSocket slots**: at most :attr:`ServerLimits.max_websockets` WebSockets, counted apart from the HTTP
  slots (a WebSocket never takes one); one more handshake is answered 429;
* **chunk sizes**: a chunked request body whose chunk sizes add up to more than the app's body cap
  (``create_app(max_request_bytes=)``) is answered 413 and closed at the chunk header, before its bytes arrive.

"One client" is one connection: every client on the machine is ``127.0.0.1``, so a share per peer address would
lock local users out together with the one that misbehaves. What a connection may hold is one slot, for a
bounded time while it waits on its client, and never against a newcomer (docs/node.md, "Connection caps").
"""

from __future__ import annotations

import asyncio
import http
import re
from dataclasses import dataclass
from typing import Any

from pfield.transport._asgi import DEFAULT_MAX_REQUEST_BYTES, error_body

__all__ = ["ServerLimits", "uvicorn_config"]


@dataclass(frozen=True)
class ServerLimits:
    """Connection-level caps (each documented in docs/node.md)."""

    max_connections: int = 200
    """Open HTTP connections (a file descriptor each; WebSockets have their own cap). One more takes the slot of
    the connection that has waited longest on its client, or is answered 429 and closed when every connection
    has a request in progress."""
    header_timeout: float = 10.0
    """s a client may take to send a complete request head; then the connection is closed."""
    body_timeout: float = 10.0
    """s a client may take to send the rest of a request body once its head has arrived (1 MB in 10 s is
    100 kB/s); then the request is answered 408 and the connection closed."""
    max_websockets: int = 64
    """Open WebSockets, apart from ``max_connections``; one more handshake is answered 429. Each may buffer up
    to ``ws_queue_bytes`` of messages for a client that does not read."""
    keep_alive_timeout: int = 5
    """s an idle keep-alive connection stays open between requests."""
    max_header_bytes: int = 16_384
    """Largest request head (request line + headers); a larger one is answered 400."""
    ws_max_message_bytes: int = 1_000_000
    """Largest WebSocket message a client may send (larger: the socket is closed with code 1009)."""
    gil_switch_interval: float = 0.0005
    """s a thread that holds the GIL keeps it while another waits (``sys.setswitchinterval``, set for the
    process when the server starts; Python's default is 0.005). A plan's Python work (its answer) holds the
    GIL; each control-loop call needs it a few times (event loop, calls thread), so it waits up to this long
    at each hand-off."""

    def __post_init__(self) -> None:
        from pfield._validation import positive

        for name in ("max_connections", "header_timeout", "body_timeout", "max_websockets", "keep_alive_timeout",
                     "max_header_bytes", "ws_max_message_bytes", "gil_switch_interval"):
            positive(name, getattr(self, name))

    def apply_to_process(self) -> None:
        """The process-wide part: the GIL switch interval."""
        import sys

        sys.setswitchinterval(self.gil_switch_interval)


_CHUNKED = re.compile(rb"chunked", re.IGNORECASE)
"""Data that may carry ``Transfer-Encoding: chunked`` is fed to the parser line by line (see ``_feed_lines``)."""
_HEX = re.compile(rb"[0-9A-Fa-f]+")
_LINE_KEPT = 64
"""Bytes kept of the line being received: a chunk-size line is read from them (llhttp takes ≤ 16 hex digits)."""


class _Slots:
    """The HTTP connections of one server, and among them those waiting on their client, longest-waiting first
    (a dict keeps insertion order: a connection that starts waiting moves to the end)."""

    def __init__(self) -> None:
        self.open: set[Any] = set()
        self.waiting: dict[Any, None] = {}

    def mark(self, connection: Any, waiting: bool) -> None:
        self.waiting.pop(connection, None)
        if waiting:
            self.waiting[connection] = None

    def drop(self, connection: Any) -> None:
        self.open.discard(connection)
        self.waiting.pop(connection, None)

    def longest_waiting(self) -> Any:
        return next(iter(self.waiting), None)


def _guarded_protocol(server_limits: ServerLimits, max_body_bytes: int) -> type[asyncio.Protocol]:
    """uvicorn's httptools protocol (its C parser: a fraction of h11's time per request) with the caps of the
    module docstring; ``max_body_bytes`` is the app's body cap, which chunk sizes may not exceed."""
    from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

    class GuardedProtocol(HttpToolsProtocol):
        limits = server_limits
        slots = _Slots()
        max_body = max_body_bytes

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            self._deadline: asyncio.TimerHandle | None = None
            self._waiting_for: str | None = None  # "head" or "body": what the connection waits on its client for
            self._reading = "head"  # the parser's place in the current message: "head", "body" or "done"
            self._head_bytes = 0
            self._head_size = 0
            self._chunked = False
            self._chunk_total = 0
            self._by_lines = False  # feed line by line (see _feed_lines)
            self._line, self._line_open, self._tail = b"", False, b""
            super().connection_made(transport)
            if len(self.slots.open) >= self.limits.max_connections:
                longest = self.slots.longest_waiting()
                if longest is None:
                    self._answer(429, f"too many connections (at most {self.limits.max_connections}, each with a "
                                      "request in progress); retry later", "connections", b"retry-after: 1\r\n")
                    return
                longest._evict()
            self.slots.open.add(self)
            self._refresh()

        # ---- waiting on the client: deadlines and the slots' order ------------------------------------------
        def _refresh(self) -> None:
            """Start, keep or stop the deadline: a connection waits on its client for a head when it has nothing
            to answer (no request yet, or the last one answered) and for a body while one is incomplete; a
            connection with a request in progress (or queued behind one) waits on the server."""
            if self.pipeline:
                waiting_for = None
            elif self._reading == "body":
                waiting_for = "body"
            else:
                waiting_for = "head" if self.cycle is None or self.cycle.response_complete else None
            if waiting_for == self._waiting_for or self not in self.slots.open:
                return
            self._cancel_deadline()
            self._waiting_for = waiting_for
            self.slots.mark(self, waiting_for is not None)
            if waiting_for is not None:
                timeout = self.limits.header_timeout if waiting_for == "head" else self.limits.body_timeout
                self._deadline = self.loop.call_later(timeout, self._deadline_passed)

        def _cancel_deadline(self) -> None:
            if self._deadline is not None:
                self._deadline.cancel()
                self._deadline = None

        def _deadline_passed(self) -> None:
            self._deadline = None
            if self._waiting_for == "body":
                self._refuse_body(408, f"the request body did not arrive within {self.limits.body_timeout:g} s "
                                       "of its head; send the body with the head")
            else:
                self._close()

        def _evict(self) -> None:
            """Give this connection's slot to a new one (it waits on its client: see the module docstring)."""
            if self._waiting_for == "body":
                self._refuse_body(408, f"closed to admit another connection: the server holds at most "
                                       f"{self.limits.max_connections} and this one had waited longest for its "
                                       "request body")
            else:
                self._close()

        def _refuse_body(self, status: int, reason: str) -> None:
            """Answer the request whose body is being received ``status`` (unless its answer has started; the
            app's ``receive()`` then sees a disconnect, as after connection_lost) and close."""
            cycle = self.cycle  # the request being received; behind an answer still being written, only close
            if cycle is not None and not cycle.response_started and not self.pipeline \
                    and not self.transport.is_closing():
                cycle.disconnected = True
                cycle.message_event.set()
                self._answer(status, reason, "body")
            else:
                self._close()

        def _answer(self, status: int, reason: str, field: str, extra_headers: bytes = b"") -> None:
            """Write pfield's JSON error with ``status`` on the raw connection, then close it."""
            body = error_body(reason, field)
            self.transport.write(f"HTTP/1.1 {status} {http.HTTPStatus(status).phrase}\r\n".encode()
                                 + b"content-type: application/json\r\nconnection: close\r\n" + extra_headers
                                 + b"content-length: " + str(len(body)).encode() + b"\r\n\r\n" + body)
            self._close()

        def _close(self) -> None:
            """Close the connection; its slot is free at once (connection_lost comes later)."""
            self.slots.drop(self)
            self._cancel_deadline()
            if not self.transport.is_closing():
                self.transport.close()

        # ---- bytes in ------------------------------------------------------------------------------------------
        def data_received(self, data: bytes) -> None:
            in_head = self._reading != "body"
            if in_head:
                self._head_bytes += len(data)
            if not self._by_lines and (_CHUNKED.search(data) or _CHUNKED.search(self._tail + data[:6])):
                self._by_lines = True  # until the head says whether the body is chunked
            if self._by_lines:
                self._feed_lines(data)
            else:
                super().data_received(data)
            self._tail = data[-6:]
            if in_head and self._reading != "body" and self._head_bytes > self.limits.max_header_bytes \
                    and not self.transport.is_closing():  # a head still incomplete after that many bytes
                self.send_400_response("request head too large")

        def _feed_lines(self, data: bytes) -> None:
            """Feed ``data`` one line at a time, so that when the parser reports a chunk header the line just fed
            is its size line (httptools does not expose the size). Only the data of a request that may be chunked
            comes here: from a buffer that mentions "chunked" to the end of the head, then to the end of a
            chunked body."""
            start = 0
            while start < len(data) and self.transport.get_protocol() is self and not self.transport.is_closing():
                end = data.find(b"\n", start) + 1 or len(data)
                piece = data[start:end]
                self._line = (self._line + piece)[:_LINE_KEPT] if self._line_open else piece[:_LINE_KEPT]
                self._line_open = not piece.endswith(b"\n")
                super().data_received(piece)
                start = end

        def on_chunk_header(self) -> None:
            match = _HEX.match(self._line)
            self._chunk_total += int(match.group(), 16) if match else 0
            if self._chunk_total > self.max_body and not self.transport.is_closing():
                self._refuse_body(413, f"request body over {self.max_body} bytes (chunk sizes add up to "
                                       f"{self._chunk_total})")

        # ---- the parser's events -------------------------------------------------------------------------------
        def on_message_begin(self) -> None:
            super().on_message_begin()
            self._reading = "head"
            self._head_size = 0
            self._chunked = False
            self._chunk_total = 0
            self._refresh()

        def _count_head(self, size: int) -> None:
            self._head_size += size
            if self._head_size > self.limits.max_header_bytes:  # the parser answers 400 for this
                raise ValueError(f"request head over {self.limits.max_header_bytes} bytes")

        def on_url(self, url: bytes) -> None:
            self._count_head(len(url))
            super().on_url(url)

        def on_header(self, name: bytes, value: bytes) -> None:
            self._count_head(len(name) + len(value) + 4)
            if len(name) == 17 and name.lower() == b"transfer-encoding" and b"chunked" in value.lower():
                self._chunked = True
            super().on_header(name, value)

        def on_headers_complete(self) -> None:
            self._reading = "body"
            self._head_bytes = 0
            self._by_lines = self._chunked
            super().on_headers_complete()
            self._refresh()

        def on_message_complete(self) -> None:
            super().on_message_complete()
            self._reading = "done"
            self._chunked = self._by_lines = False
            self._refresh()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            self._refresh()

        def handle_websocket_upgrade(self) -> None:
            """Upgrade within the WebSocket cap (HTTP's slot is given back), else answer 429."""
            self.slots.drop(self)  # slot and deadline: the WebSocket protocol takes the connection over
            self._cancel_deadline()
            websockets = sum(1 for connection in self.connections if not isinstance(connection, HttpToolsProtocol))
            if websockets >= self.limits.max_websockets:
                self._answer(429, f"too many WebSockets (at most {self.limits.max_websockets}); retry later",
                             "websockets", b"retry-after: 1\r\n")
                return
            super().handle_websocket_upgrade()

        def send_400_response(self, msg: str) -> None:
            """A request the parser refuses (malformed, head over the size cap): pfield's JSON error, then close."""
            self._answer(400, f"{msg} (malformed request, or a request head over {self.limits.max_header_bytes} "
                              "bytes)", "request")

        def connection_lost(self, exc: Exception | None) -> None:
            self.slots.drop(self)
            self._cancel_deadline()
            super().connection_lost(exc)

    return GuardedProtocol


def uvicorn_config(app: Any, limits: ServerLimits, **options: Any) -> Any:
    """A ``uvicorn.Config`` for ``app`` with ``limits`` applied (``options``: host, port, log_level ...); the
    body cap for chunk sizes is the app's own (``app.state.max_request_bytes``, set by ``create_app``)."""
    import uvicorn

    max_body = getattr(getattr(app, "state", None), "max_request_bytes", DEFAULT_MAX_REQUEST_BYTES)
    return uvicorn.Config(app, http=_guarded_protocol(limits, max_body), timeout_keep_alive=limits.keep_alive_timeout,
                          ws_max_size=limits.ws_max_message_bytes, proxy_headers=False, server_header=False,
                          lifespan="on", **options)
