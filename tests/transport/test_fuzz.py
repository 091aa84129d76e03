"""Fuzz a real ``pfield serve`` (127.0.0.1) with hand-made and generated hostile requests on every route and
WebSocket: 0 crashes, 0 5xx, 0 hangs, and no state change from any refused request.

Bounded: a fixed number of examples (hypothesis, derandomised: the same cases on every run) and a client
timeout per request; the whole module takes well under two minutes on a warm node.
"""

from __future__ import annotations

import json
import math
import socket
import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from websockets.sync.client import connect

from serve_process import pfield_serve

BALL = {"header": {"frame_id": "world"},
        "obstacles": [{"frame_id": "ball", "type": "Sphere", "group": "Static", "radius": 0.1,
                       "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.1}}}]}
GOAL = {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.5, "y": 0.2, "z": 0.4}}}
TIMEOUT = httpx.Timeout(60.0)
FUZZ = settings(max_examples=120, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck), phases=[Phase.explicit, Phase.generate])
"""A failing example is reported as found (no shrinking: it would repeat slow requests)."""


class Fuzzed:
    """The served node, its routes (from ``/openapi.json``) and the answers seen."""

    def __init__(self, url: str) -> None:
        self.url = url
        self.port = int(url.rsplit(":", 1)[1])
        self.client = httpx.Client(base_url=url, timeout=TIMEOUT)
        # no connection kept: every hostile request opens its own (one client: building one costs 40 ms)
        self.fresh = httpx.Client(timeout=TIMEOUT, limits=httpx.Limits(max_keepalive_connections=0))
        schema = self.client.get("/openapi.json").json()
        self.routes = [(method.upper(), path) for path, item in schema["paths"].items() for method in item]
        self.topics = [t["name"] for t in self.client.get("/topics").json()]
        self.statuses: list[int] = []

    def state(self) -> dict[str, Any]:
        """Everything a request could change, through the GET routes (and RemoveObstacles of no ids)."""
        answer: dict[str, Any] = {"params": {n: self.client.get(f"/param{n}").json()
                                             for n in self.client.get("/nodes").json()}}
        answer["obstacles"] = sorted(self.client.post("/srv/pfield/remove_obstacles",
                                                      json={"frame_ids": []}).json()["remaining"])
        for topic in sorted(t["name"] for t in self.client.get("/topics").json()):
            latest = self.client.get(f"/topic{topic}")
            answer[topic] = latest.json() if latest.status_code == 200 else latest.status_code
        return answer

    def send(self, method: str, path: str, content: bytes | None = None,
             headers: dict[str, str] | None = None) -> httpx.Response:
        """One request on a fresh connection; a 5xx or a timeout fails the test."""
        try:
            answer = self.fresh.request(method, self.url + path, content=content, headers=headers)
        except httpx.TimeoutException:
            pytest.fail(f"no answer in time to {method} {path} {content!r:.200}")
        self.statuses.append(answer.status_code)
        assert answer.status_code < 500, f"{method} {path} {content!r:.200}: {answer.status_code} {answer.text:.300}"
        if answer.status_code >= 400:
            assert set(answer.json()) == {"error", "field", "value"}, answer.text
        return answer


@pytest.fixture(scope="module")
def fuzzed(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Fuzzed]:
    log = tmp_path_factory.mktemp("fuzz") / "serve.log"
    with pfield_serve(log=log) as (url, process):
        target = Fuzzed(url)
        assert target.client.post("/topic/pfield/obstacles", json=BALL).status_code == 200
        assert target.client.post("/topic/pfield/planning_goal_pose", json=GOAL).status_code == 200
        yield target
        assert process.poll() is None, "the node died"
        deadline = time.monotonic() + 900.0  # the background warm-up may still compile on a cold cache
        while target.client.get("/health").json()["ready"] is not True and time.monotonic() < deadline:
            time.sleep(1.0)
        assert target.client.get("/health").json()["ready"] is True
    text = log.read_text()
    assert "Traceback" not in text, text[-3000:]


def _concrete(path: str) -> str:
    return path.replace("{name}", "pfield/nothing").replace("{topic}", "fuzz/topic").replace("{node}",
                                                                                             "pfield_manager")


def _hostile(fuzzed: Fuzzed) -> Iterator[tuple[str, str, bytes | None, dict[str, str]]]:
    """Requests every one of which must be refused (4xx) without changing anything."""
    json_type = {"content-type": "application/json"}
    evil_host = {"host": "evil.example"}
    for method, path in fuzzed.routes:
        route = _concrete(path)
        yield method, route, b"{}", json_type | evil_host
        yield method, route, b"{}", json_type | {"host": f"127.0.0.1:{fuzzed.port + 1}"}
        if method in ("POST", "PUT"):
            yield method, route, b"{}", json_type | {"origin": "http://evil.example"}
            yield method, route, b"{}", json_type | {"origin": "null"}
            yield method, route, b"a=1", {"content-type": "application/x-www-form-urlencoded"}
            yield method, route, b'{"x": 1}', {"content-type": "text/plain"}
            yield method, route, b"", json_type
            yield method, route, b"null", json_type
            yield method, route, b"[" * 50_000 + b"]" * 50_000, json_type
            yield method, route, b"{" * 70 + b"}" * 70, json_type
            yield method, route, b'{"a": ' * 200 + b"1" + b"}" * 200, json_type
            yield method, route, b"\xff\xfe{}", json_type
            yield method, route, b'{"frame_id": "\\ud800"', json_type
            yield method, route, b"x" * 1_100_000, json_type
        for other in ("DELETE", "PATCH", "TRACE"):
            yield other, route, b"{}", json_type
    yield "POST", "/topic/cmd_vel?type=geometry_msgs/msg/Twist", b'{"linear": {"x": 1}}', {"content-type": "text/plain"}
    yield "POST", "/topic/cmd_vel?type=no/such/Type", b'{"linear": {"x": 1}}', json_type
    yield "POST", "/topic/cmd_vel", b'{"linear": {"x": 1}}', json_type | {"origin": "http://evil.example"}
    yield "POST", "/srv/pfield/plan_path?x=" + "9" * 5000, b"{}", json_type | {"origin": "http://evil.example"}
    yield "GET", "/" + "a" * 20_000, None, {}
    yield "GET", "/param/nobody", None, {}
    yield "GET", "/topic/%00%ff", None, {}


def test_hand_made_hostile_requests_are_refused_and_change_nothing(fuzzed: Fuzzed) -> None:
    before = fuzzed.state()
    count = 0
    for method, path, content, headers in _hostile(fuzzed):
        answer = fuzzed.send(method, path, content, headers)
        assert 400 <= answer.status_code < 500, f"{method} {path} {content!r:.100} {headers}: {answer.status_code}"
        count += 1
    assert count > 200
    assert fuzzed.state() == before


def test_raw_protocol_garbage_never_kills_the_node(fuzzed: Fuzzed) -> None:
    garbage = [b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03" + b"\x00" * 64, b"GET / HTTP/9.9\r\n\r\n",
               b"POST /srv/pfield/clear_obstacles HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 5\r\n"
               b"Transfer-Encoding: chunked\r\n\r\n0\r\n\r\n",
               b"GET /nodes HTTP/1.1\r\nHost: 127.0.0.1\r\n" + b"X: " + b"y" * 40_000 + b"\r\n\r\n",
               b"\r\n" * 1000, b"GET /nodes HTTP/1.1\r\nHost: a\r\nHost: b\r\n\r\n"]
    before = fuzzed.state()
    for data in garbage:
        answer = b""
        with socket.create_connection(("127.0.0.1", fuzzed.port), timeout=30) as raw:
            try:
                raw.sendall(data)
                raw.shutdown(socket.SHUT_WR)
                while chunk := raw.recv(65536):
                    answer += chunk
            except ConnectionResetError:  # the server may close on garbage before reading all of it (a reset)
                pass
        assert not answer.startswith(b"HTTP/1.1 5"), answer[:200]
        assert not answer or answer.startswith((b"HTTP/1.1 2", b"HTTP/1.1 4")), answer[:200]
    assert fuzzed.state() == before


JSON_LEAVES = st.one_of(st.none(), st.booleans(), st.integers(min_value=-(2**70), max_value=2**70),
                        st.floats(allow_nan=False, allow_infinity=False), st.sampled_from([1e308, -1e308, 5e-324]),
                        st.text(max_size=20))
FIELD_NAMES = st.sampled_from(["header", "frame_id", "pose", "position", "orientation", "x", "y", "z", "w",
                               "obstacles", "type", "group", "radius", "goal", "start", "delta_time",
                               "max_iterations", "goal_tolerance", "planning_method", "query_pose", "frame_ids",
                               "joint_angles", "mesh_resource", "linear", "angular", "fixed_frame",
                               "influence_distance", "static_transforms", "attractive_gain"])
JSON_VALUES = st.recursive(JSON_LEAVES, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.one_of(FIELD_NAMES, st.text(max_size=8)), inner, max_size=5)),
    max_leaves=20)


def _mutating_routes(fuzzed: Fuzzed) -> list[tuple[str, str]]:
    # plan_path is left out: a valid generated request would plan (slow by design, and not hostile)
    return [(m, _concrete(p)) for m, p in fuzzed.routes if m in ("POST", "PUT") and "plan_path" not in p]


def test_generated_bodies_on_every_route(fuzzed: Fuzzed) -> None:
    routes = _mutating_routes(fuzzed)

    @FUZZ
    @given(route=st.sampled_from(routes), body=JSON_VALUES,
           content_type=st.sampled_from(["application/json", "application/json; charset=utf-8", "text/plain",
                                         "application/x-www-form-urlencoded", "multipart/form-data; boundary=x"]),
           origin=st.sampled_from([None, "http://evil.example", f"http://127.0.0.1:{fuzzed.port}"]))
    def check(route: tuple[str, str], body: Any, content_type: str, origin: str | None) -> None:
        method, path = route
        headers = {"content-type": content_type} | ({"origin": origin} if origin else {})
        before = fuzzed.state()
        answer = fuzzed.send(method, path, json.dumps(body, allow_nan=False).encode(), headers)
        if answer.status_code >= 400:
            assert fuzzed.state() == before, f"{method} {path} {body!r:.300} was refused but changed the state"
        elif path == "/srv/pfield/clear_obstacles" or "obstacles" in path:
            fuzzed.client.post("/topic/pfield/obstacles", json=BALL)

    check()
    assert any(s == 415 for s in fuzzed.statuses) and any(s == 400 for s in fuzzed.statuses)


def test_generated_websocket_frames(fuzzed: Fuzzed) -> None:
    topics = [t for t in fuzzed.topics if t not in ("/pfield/obstacles",)] + ["/fuzz/free"]

    @settings(FUZZ, max_examples=60)
    @given(topic=st.sampled_from(topics),
           frames=st.lists(st.one_of(JSON_VALUES.map(lambda v: json.dumps(v, allow_nan=False)),
                                     st.binary(max_size=64), st.sampled_from(["[" * 10_000, "{", "", "NaN",
                                                                              '{"x": 1e999}'])), min_size=1,
                           max_size=5))
    def check(topic: str, frames: list[str | bytes]) -> None:
        with connect(f"ws://127.0.0.1:{fuzzed.port}/ws{'/topic' + topic}", open_timeout=30,
                     close_timeout=10) as ws:
            for frame in frames:
                ws.send(frame)
            ws.send("{not json")  # always answered with an error frame: proves the socket is still served
            while True:
                answer = json.loads(ws.recv(timeout=60))
                if isinstance(answer, dict) and "malformed JSON" in str(answer.get("error")):
                    break

    check()


ABSURD = st.one_of(st.sampled_from([1e308, -1e308, 1.7e308, 5e-324, -5e-324, 1e38, -1e6, 0.0]),
                   st.floats(allow_nan=False, allow_infinity=False), st.floats(min_value=-1.0, max_value=1.0))
"""Finite float64 values, weighted toward the extremes of issue 31 (F1, F2)."""
VECTOR3 = st.fixed_dictionaries({"x": ABSURD, "y": ABSURD, "z": ABSURD})
COMMAND_REQUESTS = st.fixed_dictionaries({
    "planning_method": st.sampled_from(["task_space", "whole_body"]),
    "query_pose": st.fixed_dictionaries({"pose": st.fixed_dictionaries({"position": VECTOR3})}),
    "joint_angles": st.lists(st.floats(min_value=-1.5, max_value=1.5), min_size=7, max_size=7),
    "prev_joint_velocities": st.one_of(st.just([]), st.lists(st.sampled_from([0.0, 10.0, -1e38, 1e38, 3.0, 5e-324]),
                                                             min_size=7, max_size=7)),
    "delta_time": st.sampled_from([0.0, 0.001, 0.02, 0.5]),
    "user_command": st.fixed_dictionaries({"twist": st.fixed_dictionaries({"linear": VECTOR3, "angular": VECTOR3})}),
    "arbitration": st.sampled_from(["", "linear", "linear_goal", "safety_only"])})


def _within_limits(twist: dict[str, Any], limits: dict[str, Any]) -> bool:
    linear = [twist["linear"][k] for k in "xyz"]
    angular = [twist["angular"][k] for k in "xyz"]
    return (all(map(math.isfinite, linear + angular))
            and math.hypot(*linear) <= limits["max_linear_velocity"] * (1 + 1e-6)  # float32 on the wire
            and math.hypot(*angular) <= limits["max_angular_velocity"] * (1 + 1e-6))


def test_generated_commands_are_finite_and_within_limits(fuzzed: Fuzzed) -> None:
    """Issue 31: well-formed control-loop requests with absurd finite numbers (and absurd obstacle speeds on
    ``/pfield/obstacle_velocities``) answer commands that are finite and within the node's limits, or a 400."""
    limits = fuzzed.client.get("/param/pfield_manager").json()

    @settings(FUZZ, max_examples=150)
    @given(request=COMMAND_REQUESTS, velocity=st.one_of(st.none(), VECTOR3))
    def check(request: dict[str, Any], velocity: dict[str, float] | None) -> None:
        if velocity is not None:
            sent = fuzzed.send("POST", "/topic/pfield/obstacle_velocities",
                               json.dumps({"velocities": [{"frame_id": "ball", "linear": velocity}]}).encode(),
                               {"content-type": "application/json"})
            assert sent.status_code in (200, 400)
        for service, fields in (("compute_autonomy_vector", ("autonomy_vector",)),
                                ("compute_assistance", ("autonomy_vector", "blended_command"))):
            body = request if service == "compute_assistance" else {k: v for k, v in request.items()
                                                                    if k not in ("user_command", "arbitration")}
            answer = fuzzed.send("POST", f"/srv/pfield/{service}", json.dumps(body).encode(),
                                 {"content-type": "application/json"})
            if answer.status_code != 200:
                assert answer.status_code == 400
                continue
            result = answer.json()
            for name in fields:
                assert _within_limits(result[name]["twist"], limits), (service, body, result)
            assert all(map(math.isfinite, result.get("joint_velocities", []))), (body, result)

    check()
