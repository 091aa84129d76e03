"""A real ``pfield serve`` process on a free 127.0.0.1 port, shared by the CLI tests (one start-up)."""

from __future__ import annotations

import shlex
from collections.abc import Iterator

import pytest
from pfield_node_server import MESH_PACKAGE, NodeServer

from seed_examples import OBSTACLE_COMMANDS
from serve_process import pfield_serve


@pytest.fixture(scope="session")
def node_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[NodeServer]:
    work = tmp_path_factory.mktemp("pfield_serve")
    log = work / "serve.log"
    with pfield_serve("--package-path", f"my_robot_description={MESH_PACKAGE}", "--csv-dir", str(work / "csv"),
                      log=log) as (url, process):
        yield NodeServer(url, process, work / "csv", log)


@pytest.fixture(scope="session")
def seeded(node_server: NodeServer) -> NodeServer:
    """The server after the seed's six obstacle examples, run verbatim through the CLI (``ros2`` → ``pfield``)."""
    for name, command in OBSTACLE_COMMANDS.items():
        argv = shlex.split(command)
        assert argv[0] == "ros2"
        done = node_server.cli(*argv[1:])
        assert done.returncode == 0, f"{name}: {done.stderr}"
    return node_server
