"""Robustness and caps of the HTTP transport on a real uvicorn server (127.0.0.1) with small real nodes:
a server fault keeps the connection, abandoned plans are cancelled, connection / queue / topic caps hold."""

from __future__ import annotations

import contextlib
import json
import socket
import threading
import time
from collections.abc import Iterator, Mapping
from typing import Any

import httpx
import pytest
from websockets.sync.client import connect

from pfield.errors import InvalidInput
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import std_srvs
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.planning.cancel import CancelToken
from pfield.transport.http import DEFAULT_MAX_REQUEST_BYTES, ServerLimits, ServerThread, create_app


class FaultyNode(Node):
    """A service that fails unexpectedly, a cancellable one that runs until cancelled, a publisher."""

    name = "/faulty"

    def __init__(self, bus: Bus) -> None:
        super().__init__(bus)
        self.cancelled = threading.Event()
        self.running = threading.Event()
        self.tokens: list[CancelToken] = []

    def services(self) -> list[ServiceSpec]:
        return [ServiceSpec("/faulty/boom", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, self.boom),
                ServiceSpec("/faulty/ok", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, lambda _: std_srvs.Trigger_Response(success=True)),
                ServiceSpec("/faulty/until_cancelled", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, self.until_cancelled, long_running=True, cancellable=True)]

    def subscriptions(self) -> list[SubscriptionSpec]:
        return [SubscriptionSpec("/faulty/in", "geometry_msgs/msg/Vector3", gm.Vector3, self.on_in)]

    def publications(self) -> list[PublicationSpec]:
        return [PublicationSpec("/faulty/out", "geometry_msgs/msg/Vector3", gm.Vector3)]

    def get_parameters(self) -> dict[str, Any]:
        return {}

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        return {}

    def boom(self, request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        raise RuntimeError("a bug in the node")

    def on_in(self, message: gm.Vector3) -> None:
        if message.x < 0:
            raise ZeroDivisionError("a bug in a subscription handler")

    def until_cancelled(self, request: std_srvs.Trigger_Request, cancel: CancelToken) -> std_srvs.Trigger_Response:
        self.tokens.append(cancel)
        self.running.set()
        deadline = time.monotonic() + 120
        while not cancel.cancelled and time.monotonic() < deadline:
            time.sleep(0.01)
        if cancel.cancelled:
            self.cancelled.set()
        return std_srvs.Trigger_Response(success=not cancel.cancelled, message="cancelled")


def _serve() -> Iterator[tuple[FaultyNode, ServerThread]]:
    node = FaultyNode(Bus())
    limits = ServerLimits(max_connections=20, header_timeout=1.0, body_timeout=1.0, max_websockets=3)
    with ServerThread(create_app([node], ws_queue_size=5, ws_queue_bytes=10_000), limits=limits) as server:
        yield node, server


@pytest.fixture(scope="module")
def served() -> Iterator[tuple[FaultyNode, ServerThread]]:
    yield from _serve()


@pytest.fixture
def served_alone() -> Iterator[tuple[FaultyNode, ServerThread]]:
    """A server of its own, for a test that counts every slot: a connection an earlier test closed leaves the
    module's server only when the server notices (a loaded machine may take a while), and one with a request
    still in progress is not evicted, so it would take one of the counted slots."""
    yield from _serve()


def _raw_request(conn: socket.socket, method: str, path: str, body: bytes = b"") -> tuple[int, bytes]:
    """Send one HTTP/1.1 request on ``conn`` (kept alive) and read its answer (status, body)."""
    head = (f"{method} {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
            f"Content-Length: {len(body)}\r\n\r\n").encode()
    conn.sendall(head + body)
    return _read_response(conn)


def _read_response(conn: socket.socket) -> tuple[int, bytes]:
    """The next answer on ``conn`` (status, body), which stays open."""
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = conn.recv(65536)
        assert chunk, "the server closed the connection"
        data += chunk
    header, _, rest = data.partition(b"\r\n\r\n")
    length = int(next(line.split(b":")[1] for line in header.split(b"\r\n")
                      if line.lower().startswith(b"content-length")))
    while len(rest) < length:
        chunk = conn.recv(65536)
        assert chunk, "the server closed the connection"
        rest += chunk
    return int(header.split(b" ")[1]), rest[:length]


def test_a_server_fault_answers_json_500_and_keeps_the_connection(served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    with socket.create_connection((server.host, server.port), timeout=30) as conn:
        status, body = _raw_request(conn, "POST", "/srv/faulty/boom", b"{}")
        assert status == 500
        error = json.loads(body)
        assert set(error) == {"error", "field", "value"} and "RuntimeError: a bug in the node" in error["error"]
        assert _raw_request(conn, "POST", "/srv/faulty/ok", b"{}")[0] == 200  # the same connection still works
        status, body = _raw_request(conn, "POST", "/topic/faulty/in", b'{"x": -1}')
        assert status == 500 and "ZeroDivisionError" in json.loads(body)["error"]
        assert _raw_request(conn, "GET", "/nodes")[0] == 200
    with httpx.Client(base_url=server.url) as client:
        assert client.post("/srv/faulty/boom", json={}).status_code == 500
        assert client.post("/srv/faulty/ok", json={}).json()["success"] is True


def test_a_call_is_cancelled_when_its_client_goes_away(served: tuple[FaultyNode, ServerThread]) -> None:
    node, server = served
    with pytest.raises(httpx.ReadTimeout):
        httpx.post(f"{server.url}/srv/faulty/until_cancelled", json={}, timeout=httpx.Timeout(30, read=1.0))
    assert node.running.is_set()
    assert node.cancelled.wait(timeout=60)  # the client closed its connection: the handler's token was cancelled
    assert node.tokens[-1].cancelled
    assert httpx.post(f"{server.url}/srv/faulty/ok", json={}).json()["success"] is True


@contextlib.contextmanager
def _connections(server: ServerThread, count: int) -> Iterator[list[socket.socket]]:
    """``count`` open connections to ``server``; closed afterwards, then until the server answers again
    (closed sockets leave its table as it notices them)."""
    conns = [socket.create_connection((server.host, server.port), timeout=30) for _ in range(count)]
    try:
        yield conns
    finally:
        for conn in conns:
            conn.close()
    deadline = time.monotonic() + 30
    while True:
        try:
            if httpx.get(f"{server.url}/nodes", timeout=5).status_code == 200:
                return
        except httpx.TransportError:
            pass
        assert time.monotonic() < deadline
        time.sleep(0.1)


def test_a_new_connection_beyond_the_cap_takes_the_slot_of_the_longest_idle_one(
        served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    with _connections(server, 20) as idle:
        time.sleep(0.1)
        with socket.create_connection((server.host, server.port), timeout=30) as extra:
            assert _raw_request(extra, "GET", "/nodes")[0] == 200
        assert idle[0].recv(100) == b""  # the first idle connection gave its slot


def test_connections_beyond_the_cap_are_refused_with_429_when_all_are_busy(
        served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    with _connections(server, 20) as busy:
        for conn in busy:  # each holds a request in progress (until its client goes away)
            conn.sendall(b"POST /srv/faulty/until_cancelled HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                         b"Content-Type: application/json\r\nContent-Length: 2\r\n\r\n{}")
        time.sleep(0.3)
        with socket.create_connection((server.host, server.port), timeout=30) as extra:
            answer = extra.recv(4096)
            assert answer.startswith(b"HTTP/1.1 429 ")
            assert json.loads(answer.partition(b"\r\n\r\n")[2])["field"] == "connections"


def test_half_sent_request_heads_are_closed(served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    with socket.create_connection((server.host, server.port), timeout=30) as slow:
        slow.sendall(b"POST /srv/faulty/ok HTTP/1.1\r\nHost: 127.0.0.1\r\n")
        assert slow.recv(100) == b""
    with socket.create_connection((server.host, server.port), timeout=30) as keep:
        assert _raw_request(keep, "GET", "/nodes")[0] == 200
        keep.sendall(b"GET /nodes HTTP/1.1\r\n")  # a second head, never finished
        assert keep.recv(100) == b""


_OK_HEAD = b"POST /srv/faulty/ok HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"


def _answer(conn: socket.socket) -> tuple[int, dict[str, Any]]:
    """Status and JSON body of the one answer on ``conn``, read until the server closes it."""
    data = b""
    while chunk := conn.recv(65536):
        data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    return int(head.split(b" ")[1]), json.loads(body)


def test_a_half_sent_body_is_answered_408_and_closed_at_the_body_deadline(
        served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    with socket.create_connection((server.host, server.port), timeout=30) as slow:
        slow.sendall(_OK_HEAD + b"Content-Length: 10\r\n\r\n{}")  # 2 of the 10 bytes announced
        started = time.monotonic()
        status, error = _answer(slow)
    assert status == 408 and error["field"] == "body" and 0.9 < time.monotonic() - started < 5.0
    with socket.create_connection((server.host, server.port), timeout=30) as fine:  # a body in pieces is fine
        fine.sendall(_OK_HEAD + b"Content-Length: 2\r\n\r\n{")
        time.sleep(0.3)
        fine.sendall(b"}")
        assert _read_response(fine) == (200, b'{"success":true,"message":""}')


def test_at_the_cap_a_new_connection_takes_the_slot_of_the_longest_waiting_half_sent_body(
        served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    with _connections(server, 20) as bodies:
        for conn in bodies:
            conn.sendall(_OK_HEAD + b"Content-Length: 10\r\n\r\n")
        time.sleep(0.2)
        with socket.create_connection((server.host, server.port), timeout=30) as newcomer:
            assert _raw_request(newcomer, "GET", "/nodes")[0] == 200
        status, error = _answer(bodies[0])
        assert status == 408 and "admit another connection" in error["error"]


def test_chunk_sizes_beyond_the_body_cap_are_refused_413_before_their_bytes(
        served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    cap = DEFAULT_MAX_REQUEST_BYTES  # the app's body cap (create_app's max_request_bytes)
    for sizes in (b"ffffffffffffffff\r\n", b"80000\r\n" + b" " * 0x80000 + b"\r\n80000\r\n"):
        with socket.create_connection((server.host, server.port), timeout=30) as conn:
            conn.sendall(_OK_HEAD + b"Transfer-Encoding: chunked\r\n\r\n" + sizes)
            status, error = _answer(conn)
        assert status == 413 and error["field"] == "body" and str(cap) in error["error"], error
    with socket.create_connection((server.host, server.port), timeout=30) as conn:  # a chunked body in pieces
        for piece in (_OK_HEAD + b"Transfer-Enc", b"oding: Chunked\r\n", b"\r\n1\r\n{\r",
                      b"\n1;ext=1\r\n}\r\n0\r\n\r\n"):
            conn.sendall(piece)
            time.sleep(0.02)
        assert _read_response(conn) == (200, b'{"success":true,"message":""}')
        assert _raw_request(conn, "GET", "/nodes")[0] == 200  # and the connection stays usable
    with httpx.Client(base_url=server.url) as client:  # httpx streams an iterator's body chunked
        answer = client.post("/srv/faulty/ok", content=iter([b"{", b"}"]), headers={"content-type": "application/json"})
        assert answer.status_code == 200 and answer.json()["success"] is True


def _websocket_handshake(server: ServerThread) -> tuple[socket.socket, int]:
    conn = socket.create_connection((server.host, server.port), timeout=30)
    conn.sendall(b"GET /ws/topic/faulty/quiet HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
                 b"Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                 b"Sec-WebSocket-Version: 13\r\n\r\n")
    return conn, int(conn.recv(4096).split(b" ")[1])


def test_websockets_have_their_own_cap_and_take_no_http_slot(served_alone: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served_alone
    sockets = [_websocket_handshake(server) for _ in range(5)]
    try:
        assert [status for _, status in sockets] == [101, 101, 101, 429, 429]
        with _connections(server, 20) as http:  # all 20 HTTP slots answer beside the 3 WebSockets
            assert all(_raw_request(conn, "GET", "/nodes")[0] == 200 for conn in http)
        sockets[0][0].close()
        deadline = time.monotonic() + 30
        while (status := _websocket_handshake(server))[1] != 101:  # a closed WebSocket frees its slot
            status[0].close()
            assert time.monotonic() < deadline
            time.sleep(0.05)
        sockets.append(status)
    finally:
        for conn, _ in sockets:
            conn.close()


def test_a_websocket_that_never_reads_drops_the_oldest_and_counts(served: tuple[FaultyNode, ServerThread]) -> None:
    node, server = served
    with connect(server.url.replace("http", "ws") + "/ws/topic/faulty/out", open_timeout=10) as ws:
        deadline = time.monotonic() + 30
        while httpx.get(f"{server.url}/health").json()["websocket"]["connections"] < 1:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        big = gm.Vector3(x=1.0)
        for i in range(20_000):
            node.bus.publish("/faulty/out", big.model_copy(update={"y": float(i)}))
        deadline = time.monotonic() + 30
        while (health := httpx.get(f"{server.url}/health").json())["websocket"]["dropped_messages"] == 0:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert health["limits"]["ws_queue_messages"] == 5
        last = None
        while last is None or last["y"] != 19_999.0:  # the newest message always arrives
            last = json.loads(ws.recv(timeout=30))


def test_undeclared_topics_keep_a_bounded_number_of_latest_messages(served: tuple[FaultyNode, ServerThread]) -> None:
    node, server = served
    declared = {t["name"] for t in httpx.get(f"{server.url}/topics").json()}
    with connect(server.url.replace("http", "ws") + "/ws/topic/junk/live", open_timeout=10) as live:
        assert httpx.post(f"{server.url}/topic/junk/live", params={"type": "geometry_msgs/msg/Vector3"},
                          json={"x": 5}).status_code == 200
        assert json.loads(live.recv(timeout=30))["x"] == 5.0  # live listeners get every topic
    with httpx.Client(base_url=server.url) as client:  # one client: building one costs 40 ms
        for i in range(300):
            answer = client.post(f"/topic/junk/{i}", params={"type": "geometry_msgs/msg/Vector3"}, json={"x": i})
            assert answer.status_code == 200
        listed = {t["name"] for t in client.get("/topics").json()} - declared
        assert listed == {f"/junk/{i}" for i in range(300 - node.bus.max_undeclared, 300)}
        assert client.get("/topic/junk/299").json()["x"] == 299.0
        assert client.get("/topic/junk/0").status_code == 404
        client.post("/topic/faulty/in", json={"x": 3})  # declared topics always keep their latest
        for i in range(100):
            client.post(f"/topic/junk/more{i}", params={"type": "geometry_msgs/msg/Vector3"}, json={"x": i})
        assert client.get("/topic/faulty/in").json()["x"] == 3.0


def test_health_reports_readiness_from_the_callable() -> None:
    warm = threading.Event()
    with ServerThread(create_app([FaultyNode(Bus())], ready=warm.is_set)) as server:
        health = httpx.get(f"{server.url}/health").json()
        assert health["ready"] is False and health["start_up"] == "running"
        warm.set()
        health = httpx.get(f"{server.url}/health").json()
        assert health["ready"] is True and health["start_up"] == "done" and health["nodes"] == ["/faulty"]
        assert "errors" not in health


def test_health_reports_start_up_work_that_failed() -> None:
    failures: list[str] = []
    with ServerThread(create_app([FaultyNode(Bus())], ready=lambda: True, errors=lambda: failures)) as server:
        assert httpx.get(f"{server.url}/health").json()["start_up"] == "done"
        failures.append("fitting the link model of robot flat failed: link l1=...")
        health = httpx.get(f"{server.url}/health").json()
        assert health["ready"] is False and health["start_up"] == "failed" and health["errors"] == failures


def test_json_null_is_not_a_message_of_defaults(served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    for path in ("/topic/faulty/in", "/topic/other?type=geometry_msgs/msg/Vector3", "/srv/faulty/ok"):
        answer = httpx.post(server.url + path, content=b"null", headers={"content-type": "application/json"})
        assert answer.status_code == 400 and answer.json()["field"] == "body", answer.text


def test_a_request_head_over_the_cap_is_answered_400_and_closed(served: tuple[FaultyNode, ServerThread]) -> None:
    _, server = served
    cap = ServerLimits().max_header_bytes
    with socket.create_connection((server.host, server.port), timeout=30) as big:
        big.sendall(b"GET /nodes HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Padding: " + b"a" * (cap + 100) + b"\r\n\r\n")
        data = b""
        while chunk := big.recv(65536):
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 400") and json.loads(body)["field"] == "request"
    with socket.create_connection((server.host, server.port), timeout=30) as fine:  # the server still answers
        assert _raw_request(fine, "GET", "/nodes")[0] == 200


@pytest.mark.parametrize("body", [b"{", b"\xff\xfe{}", b"[1, 2]", b'{"unknown": 1}'])
def test_a_short_service_refuses_a_bad_body_with_400_naming_it(served: tuple[FaultyNode, ServerThread],
                                                                body: bytes) -> None:
    _, server = served
    answer = httpx.post(f"{server.url}/srv/faulty/ok", content=body, headers={"content-type": "application/json"})
    assert answer.status_code == 400, answer.text
    error = answer.json()
    assert set(error) == {"error", "field", "value"} and error["field"] in ("body", "unknown"), error
    assert httpx.post(f"{server.url}/srv/faulty/ok", json={}).json() == {"success": True, "message": ""}


class NicenessNode(FaultyNode):
    """Two Trigger services answering the niceness of the thread that runs them: one short, one long-running."""

    name = "/nice"

    def services(self) -> list[ServiceSpec]:
        def niceness(_: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
            import os

            return std_srvs.Trigger_Response(success=True, message=str(os.getpriority(os.PRIO_PROCESS,
                                                                                      threading.get_native_id())))

        return [ServiceSpec("/nice/short", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, niceness),
                ServiceSpec("/nice/long", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, niceness, long_running=True)]


def test_long_running_services_run_at_a_lower_priority_than_short_ones() -> None:
    import os

    from pfield.transport.http import LONG_RUNNING_NICENESS

    with ServerThread(create_app([NicenessNode(Bus())])) as server:
        short = int(httpx.post(f"{server.url}/srv/nice/short", json={}).json()["message"])
        long = int(httpx.post(f"{server.url}/srv/nice/long", json={}).json()["message"])
    assert short == os.getpriority(os.PRIO_PROCESS, 0)
    assert long == min(19, short + LONG_RUNNING_NICENESS)


def test_a_server_shortens_the_gil_switch_interval_and_refuses_a_nonpositive_one() -> None:
    """A plan's answer is written in GIL-holding steps; control-loop calls get the GIL within the interval."""
    import sys

    before = sys.getswitchinterval()
    try:
        sys.setswitchinterval(0.005)
        with ServerThread(create_app([NicenessNode(Bus())]), limits=ServerLimits(gil_switch_interval=0.0007)):
            assert sys.getswitchinterval() == pytest.approx(0.0007)
        assert ServerLimits().gil_switch_interval < 0.005
        with pytest.raises(InvalidInput) as info:
            ServerLimits(gil_switch_interval=0.0)
        assert info.value.field == "gil_switch_interval"
    finally:
        sys.setswitchinterval(before)
