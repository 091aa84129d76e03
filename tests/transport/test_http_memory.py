"""Memory of a real ``pfield serve`` stays bounded under floods of legal input (RSS read from /proc):
100 junk topic names of 300 kB messages each, a WebSocket client that never reads, a 2 GB mesh file inside
an allowed mesh root, and 500 connections that never finish their request head. (The obstacle flood:
``tests/cli/test_node_limits.py``.)"""

from __future__ import annotations

import base64
import json
import os
import socket
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from serve_process import pfield_serve, rss_bytes, wait_warm

SCAN = json.dumps({"ranges": [1.25] * 60_000}).encode()  # 300 kB of JSON, about 2 MB as a message
CEILING = 100_000_000
"""Growth of the node's RSS allowed under each flood (docs/node.md): 16 kept undeclared topics of 2 MB each,
the WebSocket outbox cap (16 MB) and the allocator's slack (measured: 0.5 MB and 14 MB). Without the caps the junk
topics alone kept their 100 messages (about 200 MB)."""


HALF_SENT = 500
"""Connections of the connection flood: beyond ``pfield serve``'s default cap of 200 open connections."""


@pytest.fixture(scope="module")
def meshes(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("meshes")


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory, meshes: Path) -> Iterator[tuple[str, int]]:
    log = tmp_path_factory.mktemp("serve") / "serve.log"
    with pfield_serve("--mesh-root", str(meshes), "--header-timeout", "2", log=log) as (url, process):
        wait_warm(url)  # kernels compiling on a cold cache grow the RSS by more than any flood may
        yield url, process.pid


def _flood(url: str, names: range, prefix: str) -> None:
    with httpx.Client(base_url=url, timeout=120, headers={"content-type": "application/json"}) as client:
        for i in names:
            answer = client.post(f"/topic/{prefix}/{i}", params={"type": "sensor_msgs/msg/LaserScan"}, content=SCAN)
            assert answer.status_code == 200, answer.text


def test_junk_topic_names_do_not_grow_memory_without_bound(served: tuple[str, int]) -> None:
    url, pid = served
    _flood(url, range(20), "warmup")  # the allocator's first arenas and the kept set are filled
    before = rss_bytes(pid)
    _flood(url, range(100), "junk")
    grown = rss_bytes(pid) - before
    assert grown < CEILING, f"RSS grew {grown / 1e6:.0f} MB under 100 junk topics"
    kept = [t["name"] for t in httpx.get(f"{url}/topics").json() if t["name"].startswith("/junk/")]
    assert len(kept) == 16


def _never_reading_websocket(url: str, path: str) -> socket.socket:
    """A WebSocket handshake on a raw socket (small receive buffer) that then never reads."""
    host, port = url.removeprefix("http://").split(":")
    raw = socket.create_connection((host, int(port)), timeout=30)
    raw.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    key = base64.b64encode(os.urandom(16)).decode()
    raw.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n".encode())
    assert raw.recv(12) == b"HTTP/1.1 101"
    return raw


def test_a_websocket_client_that_never_reads_costs_bounded_memory(served: tuple[str, int]) -> None:
    url, pid = served
    before = rss_bytes(pid)
    with _never_reading_websocket(url, "/ws/topic/slow/reader"):
        with httpx.Client(base_url=url, timeout=120, headers={"content-type": "application/json"}) as client:
            for _ in range(150):  # 45 MB of JSON for a client that reads none of it (its queue holds 16 MB)
                answer = client.post("/topic/slow/reader", params={"type": "sensor_msgs/msg/LaserScan"},
                                     content=SCAN)
                assert answer.status_code == 200
            health = client.get("/health").json()
        grown = rss_bytes(pid) - before
        assert grown < CEILING, f"RSS grew {grown / 1e6:.0f} MB with a WebSocket client that never reads"
        assert health["websocket"]["dropped_messages"] > 0


def test_a_huge_mesh_file_is_refused_without_reading_it(served: tuple[str, int], meshes: Path) -> None:
    url, pid = served
    huge = meshes / "huge.stl"
    with huge.open("wb") as sparse:  # 2 GB on paper, no disk used
        sparse.truncate(2_000_000_000)
    before = rss_bytes(pid)
    mesh = {"frame_id": "huge", "type": "Mesh", "group": "Static", "scale_x": 1.0, "scale_y": 1.0, "scale_z": 1.0,
            "mesh_resource": huge.as_uri()}
    answer = httpx.post(f"{url}/topic/pfield/obstacles", json={"obstacles": [mesh]}, timeout=60)
    assert answer.status_code == 400 and answer.json()["field"] == "obstacles[0].mesh_resource", answer.text
    assert "max_mesh_file_size" in answer.json()["error"]
    grown = rss_bytes(pid) - before
    assert grown < CEILING, f"RSS grew {grown / 1e6:.0f} MB for a refused 2 GB mesh"
    ids = httpx.post(f"{url}/srv/pfield/remove_obstacles", json={"frame_ids": []}).json()["remaining"]
    assert "huge" not in ids


def test_half_sent_requests_beyond_the_connection_cap_cost_bounded_memory(served: tuple[str, int]) -> None:
    url, pid = served
    host, port = url.removeprefix("http://").split(":")
    before = rss_bytes(pid)
    sockets = []
    try:
        for _ in range(HALF_SENT):
            raw = socket.create_connection((host, int(port)), timeout=30)
            raw.sendall(b"POST /srv/pfield/clear_obstacles HTTP/1.1\r\nHost: 127.0.0.1\r\n")  # never finished
            sockets.append(raw)
        grown = rss_bytes(pid) - before
        closed = 0
        for raw in sockets[:50]:  # beyond the cap each new one took the slot of the longest-waiting head
            raw.settimeout(10)
            closed += raw.recv(12) == b""
        assert closed == 50
    finally:
        for raw in sockets:
            raw.close()
    assert grown < CEILING, f"RSS grew {grown / 1e6:.0f} MB under {HALF_SENT} half-sent requests"
    deadline = time.monotonic() + 30  # the header timeout closed the ones still held
    while httpx.get(f"{url}/nodes", timeout=5).status_code != 200:
        assert time.monotonic() < deadline
        time.sleep(0.1)
