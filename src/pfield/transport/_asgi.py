"""ASGI middleware of the HTTP transport: the checks every request passes before routing.

In order: ``Host`` names this server (421 otherwise: DNS rebinding), a state-changing request or any
WebSocket from a browser page comes from an allowed ``Origin`` (403: cross-site request forgery), the bearer
token (401), the body size (413), ``Content-Type: application/json`` (415), a body that is present (400) and
nested at most :data:`MAX_JSON_DEPTH` deep (400). Unexpected exceptions of the app answer a JSON 500 here,
so the keep-alive connection stays usable. Every refusal is pfield's JSON error ``{"error", "field", "value"}``.
The rules follow OWASP's CSRF and DNS-rebinding advice and what Jupyter and rosbridge servers do on localhost.
"""

from __future__ import annotations

import hmac
import ipaddress
import json
import logging
import re
from collections.abc import Awaitable, Callable, Iterable, MutableMapping
from typing import Any
from urllib.parse import parse_qs

import numpy as np

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

__all__ = ["DEFAULT_MAX_REQUEST_BYTES", "LOOPBACK_NAMES", "MAX_JSON_DEPTH", "GuardMiddleware", "error_body",
           "excess_depth", "json_depth"]

_log = logging.getLogger("pfield.transport.http")
DEFAULT_MAX_REQUEST_BYTES = 1_000_000
"""Request bodies above this many bytes are refused with 413 (a seed request is < 1 kB)."""
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "[::1]")
"""Host names always accepted in ``Host`` (with the server's port) and in same-origin ``Origin`` values."""
MAX_JSON_DEPTH = 64
"""Deepest accepted nesting of JSON arrays/objects in a body or WebSocket frame (a MarkerArray is < 10 deep);
deeper input is refused with 400 before any parser recurses into it."""
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
"""Methods that change nothing: cross-origin pages may send them (they cannot read the answer without CORS)."""
_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_BRACKETS = re.compile(rb"[\[\]{}]")
_SHALLOW = 64
"""Up to this many brackets (a service request has < 20) the depth is counted bracket by bracket; above,
with one vectorised pass over the bytes."""
_STEPS = np.zeros(256, dtype=np.int8)
_STEPS[[0x5B, 0x7B]] = 1
_STEPS[[0x5D, 0x7D]] = -1


_CLOSE = ((b"connection", b"close"),)
"""A refused body is not read: the connection closes after the answer instead of parsing the rest of it."""


def error_body(error: str, field: str = "", value: object = None) -> bytes:
    """pfield's JSON error ``{"error", "field", "value"}`` (``value`` as its repr cut at 200 characters, or null)."""
    shown = None if value is None else repr(value)[:200]
    return json.dumps({"error": error, "field": field, "value": shown}).encode()


def json_depth(text: bytes | str) -> int:
    """Deepest nesting of ``[``/``{`` in JSON ``text`` (brackets inside strings do not count); linear time."""
    data = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else text
    if b"[" not in data and b"{" not in data:
        return 0
    data = _STRING.sub(b'""', data) if b'"' in data else data
    if data.count(b"[") + data.count(b"{") <= _SHALLOW:
        return _depth_of_few(data)
    steps = _STEPS[np.frombuffer(data, dtype=np.uint8)]
    return int(np.cumsum(steps, dtype=np.int64).max(initial=0))


def excess_depth(text: bytes | str) -> int:
    """The nesting depth of JSON ``text`` when it exceeds :data:`MAX_JSON_DEPTH`, else 0. A text with at most
    that many opening brackets cannot exceed it: then nothing more is read (a service request: < 1 µs)."""
    opening = ("[", "{") if isinstance(text, str) else (b"[", b"{")
    if text.count(opening[0]) + text.count(opening[1]) <= MAX_JSON_DEPTH:  # type: ignore[arg-type]
        return 0
    depth = json_depth(text)
    return depth if depth > MAX_JSON_DEPTH else 0


def _depth_of_few(data: bytes) -> int:
    """:func:`json_depth` of string-free ``data`` with few brackets: walk only the bracket characters."""
    depth = deepest = 0
    for bracket in _BRACKETS.findall(data):
        depth += 1 if bracket in b"[{" else -1
        deepest = max(deepest, depth)
    return deepest


async def _reject(send: Send, status: int, error: str, field: str, value: object = None,
                  headers: Iterable[tuple[bytes, bytes]] = ()) -> None:
    body = error_body(error, field, value)
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                            *headers]})
    await send({"type": "http.response.body", "body": body})


def _split_host(value: str) -> tuple[str, int | None]:
    """``(host, port)`` of a ``Host`` header or an origin's authority; IPv6 stays bracketed."""
    host, port = value, None
    match = re.fullmatch(r"(\[[^\]]*\]|[^:\[\]]*)(?::(\d{1,5}))?", value)
    if match is None:
        return value, None
    host, port_text = match.group(1), match.group(2)
    if port_text is not None:
        port = int(port_text)
    return host.lower(), port


def _is_ip_literal(host: str) -> bool:
    try:
        ipaddress.ip_address(host.strip("[]"))
    except ValueError:
        return False
    return True


class GuardMiddleware:
    """The checks of the module docstring, before routing.

    ``token``: required bearer token, given as ``Authorization: Bearer <token>`` or, for WebSocket clients that
    cannot set headers, the ``token`` query parameter. ``max_bytes``: the body cap; bodies are buffered up to
    it. ``allowed_origins``: origins (``scheme://host[:port]``) besides this server's own loopback origins
    whose pages may change state. ``allowed_hosts``: names accepted in ``Host`` besides the loopback names and
    the bound address. When the server is bound to a wildcard address (``0.0.0.0``), any IP literal is
    accepted in ``Host`` (an IP literal cannot be rebound by DNS).
    """

    def __init__(self, app: ASGIApp, token: str | None, max_bytes: int, allowed_origins: Iterable[str] = (),
                 allowed_hosts: Iterable[str] = ()) -> None:
        self.app = app
        self.token = token
        self.max_bytes = max_bytes
        self.allowed_origins = frozenset(o.rstrip("/").lower() for o in allowed_origins)
        self.allowed_hosts = frozenset(h.lower() for h in allowed_hosts)

    # ---- the checks (each returns the refusal, or None) ------------------------------------------------------
    def _host_refusal(self, scope: Scope, headers: dict[bytes, bytes]) -> tuple[int, str, str, object] | None:
        given = headers.get(b"host")
        if given is None:
            return 421, "the Host header is required", "Host", None
        host, port = _split_host(given.decode("latin-1"))
        bound_host, bound_port = (scope.get("server") or ("127.0.0.1", None))[:2]
        bound = f"[{bound_host}]" if ":" in str(bound_host) else str(bound_host)
        names = {*LOOPBACK_NAMES, bound.lower(), *self.allowed_hosts}
        wildcard = bound in ("0.0.0.0", "[::]")
        if (host in names or (wildcard and _is_ip_literal(host))) and port in (None, bound_port):
            return None
        return 421, f"this server does not answer for Host {given.decode('latin-1')!r} (DNS rebinding guard)", \
            "Host", given.decode("latin-1")

    def _origin_allowed(self, origin: str, scope: Scope) -> bool:
        origin = origin.rstrip("/").lower()
        if origin in self.allowed_origins or "*" in self.allowed_origins:
            return True
        scheme, sep, authority = origin.partition("://")
        if not sep or scheme not in ("http", "https", "ws", "wss"):
            return False  # "null" (sandboxed frames, file://) and anything unparsable
        host, port = _split_host(authority)
        bound_host, bound_port = (scope.get("server") or ("127.0.0.1", None))[:2]
        bound = f"[{bound_host}]" if ":" in str(bound_host) else str(bound_host)
        return host in (*LOOPBACK_NAMES, bound.lower()) and port == bound_port

    def _authorised(self, scope: Scope, headers: dict[bytes, bytes]) -> bool:
        if not self.token:
            return True
        given = headers.get(b"authorization", b"").decode("latin-1").removeprefix("Bearer ").strip()
        if not given:
            given = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [""])[0]
        return hmac.compare_digest(given.encode("utf-8", "surrogateescape"), self.token.encode())

    # ---- ASGI ------------------------------------------------------------------------------------------------
    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or [])
        websocket = scope["type"] == "websocket"
        refusal = self._host_refusal(scope, headers)
        origin = headers.get(b"origin")
        if refusal is None and origin is not None and (websocket or scope["method"] not in SAFE_METHODS) \
                and not self._origin_allowed(origin.decode("latin-1"), scope):
            refusal = (403, f"requests from the page at {origin.decode('latin-1')!r} are refused "
                            "(pfield serve --allow-origin ORIGIN allows a page)", "Origin", origin.decode("latin-1"))
        if refusal is None and not self._authorised(scope, headers):
            refusal = (401, "missing or wrong token (Authorization: Bearer <token>)", "token", None)
        if refusal is not None:
            if websocket:
                await send({"type": "websocket.close", "code": 1008, "reason": refusal[1][:120]})
            else:
                await _reject(send, *refusal)
            return
        if websocket:
            await self._run(scope, receive, send)
            return
        if scope["method"] in ("POST", "PUT", "PATCH"):
            checked = await self._checked_body(scope, headers, receive, send)
            if checked is None:
                return
            receive = checked
        await self._run(scope, receive, send)

    async def _run(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Call the app; an exception before the answer started becomes a JSON 500 (the connection stays open)."""
        started = False

        async def tracking_send(message: Message) -> None:
            nonlocal started
            if message["type"] in ("http.response.start", "websocket.accept", "websocket.close"):
                started = True
            await send(message)

        try:
            await self.app(scope, receive, tracking_send)
        except Exception as exc:
            _log.error("%s %s failed", scope.get("method", "WEBSOCKET"), scope.get("path"), exc_info=exc)
            if started:
                if scope["type"] == "websocket":
                    return  # the socket handler already answered or closed; nothing more to send
                raise
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1011})
            else:
                await _reject(send, 500, f"internal error: {type(exc).__name__}: {exc}", "")

    async def _checked_body(self, scope: Scope, headers: dict[bytes, bytes], receive: Receive,
                            send: Send) -> Receive | None:
        """Read the whole body (up to the cap) and check it; a replaying ``receive``, or None after a refusal."""
        length = headers.get(b"content-length")
        if length is not None and (not length.isdigit() or int(length) > self.max_bytes):
            await _reject(send, 413 if length.isdigit() else 400, f"request body over {self.max_bytes} bytes"
                          if length.isdigit() else "malformed Content-Length", "body", headers=_CLOSE)
            return None
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return None
            chunks.append(message.get("body", b""))
            size += len(chunks[-1])
            if size > self.max_bytes:
                await _reject(send, 413, f"request body over {self.max_bytes} bytes", "body", headers=_CLOSE)
                return None
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        media_type = headers.get(b"content-type", b"").split(b";")[0].strip().lower()
        if media_type != b"application/json":
            await _reject(send, 415, "the body must be JSON sent as Content-Type: application/json",
                          "Content-Type", headers.get(b"content-type", b"").decode("latin-1") or None)
            return None
        if not body.strip():
            await _reject(send, 400, "the body is empty: send a JSON value ({} for a message of defaults)", "body")
            return None
        depth = excess_depth(body)
        if depth:
            await _reject(send, 400, f"JSON nested {depth} deep; at most {MAX_JSON_DEPTH} levels are accepted",
                          "body")
            return None
        sent = False

        async def replay() -> Message:
            nonlocal sent
            if sent:
                return await receive()
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}

        return replay
