"""Helpers to drive a real ``pfield serve`` process from tests."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import yaml

PFIELD = Path(sys.executable).with_name("pfield")
REPO = Path(__file__).resolve().parents[2]
MESH_PACKAGE = REPO / "tests" / "data" / "my_robot_description"


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@dataclass
class NodeServer:
    url: str
    process: subprocess.Popen[bytes]
    csv_dir: Path
    log: Path

    def cli(self, *args: str) -> subprocess.CompletedProcess[str]:
        """Run ``pfield ARGS`` against this server (through PFIELD_URL, as a user would)."""
        env = os.environ | {"PFIELD_URL": self.url}
        return subprocess.run([str(PFIELD), *args], capture_output=True, text=True, env=env, timeout=300,
                              check=False)

    def call(self, service: str, type_name: str, text: str) -> dict[str, Any]:
        """``pfield service call`` that must succeed; the printed YAML response as a dict."""
        done = self.cli("service", "call", service, type_name, text)
        assert done.returncode == 0, done.stderr
        head, _, body = done.stdout.partition("\n")
        assert head == "response:"
        return dict(yaml.safe_load(body))

    def obstacle_ids(self) -> list[str]:
        """Ids the node holds (RemoveObstacles with no ids removes nothing and lists them)."""
        answer = httpx.post(f"{self.url}/srv/pfield/remove_obstacles", json={"frame_ids": []}).json()
        return list(answer["remaining"])
