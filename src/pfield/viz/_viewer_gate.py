"""A token gate in front of the viewer's page, for serving it beyond this machine.

viser has no authentication, so when the page is served on another interface the viewer binds viser to
127.0.0.1 and puts this TCP gate on the public address: a connection is admitted when its first request
carries the token, as ``?token=…`` in the URL, as the ``pfield_token`` cookie or as
``Authorization: Bearer …``. A request admitted through the URL gets the cookie in its response, so the
page's own WebSocket (same host, no query) is admitted too. Admitted connections are piped to viser, every
response but a switch to WebSocket marked ``Connection: close`` (viser answers one request per connection);
others get 401 and are closed. Tokens are compared in constant time.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import logging
import threading
from urllib.parse import parse_qs, urlsplit

__all__ = ["TokenGate"]

_log = logging.getLogger(__name__)
_HEAD_LIMIT = 65536
_COOKIE = "pfield_token"


def _presented(head: bytes) -> tuple[list[str], bool]:
    """Tokens a request head presents, and whether one came from the URL."""
    lines = head.decode("latin-1").split("\r\n")
    parts = lines[0].split(" ")
    target = parts[1] if len(parts) > 1 else ""
    from_url = parse_qs(urlsplit(target).query).get("token", [])
    tokens = list(from_url)
    for line in lines[1:]:
        name, _, value = line.partition(":")
        name, value = name.strip().lower(), value.strip()
        if name == "authorization" and value.lower().startswith("bearer "):
            tokens.append(value[7:].strip())
        elif name == "cookie":
            for item in value.split(";"):
                key, _, cookie = item.strip().partition("=")
                if key == _COOKIE:
                    tokens.append(cookie)
    return tokens, bool(from_url)


def _switches(status_line: bytes) -> bool:
    """Whether a response's status line switches protocols (101: the page's WebSocket from here on)."""
    parts = status_line.split(b" ", 2)
    return len(parts) > 1 and parts[1] == b"101"


class TokenGate:
    """Admit connections on ``host:port`` that present ``token``; pipe them to 127.0.0.1:``backend_port``."""

    def __init__(self, host: str, port: int, backend_port: int, token: str) -> None:
        self.host, self.port, self.backend_port, self._token = host, port, backend_port, token
        self._loop = asyncio.new_event_loop()
        self._server: asyncio.AbstractServer | None = None
        self._thread = threading.Thread(target=self._loop.run_forever, name="pfield-view-gate", daemon=True)

    def start(self) -> TokenGate:
        self._thread.start()
        future = asyncio.run_coroutine_threadsafe(self._serve(), self._loop)
        self.port = future.result(timeout=10)
        return self

    async def _serve(self) -> int:
        self._server = await asyncio.start_server(self._handle, self.host, self.port, limit=_HEAD_LIMIT)
        return int(self._server.sockets[0].getsockname()[1])

    def stop(self) -> None:
        async def close() -> None:
            if self._server is not None:
                self._server.close()
            open_connections = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
            for task in open_connections:
                task.cancel()
            await asyncio.gather(*open_connections, return_exceptions=True)
        with contextlib.suppress(Exception):
            asyncio.run_coroutine_threadsafe(close(), self._loop).result(timeout=5)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=5)

    def _admits(self, tokens: list[str]) -> bool:
        return any(hmac.compare_digest(t.encode(), self._token.encode()) for t in tokens)

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            head = await reader.readuntil(b"\r\n\r\n")
        except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, ConnectionError):
            writer.close()
            return
        tokens, from_url = _presented(head)
        if not self._admits(tokens):
            body = b"401: this page needs its token (open the URL with ?token=...)\n"
            writer.write(b"HTTP/1.1 401 Unauthorized\r\nContent-Type: text/plain\r\nConnection: close\r\n"
                         b"Content-Length: " + str(len(body)).encode() + b"\r\n\r\n" + body)
            with contextlib.suppress(ConnectionError):
                await writer.drain()
            writer.close()
            return
        try:
            up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.backend_port, limit=_HEAD_LIMIT)
        except OSError:
            writer.close()
            return
        up_writer.write(head)
        try:
            answer = await up_reader.readuntil(b"\r\n\r\n")
        except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, ConnectionError):
            writer.close()
            up_writer.close()
            return
        status, _, rest = answer.partition(b"\r\n")
        added = b""
        if from_url:  # hand the browser the cookie with the first response
            added += f"Set-Cookie: {_COOKIE}={self._token}; HttpOnly; SameSite=Strict; Path=/\r\n".encode()
        if not _switches(status):
            # viser closes the connection after any answer but a switch to WebSocket, without saying so; saying
            # it keeps a keep-alive client from sending its next request down a closing connection
            added += b"Connection: close\r\n"
        writer.write(status + b"\r\n" + added + rest)
        await asyncio.gather(self._pipe(reader, up_writer), self._pipe(up_reader, writer))

    @staticmethod
    async def _pipe(source: asyncio.StreamReader, target: asyncio.StreamWriter) -> None:
        try:
            while chunk := await source.read(65536):
                target.write(chunk)
                await target.drain()
        except ConnectionError:
            pass
        finally:
            with contextlib.suppress(Exception):
                target.close()
