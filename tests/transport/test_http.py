"""The HTTP/WebSocket transport on a real uvicorn server (127.0.0.1, free port) with a small real node."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator, Mapping
from typing import Any

import httpx
import pytest
from websockets.sync.client import connect

from pfield.errors import InvalidInput
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces import std_srvs
from pfield.node._base import Bus, Node, PublicationSpec, ServiceSpec, SubscriptionSpec
from pfield.transport.http import ServerThread, create_app


class CounterNode(Node):
    """Holds a pose (fixed frame 'world'), a gain parameter, a fast and a blocking service."""

    name = "/counter"
    tick_period = 0.01

    def __init__(self, bus: Bus) -> None:
        super().__init__(bus)
        self.pose: gm.PoseStamped | None = None
        self.gain = 1.0
        self.ticks = 0
        self.release = threading.Event()
        self.slow_started = threading.Event()

    def services(self) -> list[ServiceSpec]:
        return [ServiceSpec("/counter/fast", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, self.fast),
                ServiceSpec("/counter/slow", "std_srvs/srv/Trigger", std_srvs.Trigger_Request,
                            std_srvs.Trigger_Response, self.slow, long_running=True)]

    def subscriptions(self) -> list[SubscriptionSpec]:
        return [SubscriptionSpec("/counter/pose", "geometry_msgs/msg/PoseStamped", gm.PoseStamped, self.on_pose),
                SubscriptionSpec("/counter/block", "geometry_msgs/msg/Vector3", gm.Vector3, self.on_block)]

    def publications(self) -> list[PublicationSpec]:
        return [PublicationSpec("/counter/out", "geometry_msgs/msg/Vector3", gm.Vector3)]

    def get_parameters(self) -> dict[str, Any]:
        return {"gain": self.gain}

    def set_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        for key, value in values.items():
            if key != "gain":
                raise InvalidInput(key, value, "unknown parameter")
            if not isinstance(value, int | float) or value <= 0:
                raise InvalidInput("gain", value, "must be > 0")
        self.gain = float(values.get("gain", self.gain))
        return self.get_parameters()

    def on_pose(self, message: gm.PoseStamped) -> None:
        if message.header.frame_id != "world":
            raise InvalidInput("header.frame_id", message.header.frame_id, "must be 'world'")
        self.pose = message
        self.bus.publish("/counter/out", gm.Vector3(x=message.pose.position.x * self.gain))

    def on_block(self, message: gm.Vector3) -> None:
        self.slow_started.set()
        self.release.wait(timeout=30)

    def fast(self, request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        return std_srvs.Trigger_Response(success=True, message=f"gain {self.gain}")

    def slow(self, request: std_srvs.Trigger_Request) -> std_srvs.Trigger_Response:
        self.slow_started.set()
        released = self.release.wait(timeout=30)
        return std_srvs.Trigger_Response(success=released, message="slow done")

    def tick(self, now: float) -> None:
        self.ticks += 1


@pytest.fixture(scope="module")
def served() -> Iterator[tuple[CounterNode, str]]:
    node = CounterNode(Bus())
    with ServerThread(create_app([node], max_request_bytes=10_000)) as server:
        yield node, server.url


def test_listings_and_openapi(served: tuple[CounterNode, str]) -> None:
    _, url = served
    assert httpx.get(f"{url}/nodes").json() == ["/counter"]
    assert httpx.get(f"{url}/services").json() == [{"name": "/counter/fast", "type": "std_srvs/srv/Trigger"},
                                                   {"name": "/counter/slow", "type": "std_srvs/srv/Trigger"}]
    topics = {t["name"]: t for t in httpx.get(f"{url}/topics").json()}
    assert topics["/counter/pose"]["subscribers"] == ["/counter"]
    assert topics["/counter/out"]["publishers"] == ["/counter"]
    schema = httpx.get(f"{url}/openapi.json").json()
    assert "/srv/counter/fast" in schema["paths"] and "/topic/counter/pose" in schema["paths"]


def test_service_call_and_errors(served: tuple[CounterNode, str]) -> None:
    _, url = served
    assert httpx.post(f"{url}/srv/counter/fast", json={}).json() == {"success": True, "message": "gain 1.0"}
    empty = httpx.post(f"{url}/srv/counter/fast", headers={"content-type": "application/json"})
    assert empty.status_code == 400 and empty.json()["field"] == "body"  # refused, no longer a default message
    missing = httpx.post(f"{url}/srv/counter/nope", json={})
    assert missing.status_code == 404 and "/counter/fast" in missing.json()["error"]
    unknown_field = httpx.post(f"{url}/srv/counter/fast", json={"x": 1})
    assert unknown_field.status_code == 400 and unknown_field.json()["field"] == "x"


def test_publish_validates_before_the_node_sees_it(served: tuple[CounterNode, str]) -> None:
    node, url = served
    ok = httpx.post(f"{url}/topic/counter/pose", json={"header": {"frame_id": "world"}, "pose": {"position": {"x": 2}}})
    assert ok.status_code == 200 and node.pose is not None and node.pose.pose.position.x == 2.0
    before = node.pose
    cases = [({"pose": {"position": {"xx": 1}}}, "pose.position.xx"),
             ({"header": {"frame_id": "map"}}, "header.frame_id"),
             ({"pose": {"position": {"x": "far"}}}, "pose.position.x")]
    for body, field in cases:
        answer = httpx.post(f"{url}/topic/counter/pose", json=body)
        assert answer.status_code == 400 and answer.json()["field"] == field
    malformed = httpx.post(f"{url}/topic/counter/pose", content=b"{not json", headers={"content-type":
                                                                                      "application/json"})
    assert malformed.status_code == 400 and malformed.json()["field"] == "body"
    assert node.pose is before
    assert httpx.get(f"{url}/topic/counter/out").json() == {"x": 2.0, "y": 0.0, "z": 0.0}


def test_untyped_topics_need_a_type(served: tuple[CounterNode, str]) -> None:
    _, url = served
    assert httpx.post(f"{url}/topic/free", json={"x": 1}).status_code == 400
    assert httpx.post(f"{url}/topic/free", params={"type": "geometry_msgs/msg/Vector3"}, json={"x": 1}).is_success
    assert httpx.get(f"{url}/topic/free").json()["x"] == 1.0
    wrong = httpx.post(f"{url}/topic/counter/pose", params={"type": "geometry_msgs/msg/Vector3"}, json={})
    assert wrong.status_code == 400 and wrong.json()["field"] == "type"
    assert httpx.get(f"{url}/topic/never").status_code == 404


def test_oversized_requests_are_refused(served: tuple[CounterNode, str]) -> None:
    _, url = served
    big = json.dumps({"message": "x" * 20_000})
    assert httpx.post(f"{url}/srv/counter/fast", content=big).status_code == 413

    def chunks() -> Iterator[bytes]:
        yield big.encode()

    assert httpx.post(f"{url}/srv/counter/fast", content=chunks()).status_code == 413


def test_parameters_all_or_nothing(served: tuple[CounterNode, str]) -> None:
    node, url = served
    assert httpx.put(f"{url}/param/counter", json={"gain": 2.5}).json() == {"gain": 2.5}
    bad = httpx.put(f"{url}/param/counter", json={"gain": -1})
    assert bad.status_code == 400 and bad.json()["field"] == "gain"
    assert httpx.get(f"{url}/param/counter").json() == {"gain": 2.5} and node.gain == 2.5
    assert httpx.get(f"{url}/param/nobody").status_code == 404
    httpx.put(f"{url}/param/counter", json={"gain": 1.0})


def test_websocket_streams_latest_then_new_and_accepts_publications(served: tuple[CounterNode, str]) -> None:
    _, url = served
    ws_url = url.replace("http", "ws") + "/ws/topic/counter/out"
    httpx.post(f"{url}/topic/counter/pose", json={"header": {"frame_id": "world"}, "pose": {"position": {"x": 1}}})
    with connect(ws_url) as socket:
        assert json.loads(socket.recv(timeout=10))["x"] == 1.0
        httpx.post(f"{url}/topic/counter/pose", json={"header": {"frame_id": "world"},
                                                       "pose": {"position": {"x": 3}}})
        assert json.loads(socket.recv(timeout=10))["x"] == 3.0
    with connect(url.replace("http", "ws") + "/ws/topic/counter/pose") as socket:
        assert json.loads(socket.recv(timeout=10))["pose"]["position"]["x"] == 3.0  # the latest, first
        socket.send(json.dumps({"header": {"frame_id": "world"}, "pose": {"position": {"x": 4}}}))
        assert json.loads(socket.recv(timeout=10))["pose"]["position"]["x"] == 4.0
        socket.send(json.dumps({"header": {"frame_id": "map"}}))
        assert "header.frame_id" in json.loads(socket.recv(timeout=10))["error"]


def test_short_calls_answer_while_a_long_call_runs(served: tuple[CounterNode, str]) -> None:
    node, url = served
    node.release.clear()
    node.slow_started.clear()
    result: dict[str, Any] = {}
    worker = threading.Thread(target=lambda: result.update(httpx.post(f"{url}/srv/counter/slow", json={},
                                                                      timeout=60).json()))
    worker.start()
    assert node.slow_started.wait(timeout=30)
    assert httpx.post(f"{url}/srv/counter/fast", json={}).json()["success"]  # answered while slow is blocked
    assert not result
    node.release.set()
    worker.join(timeout=30)
    assert result == {"success": True, "message": "slow done"}
    assert node.ticks > 0


def test_token_is_required_when_set() -> None:
    node = CounterNode(Bus())
    with ServerThread(create_app([node], token="s3cret")) as server:
        assert httpx.get(f"{server.url}/nodes").status_code == 401
        assert httpx.get(f"{server.url}/nodes", headers={"Authorization": "Bearer wrong"}).status_code == 401
        assert httpx.get(f"{server.url}/nodes", headers={"Authorization": "Bearer s3cret"}).json() == ["/counter"]
        with connect(server.url.replace("http", "ws") + "/ws/topic/counter/out?token=s3cret") as socket:
            socket.close()


def test_slow_subscription_handlers_do_not_block_services(served: tuple[CounterNode, str]) -> None:
    node, url = served
    node.release.clear()
    node.slow_started.clear()
    worker = threading.Thread(target=lambda: httpx.post(f"{url}/topic/counter/block", json={"x": 1}, timeout=60))
    worker.start()
    assert node.slow_started.wait(timeout=30)
    assert httpx.post(f"{url}/srv/counter/fast", json={}).json()["success"]  # answered while the handler waits
    node.release.set()
    worker.join(timeout=30)
    assert httpx.get(f"{url}/topic/counter/block").json()["x"] == 1.0
