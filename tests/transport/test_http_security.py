"""Browser protections and body checks of a real ``pfield serve`` (127.0.0.1): what a web page the user opens
can send (forms, ``text/plain``, other origins, a rebound DNS name) is refused and changes nothing."""

from __future__ import annotations

import json
import os
import socket
import subprocess
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from serve_process import PFIELD, pfield_serve

BALL = {"header": {"frame_id": "world"},
        "obstacles": [{"frame_id": "ball", "type": "Sphere", "group": "Static", "radius": 0.1,
                       "pose": {"position": {"x": 0.4, "y": 0.0, "z": 0.1}}}]}
GOAL = {"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.5, "y": 0.2, "z": 0.4}}}


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    log = tmp_path_factory.mktemp("serve") / "serve.log"
    with pfield_serve("--allow-origin", "http://viewer.example:8080", log=log) as (url, _):
        assert httpx.post(f"{url}/topic/pfield/obstacles", json=BALL).status_code == 200
        assert httpx.post(f"{url}/topic/pfield/planning_goal_pose", json=GOAL).status_code == 200
        yield url
    assert "Traceback" not in log.read_text()


def _state(url: str) -> dict[str, Any]:
    """What a refused request must not change: obstacles, goal, parameters, the teleop topics."""
    ids = httpx.post(f"{url}/srv/pfield/remove_obstacles", json={"frame_ids": []}).json()["remaining"]
    return {"obstacles": sorted(ids),
            "goal": httpx.get(f"{url}/topic/pfield/planning_goal_pose").json(),
            "params": httpx.get(f"{url}/param/pfield_manager").json(),
            "cmd_vel": httpx.get(f"{url}/topic/cmd_vel").status_code,
            "topics": [t["name"] for t in httpx.get(f"{url}/topics").json()]}


def _refusal(answer: httpx.Response, status: int, field: str) -> None:
    assert answer.status_code == status, answer.text
    body = answer.json()
    assert set(body) == {"error", "field", "value"} and body["field"] == field and body["error"]


def test_a_form_post_does_not_clear_the_obstacles(served: str) -> None:
    before = _state(served)
    form = httpx.post(f"{served}/srv/pfield/clear_obstacles", content=b"",
                      headers={"content-type": "application/x-www-form-urlencoded"})
    _refusal(form, 415, "Content-Type")
    multipart = httpx.post(f"{served}/srv/pfield/clear_obstacles", files={"x": b"1"})
    _refusal(multipart, 415, "Content-Type")
    assert _state(served) == before and before["obstacles"] == ["ball"]


def test_text_plain_and_empty_bodies_do_not_move_the_goal_or_drive(served: str) -> None:
    before = _state(served)
    for path in ("/topic/pfield/planning_goal_pose", "/topic/cmd_vel_teleop",
                 "/topic/cmd_vel?type=geometry_msgs/msg/Twist", "/srv/pfield/clear_obstacles"):
        plain = httpx.post(served + path, content=b'{"linear": {"x": 1.0}}', headers={"content-type": "text/plain"})
        _refusal(plain, 415, "Content-Type")
        empty = httpx.post(served + path, content=b"", headers={"content-type": "application/json"})
        _refusal(empty, 400, "body")
    assert _state(served) == before


def test_other_hosts_are_refused(served: str) -> None:
    """DNS rebinding: a page at evil.example that resolves to 127.0.0.1 sends ``Host: evil.example``."""
    before = _state(served)
    port = served.rsplit(":", 1)[1]
    for host in ("evil.example", f"evil.example:{port}", "127.0.0.1:1", "localhost.evil.example"):
        put = httpx.put(f"{served}/param/pfield_manager", json={"attractive_gain": 7.0}, headers={"host": host})
        _refusal(put, 421, "Host")
        _refusal(httpx.get(f"{served}/param/pfield_manager", headers={"host": host}), 421, "Host")
    for host in (f"localhost:{port}", f"127.0.0.1:{port}", "localhost"):
        assert httpx.get(f"{served}/nodes", headers={"host": host}).status_code == 200
    assert _state(served) == before


def test_other_origins_cannot_change_state_or_open_websockets(served: str) -> None:
    before = _state(served)
    port = served.rsplit(":", 1)[1]
    for origin in ("http://evil.example", "null", f"http://evil.example:{port}", "http://127.0.0.1:1"):
        posted = httpx.post(f"{served}/srv/pfield/clear_obstacles", json={}, headers={"origin": origin})
        _refusal(posted, 403, "Origin")
        with pytest.raises(InvalidStatus) as refused:
            connect(f"ws://127.0.0.1:{port}/ws/topic/pfield/planning_goal_pose", origin=origin,  # type: ignore[arg-type]
                    open_timeout=10)
        assert refused.value.response.status_code == 403
    read = httpx.get(f"{served}/param/pfield_manager", headers={"origin": "http://evil.example"})
    assert read.status_code == 200 and "access-control-allow-origin" not in read.headers  # no CORS: unreadable
    assert _state(served) == before
    for origin in (f"http://127.0.0.1:{port}", f"http://localhost:{port}", "http://viewer.example:8080"):
        with connect(f"ws://127.0.0.1:{port}/ws/topic/pfield/planning_goal_pose", origin=origin,  # type: ignore[arg-type]
                     open_timeout=10) as ws:
            assert json.loads(ws.recv(timeout=10))["pose"]["position"]["x"] == 0.5
    preflight = httpx.options(f"{served}/srv/pfield/clear_obstacles",
                              headers={"origin": "http://viewer.example:8080", "access-control-request-method": "POST",
                                       "access-control-request-headers": "content-type"})
    assert preflight.headers["access-control-allow-origin"] == "http://viewer.example:8080"


def test_errors_are_in_pfields_format(served: str) -> None:
    _refusal(httpx.get(f"{served}/srv/pfield/plan_path"), 405, "path")
    _refusal(httpx.delete(f"{served}/param/pfield_manager"), 405, "path")
    _refusal(httpx.get(f"{served}/no/such/route"), 404, "path")
    _refusal(httpx.put(f"{served}/param/pfield_manager", json=[1, 2]), 400, "body")
    bad_query = httpx.post(f"{served}/topic/pfield/planning_goal_pose", params={"type": "no/such/Type"}, json=GOAL)
    _refusal(bad_query, 400, "type")


def test_deep_json_is_refused_with_400(served: str) -> None:
    before = _state(served)
    deep = b"[" * 100_000 + b"]" * 100_000
    for path in ("/topic/junk?type=geometry_msgs/msg/Twist", "/topic/pfield/planning_goal_pose",
                 "/srv/pfield/plan_path", "/param/pfield_manager"):
        method = "PUT" if path.startswith("/param") else "POST"
        answer = httpx.request(method, served + path, content=deep, headers={"content-type": "application/json"})
        _refusal(answer, 400, "body")
    assert _state(served) == before


def test_websocket_bad_frames_get_an_error_frame_and_the_socket_stays(served: str) -> None:
    port = served.rsplit(":", 1)[1]
    with connect(f"ws://127.0.0.1:{port}/ws/topic/pfield/query_pose", open_timeout=10) as ws:
        for frame in (b"\x00\x01binary", "[" * 100_000 + "]" * 100_000, '{"pose": {"position": {"x": 1e309}}}',
                      "{not json", '{"header": {"frame_id": "mars"}}', "[1, 2]"):
            ws.send(frame)
            answer = json.loads(ws.recv(timeout=30))
            assert set(answer) == {"error", "field", "value"}, answer
        ws.send(json.dumps({"header": {"frame_id": "world"}, "pose": {"position": {"x": 0.3, "y": 0.1, "z": 0.35}}}))
        assert json.loads(ws.recv(timeout=300))["pose"]["position"]["x"] == 0.3  # the socket still works


def test_a_slow_request_head_is_cut_and_health_answers(served: str) -> None:
    health = httpx.get(f"{served}/health").json()
    assert health["ready"] is True and health["start_up"] == "done"
    assert health["limits"]["max_request_bytes"] == 1_000_000
    host, port = served.removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=60) as slow:
        slow.sendall(b"GET /nodes HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")  # and then nothing
        assert slow.recv(100) == b""  # closed by the server after its header timeout


def test_the_cli_still_works_with_the_checks(served: str) -> None:
    env = os.environ | {"PFIELD_URL": served}
    done = subprocess.run([str(PFIELD), "service", "call", "/pfield/clear_obstacles", "std_srvs/srv/Trigger"],
                          capture_output=True, text=True, env=env, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert "removed 1 obstacle(s)" in done.stdout
    assert httpx.post(f"{served}/topic/pfield/obstacles", json=BALL).status_code == 200
