"""ASGI middleware of the HTTP transport: bearer-token check and request size cap.

Both run before routing so that an oversized or unauthorised request never reaches a handler.
"""

from __future__ import annotations

import hmac
import json
from collections.abc import Awaitable, Callable, MutableMapping
from typing import Any
from urllib.parse import parse_qs

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

__all__ = ["GuardMiddleware"]


async def _reject(send: Send, status: int, error: str, field: str) -> None:
    body = json.dumps({"error": error, "field": field}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


class GuardMiddleware:
    """Rejects requests without the token (401) and request bodies over ``max_bytes`` (413).

    The token is accepted as ``Authorization: Bearer <token>`` or, for WebSocket clients that cannot set
    headers, the ``token`` query parameter. Bodies without ``Content-Length`` are buffered up to the cap.
    """

    def __init__(self, app: ASGIApp, token: str | None, max_bytes: int) -> None:
        self.app = app
        self.token = token
        self.max_bytes = max_bytes

    def _authorised(self, scope: Scope) -> bool:
        if not self.token:
            return True
        headers = dict(scope.get("headers") or [])
        given = headers.get(b"authorization", b"").decode("latin-1").removeprefix("Bearer ").strip()
        if not given:
            given = parse_qs(scope.get("query_string", b"").decode()).get("token", [""])[0]
        return hmac.compare_digest(given.encode(), self.token.encode())

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        if not self._authorised(scope):
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1008})
            else:
                await _reject(send, 401, "missing or wrong token (Authorization: Bearer <token>)", "token")
            return
        if scope["type"] == "http":
            length = dict(scope.get("headers") or []).get(b"content-length")
            if length is not None and int(length) > self.max_bytes:
                await _reject(send, 413, f"request body over {self.max_bytes} bytes", "body")
                return
            if length is None and scope["method"] in ("POST", "PUT"):
                buffered = await self._buffered(receive, send)
                if buffered is None:
                    return
                receive = buffered
        await self.app(scope, receive, send)

    async def _buffered(self, receive: Receive, send: Send) -> Receive | None:
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            chunks.append(message.get("body", b""))
            size += len(chunks[-1])
            if size > self.max_bytes:
                await _reject(send, 413, f"request body over {self.max_bytes} bytes", "body")
                return None
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        sent = False

        async def replay() -> Message:
            nonlocal sent
            if sent:
                return await receive()
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}

        return replay
