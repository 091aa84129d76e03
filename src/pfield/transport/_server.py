"""The uvicorn server of the HTTP transport with pfield's connection caps (``pfield serve`` and ServerThread).

uvicorn bounds idle keep-alive connections (``timeout_keep_alive``), but not the size of a request head
with its httptools parser, the time a client may take to send a request head (a "slowloris" client holds its
connection open by sending one header byte at a time) nor the number of open connections
(``limit_concurrency`` counts only requests whose head has arrived). :func:`_guarded_protocol` adds all
three: a request head over :attr:`ServerLimits.max_header_bytes` is answered 400 and the connection closed, a
connection whose request head is not complete :attr:`ServerLimits.header_timeout` seconds after it opened (or
after the previous answer) is closed, and a connection beyond :attr:`ServerLimits.max_connections` is
answered 429 and closed at once.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from typing import Any

from pfield.transport._asgi import error_body

__all__ = ["ServerLimits", "uvicorn_config"]


@dataclass(frozen=True)
class ServerLimits:
    """Connection-level caps (each documented in docs/node.md)."""

    max_connections: int = 200
    """Open HTTP + WebSocket connections; one more is answered 429 and closed (a file descriptor each)."""
    header_timeout: float = 10.0
    """s a client may take to send a complete request head; then the connection is closed."""
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

        for name in ("max_connections", "header_timeout", "keep_alive_timeout", "max_header_bytes",
                     "ws_max_message_bytes", "gil_switch_interval"):
            positive(name, getattr(self, name))

    def apply_to_process(self) -> None:
        """The process-wide part: the GIL switch interval."""
        import sys

        sys.setswitchinterval(self.gil_switch_interval)


def _guarded_protocol(server_limits: ServerLimits) -> type[asyncio.Protocol]:
    """uvicorn's httptools protocol (its C parser: a fraction of h11's time per request) with a request-head
    timeout, a request-head size cap and a connection cap (see the module docstring)."""
    from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

    class GuardedProtocol(HttpToolsProtocol):
        limits = server_limits

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._head_timer: asyncio.TimerHandle | None = None
            self._head_bytes = 0
            self._in_head = True
            if len(self.connections) > self.limits.max_connections:
                body = error_body(f"too many connections (at most {self.limits.max_connections}); retry later",
                                  "connections")
                transport.write(b"HTTP/1.1 429 Too Many Requests\r\ncontent-type: application/json\r\n"
                                b"retry-after: 1\r\nconnection: close\r\ncontent-length: " + str(len(body)).encode()
                                + b"\r\n\r\n" + body)
                transport.close()
                return
            self._arm_head_timer()

        def _arm_head_timer(self) -> None:
            self._cancel_head_timer()
            self._head_timer = self.loop.call_later(self.limits.header_timeout, self._head_timed_out)

        def _cancel_head_timer(self) -> None:
            timer = getattr(self, "_head_timer", None)
            if timer is not None:
                timer.cancel()
                self._head_timer = None

        def _head_timed_out(self) -> None:
            self._head_timer = None
            if self._in_head and not self.transport.is_closing():
                self.transport.close()

        def data_received(self, data: bytes) -> None:
            if self._in_head:
                self._head_bytes += len(data)
            super().data_received(data)
            if self._in_head and self._head_bytes > self.limits.max_header_bytes \
                    and not self.transport.is_closing():  # a head still incomplete after that many bytes
                self.send_400_response("request head too large")

        def on_message_begin(self) -> None:
            super().on_message_begin()
            self._in_head = True
            self._head_size = 0

        def _count_head(self, size: int) -> None:
            self._head_size += size
            if self._head_size > self.limits.max_header_bytes:  # the parser answers 400 for this
                raise ValueError(f"request head over {self.limits.max_header_bytes} bytes")

        def on_url(self, url: bytes) -> None:
            self._count_head(len(url))
            super().on_url(url)

        def on_header(self, name: bytes, value: bytes) -> None:
            self._count_head(len(name) + len(value) + 4)
            super().on_header(name, value)

        def on_headers_complete(self) -> None:
            self._in_head = False  # the head arrived; the request runs as long as it needs
            self._head_bytes = 0
            self._cancel_head_timer()
            super().on_headers_complete()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            if not self.transport.is_closing():
                self._in_head = True
                self._arm_head_timer()

        def send_400_response(self, msg: str) -> None:
            """A request the parser refuses (malformed, head over the size cap): pfield's JSON error, then close."""
            body = error_body(f"{msg} (malformed request, or a request head over "
                              f"{self.limits.max_header_bytes} bytes)", "request")
            self.transport.write(b"HTTP/1.1 400 Bad Request\r\ncontent-type: application/json\r\n"
                                 b"connection: close\r\ncontent-length: " + str(len(body)).encode()
                                 + b"\r\n\r\n" + body)
            self.transport.close()

        def connection_lost(self, exc: Exception | None) -> None:
            self._cancel_head_timer()
            super().connection_lost(exc)

    return GuardedProtocol


def uvicorn_config(app: Any, limits: ServerLimits, **options: Any) -> Any:
    """A ``uvicorn.Config`` for ``app`` with ``limits`` applied (``options``: host, port, log_level ...)."""
    import uvicorn

    return uvicorn.Config(app, http=_guarded_protocol(limits), timeout_keep_alive=limits.keep_alive_timeout,
                          ws_max_size=limits.ws_max_message_bytes, proxy_headers=False, server_header=False,
                          lifespan="on", **options)
