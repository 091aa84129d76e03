"""Issue 31's F3 and F4 against a real ``pfield serve`` on 127.0.0.1 with its default limits.

F3: a parameter value beyond its range or of an absurd size (a 400-digit integer, a 100 kB string) is a 400
naming the parameter on every node, changes nothing, and the node keeps serving (it was a 500 OverflowError).
F4: with 200 half-sent request bodies and 200 idle WebSockets held open, ``/health`` and
``compute_autonomy_vector`` from another client answer 200 within 1 s (they answered 429 for as long as the
connections stayed).
"""

from __future__ import annotations

import json
import resource
import socket
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from serve_process import pfield_serve, wait_warm

NODES = ("/pfield_manager", "/base_controller", "/costmap")
HUGE = "1" * 400
"""A 400-digit integer, as JSON text (Python's ``float`` of it raises OverflowError)."""
GOAL = {"header": {"frame_id": "world"},
        "pose": {"position": {"x": 0.5, "y": 0.2, "z": 0.4}, "orientation": {"w": 1.0}}}
QUERY = {"query_pose": {"header": {"frame_id": "world"},
                        "pose": {"position": {"x": 0.3, "y": 0.0, "z": 0.3}, "orientation": {"w": 1.0}}}}
HELD = 200
"""Half-sent bodies and WebSocket handshakes held open in the F4 test (issue 31's reproduction)."""


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("serve_bounds") / "serve.log"


@pytest.fixture(scope="module")
def url(log: Path) -> Iterator[str]:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    wanted = 4 * HELD + 256  # this process's sockets and the server's (it inherits the limit)
    if soft != resource.RLIM_INFINITY and soft < wanted:
        resource.setrlimit(resource.RLIMIT_NOFILE, (wanted if hard == resource.RLIM_INFINITY else min(wanted, hard),
                                                    hard))
    with pfield_serve(log=log) as (address, _):
        wait_warm(address)
        yield address


def _put(url: str, node: str, body: str) -> httpx.Response:
    return httpx.put(f"{url}/param{node}", content=body.encode(), headers={"content-type": "application/json"},
                     timeout=30)


def _hostile_values(row: dict[str, Any]) -> list[str]:
    """JSON texts of values no parameter of ``row``'s type may take."""
    if row["type"] in ("double", "integer"):
        return [HUGE, "-" + HUGE, "1e999"]
    if row["type"] == "string":
        return [json.dumps("a" * 100_000)]
    if row["type"] == "map":
        return [f'{{"camera": {{"translation": [{HUGE}, 0, 0]}}}}', '{"camera": {"translation": [1e300, 0, 0]}}',
                json.dumps({"a" * 100_000: {"translation": [0, 0, 0]}})]
    return []


@pytest.mark.parametrize("node", NODES)
def test_absurd_parameter_values_are_a_400_naming_the_parameter_and_change_nothing(url: str, node: str) -> None:
    before = httpx.get(f"{url}/param{node}").json()
    rows = httpx.get(f"{url}/param{node}", params={"describe": "true"}).json()
    refused = 0
    for name, row in rows.items():
        for value in _hostile_values(row):
            answer = _put(url, node, f'{{"{name}": {value}}}')
            assert answer.status_code == 400, (name, value[:50], answer.text[:300])
            error = answer.json()
            assert error["field"].startswith(name), error
            assert len(error["error"]) < 400 and len(error["value"] or "") <= 200, error  # a prefix of the value
            refused += 1
    assert refused >= 3 * len([r for r in rows.values() if r["type"] in ("double", "integer")])
    assert httpx.get(f"{url}/param{node}").json() == before
    assert httpx.get(f"{url}/health").status_code == 200  # the node keeps serving
    name = next(n for n, row in rows.items() if row["type"] == "double" and not row["read_only"])
    assert _put(url, node, json.dumps({name: before[name]})).status_code == 200


def _half_sent_body(port: int) -> socket.socket:
    """A connection that sends a complete request head announcing 10 bytes of body, and never the body."""
    conn = socket.create_connection(("127.0.0.1", port), timeout=30)
    conn.sendall(b"POST /srv/pfield/compute_autonomy_vector HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                 b"Content-Type: application/json\r\nContent-Length: 10\r\n\r\n")
    return conn


def _idle_websocket(port: int) -> tuple[socket.socket, int]:
    """A WebSocket handshake on a topic nobody publishes; the socket and the status of the answer."""
    conn = socket.create_connection(("127.0.0.1", port), timeout=30)
    conn.sendall(b"GET /ws/topic/idle/listener HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
                 b"Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                 b"Sec-WebSocket-Version: 13\r\n\r\n")
    answer = b""
    while b"\r\n\r\n" not in answer:
        chunk = conn.recv(4096)
        assert chunk, "the server closed a WebSocket handshake without an answer"
        answer += chunk
    return conn, int(answer.split(b" ", 2)[1])


def _still_open(conn: socket.socket) -> bool:
    """Whether the server has neither answered nor closed ``conn``."""
    conn.setblocking(False)
    try:
        return not conn.recv(1, socket.MSG_PEEK)
    except BlockingIOError:
        return True
    except OSError:
        return False
    finally:
        conn.setblocking(True)


def test_health_and_autonomy_answer_within_a_second_with_200_half_sent_bodies_and_200_websockets(url: str) -> None:
    port = int(url.rsplit(":", 1)[1])
    assert httpx.post(f"{url}/topic/pfield/planning_goal_pose", json=GOAL).status_code == 200
    warm = httpx.post(f"{url}/srv/pfield/compute_autonomy_vector", json=QUERY, timeout=600)
    assert warm.status_code == 200, warm.text
    limits = {"websockets": 64, "connections": 200}  # ServerLimits' defaults
    websockets = [_idle_websocket(port) for _ in range(HELD)]
    bodies = [_half_sent_body(port) for _ in range(HELD)]
    try:
        upgraded = [conn for conn, status in websockets if status == 101]
        assert len(upgraded) == limits["websockets"]  # WebSockets have their own cap ...
        assert {status for _, status in websockets} == {101, 429}
        time.sleep(0.2)  # the server has read every head
        assert all(_still_open(conn) for conn in bodies)  # ... and take no HTTP slot: 200 bodies held
        health_client, autonomy_client = httpx.Client(timeout=30), httpx.Client(timeout=30)
        started = time.perf_counter()
        health = health_client.get(f"{url}/health")
        health_s = time.perf_counter() - started
        started = time.perf_counter()
        autonomy = autonomy_client.post(f"{url}/srv/pfield/compute_autonomy_vector", json=QUERY)
        autonomy_s = time.perf_counter() - started
        health_client.close()
        autonomy_client.close()
        print(f"with {HELD} half-sent bodies and {len(upgraded)} idle WebSockets held ({HELD - len(upgraded)} "
              f"refused 429): /health {health_s * 1000:.1f} ms, compute_autonomy_vector {autonomy_s * 1000:.1f} ms")
        assert health.status_code == 200 and autonomy.status_code == 200, (health.text, autonomy.text)
        assert health_s < 1.0 and autonomy_s < 1.0
        held = sum(map(_still_open, bodies))
        assert held == HELD - 2  # each newcomer took the slot of the body that had waited longest (408)
        assert all(map(_still_open, upgraded))
        assert bodies[0].recv(4096).startswith(b"HTTP/1.1 408 ")
    finally:
        for conn in bodies + [conn for conn, _ in websockets]:
            conn.close()


def test_a_huge_chunk_size_is_refused_413_at_once(url: str) -> None:
    with socket.create_connection(("127.0.0.1", int(url.rsplit(":", 1)[1])), timeout=30) as conn:
        conn.sendall(b"POST /srv/pfield/compute_autonomy_vector HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                     b"Content-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\nffffffffffffffff\r\n")
        started = time.monotonic()
        answer = b""
        while chunk := conn.recv(4096):
            answer += chunk
    assert answer.startswith(b"HTTP/1.1 413 ") and time.monotonic() - started < 1.0
    assert json.loads(answer.partition(b"\r\n\r\n")[2])["field"] == "body"


def test_no_refusal_left_a_traceback_in_the_log(url: str, log: Path) -> None:
    del url  # the server of the tests above
    assert "Traceback" not in log.read_text()
