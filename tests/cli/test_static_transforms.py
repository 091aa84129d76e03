"""``pfield serve --static-transform``: a real server accepts messages in the configured frame."""

from __future__ import annotations

import math
import subprocess
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import yaml
from pfield_node_server import PFIELD, REPO, NodeServer, free_port

from serve_process import pfield_serve

S = math.sqrt(0.5)
OBSTACLES = "potential_fields_interfaces/msg/ObstacleArray"
BALL = "{frame_id: 'ball', type: 'Sphere', group: 'Static', pose: {position: {x: 0.4, y: 0.0, z: 0.1}, " \
       "orientation: {w: 1.0}}, radius: 0.1}"


@pytest.fixture(scope="module")
def camera_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[NodeServer]:
    work = tmp_path_factory.mktemp("pfield_frames")
    log = work / "serve.log"
    with pfield_serve("--static-transform", f"camera=1,2,3,0,0,{S!r},{S!r}", log=log) as (url, process):
        yield NodeServer(url, process, work, log)


def test_obstacle_in_configured_frame_lands_in_world(camera_server: NodeServer) -> None:
    done = camera_server.cli("topic", "pub", "--once", "/pfield/obstacles", OBSTACLES,
                             f"{{header: {{frame_id: camera}}, obstacles: [{BALL}]}}")
    assert done.returncode == 0, done.stderr
    markers = httpx.get(f"{camera_server.url}/topic/pfield/markers").json()["markers"]
    ball = next(m for m in markers if m["ns"] == "obstacles")
    position, orientation = ball["pose"]["position"], ball["pose"]["orientation"]
    assert (position["x"], position["y"], position["z"]) == pytest.approx((1.0, 2.4, 3.1), abs=1e-9)
    assert (orientation["z"], orientation["w"]) == pytest.approx((S, S), abs=1e-9)
    assert ball["header"]["frame_id"] == "world"


def test_parameter_set_and_unknown_frame_through_the_cli(camera_server: NodeServer) -> None:
    got = yaml.safe_load(camera_server.cli("param", "get", "/pfield_manager", "static_transforms").stdout)
    assert got == {"camera": {"translation": [1.0, 2.0, 3.0], "rotation": pytest.approx([0.0, 0.0, S, S])}}
    bad = camera_server.cli("param", "set", "/pfield_manager", "static_transforms",
                            "{camera: {translation: [0, 0, 0], rotation: [0, 0, 0, 0]}}")
    assert bad.returncode != 0 and "static_transforms.camera.rotation" in bad.stderr
    refused = camera_server.cli("topic", "pub", "--once", "/pfield/obstacles", OBSTACLES,
                                f"{{header: {{frame_id: lidar}}, obstacles: [{BALL}]}}")
    assert refused.returncode != 0 and "static_transforms" in refused.stderr
    assert camera_server.cli("param", "set", "/pfield_manager", "static_transforms",
                             "{lidar: {translation: [0, 0, 1]}}").returncode == 0
    accepted = camera_server.cli("topic", "pub", "--once", "/pfield/obstacles", OBSTACLES,
                                 f"{{header: {{frame_id: lidar}}, obstacles: [{BALL}]}}")
    assert accepted.returncode == 0, accepted.stderr


def test_bad_option_is_refused_before_serving(tmp_path: Path) -> None:
    done = subprocess.run([str(PFIELD), "serve", "--port", str(free_port()), "--static-transform", "camera=1,2"],
                          capture_output=True, text=True, timeout=120, check=False, cwd=REPO)
    assert done.returncode == 2 and "--static-transform" in done.stderr
