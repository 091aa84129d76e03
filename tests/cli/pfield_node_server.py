"""A real ``pfield serve`` process driven through the CLI (started by :func:`serve_process.pfield_serve`)."""

from __future__ import annotations

import os
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import yaml

from serve_process import MESH_PACKAGE, PFIELD, REPO, free_port

__all__ = ["MESH_PACKAGE", "PFIELD", "REPO", "NodeServer", "free_port"]


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
