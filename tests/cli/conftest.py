"""A real ``pfield serve`` process on a free 127.0.0.1 port, shared by the CLI tests (one start-up)."""

from __future__ import annotations

import shlex
import subprocess
import time
from collections.abc import Iterator

import httpx
import pytest
from pfield_node_server import MESH_PACKAGE, PFIELD, REPO, NodeServer, free_port

from seed_examples import OBSTACLE_COMMANDS


@pytest.fixture(scope="session")
def node_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[NodeServer]:
    work = tmp_path_factory.mktemp("pfield_serve")
    port = free_port()
    log = work / "serve.log"
    with log.open("wb") as sink:
        process = subprocess.Popen(
            [str(PFIELD), "serve", "--port", str(port), "--package-path",
             f"my_robot_description={MESH_PACKAGE}", "--csv-dir", str(work / "csv")],
            stdout=sink, stderr=subprocess.STDOUT, cwd=REPO)
    server = NodeServer(f"http://127.0.0.1:{port}", process, work / "csv", log)
    deadline = time.monotonic() + 240
    while True:
        if process.poll() is not None:
            pytest.fail(f"pfield serve exited: {log.read_text()}")
        try:
            if httpx.get(f"{server.url}/nodes", timeout=2).status_code == 200:
                break
        except httpx.TransportError:
            pass
        if time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"pfield serve did not start: {log.read_text()}")
        time.sleep(0.2)
    yield server
    process.terminate()
    try:
        process.wait(timeout=15)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


@pytest.fixture(scope="session")
def seeded(node_server: NodeServer) -> NodeServer:
    """The server after the seed's six obstacle examples, run verbatim through the CLI (``ros2`` → ``pfield``)."""
    for name, command in OBSTACLE_COMMANDS.items():
        argv = shlex.split(command)
        assert argv[0] == "ros2"
        done = node_server.cli(*argv[1:])
        assert done.returncode == 0, f"{name}: {done.stderr}"
    return node_server
