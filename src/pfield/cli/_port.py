"""Is a TCP port free to serve on? Checked by ``pfield serve`` before it prints or starts anything.

Without the check a second ``pfield serve`` on a port in use printed its banner, built its nodes, then died with
uvicorn's ``address already in use`` while the old node kept answering the user's next commands.
"""

from __future__ import annotations

import errno
import http.client
import socket

from pfield.errors import InvalidInput

__all__ = ["check_port_free"]

_PROBE_TIMEOUT_S = 1.0
"""s to wait for ``GET /nodes`` of whatever holds the port (a pfield node answers in milliseconds)."""


def check_port_free(host: str, port: int) -> None:
    """Bind ``host:port`` as the server will (every address ``host`` resolves to, ``SO_REUSEADDR`` so that a
    port left in TIME_WAIT by a stopped server counts as free) and let it go again; raise :class:`InvalidInput`
    naming ``--port`` when a bind fails: the port is in use (saying whether a pfield node answers there), not
    permitted, or ``host`` is not an address of this machine."""
    try:
        addresses = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror as exc:
        raise InvalidInput("--host", host, f"not an address of this machine ({exc.strerror})") from None
    for family, kind, protocol, _, address in addresses:
        with socket.socket(family, kind, protocol) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                probe.bind(address)
            except OSError as exc:
                raise InvalidInput("--port", port, _reason(host, port, exc)) from None


def _reason(host: str, port: int, error: OSError) -> str:
    if error.errno == errno.EADDRINUSE:
        holder = " (a pfield node answers there)" if _pfield_answers(host, port) else ""
        return (f"{host}:{port} is in use{holder}: stop the process that holds it, or serve on another port with "
                f"--port N (and point clients at it with --url or PFIELD_URL)")
    if error.errno == errno.EACCES:
        return f"not permitted to serve on {host}:{port} (ports below 1024 need privileges): choose --port N"
    if error.errno == errno.EADDRNOTAVAIL:
        return f"{host} is not an address of this machine: choose --host"
    return f"cannot serve on {host}:{port}: {error.strerror}"


def _pfield_answers(host: str, port: int) -> bool:
    """Does a pfield node answer ``GET /nodes`` at ``host:port`` (a wildcard host is asked on loopback)?"""
    target = {"0.0.0.0": "127.0.0.1", "::": "::1", "": "127.0.0.1"}.get(host, host)
    connection = http.client.HTTPConnection(target, port, timeout=_PROBE_TIMEOUT_S)  # logs nothing, unlike httpx
    try:
        connection.request("GET", "/nodes")
        answer = connection.getresponse()
        return answer.status == 200 and b"/pfield_manager" in answer.read(65536)
    except (OSError, http.client.HTTPException):
        return False
    finally:
        connection.close()
