"""Start a real ``pfield serve`` process on a free 127.0.0.1 port for tests, and read its memory.

``with pfield_serve("--map", path, log=tmp / "serve.log") as (url, process): ...`` starts this tree's
``pfield serve --port P ARGS`` (its output in ``log``), yields once ``GET /nodes`` answers, and stops the
process afterwards (``stop`` signal, then kill after 15 s).
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx

__all__ = ["MESH_PACKAGE", "PFIELD", "REPO", "SRC", "free_port", "pfield_serve", "rss_bytes"]

PFIELD = Path(sys.executable).with_name("pfield")
REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src"
MESH_PACKAGE = REPO / "tests" / "data" / "my_robot_description"
START_TIMEOUT_S = 120.0
"""s a server may take to answer (generous: it answers within seconds, on a loaded 2-core machine too)."""


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@contextmanager
def pfield_serve(*options: str, log: Path, cwd: Path = REPO, stop: int = signal.SIGTERM,
                 port: int | None = None) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """``pfield serve --port P *options`` of this tree; yields its URL and process once it answers."""
    port = free_port() if port is None else port
    env = os.environ | {"PYTHONPATH": os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")]))}
    with log.open("wb") as sink:
        process = subprocess.Popen([str(PFIELD), "serve", "--port", str(port), *options], stdout=sink,
                                   stderr=subprocess.STDOUT, cwd=cwd, env=env)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + START_TIMEOUT_S
    try:
        while True:
            if process.poll() is not None:
                raise RuntimeError(f"pfield serve exited: {log.read_text()}")
            try:
                if httpx.get(f"{url}/nodes", timeout=2, trust_env=False).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError(f"pfield serve did not start: {log.read_text()}")
            time.sleep(0.2)
        yield url, process
    finally:
        if process.poll() is None:
            process.send_signal(stop)
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def wait_warm(url: str, timeout: float = 1800.0) -> None:
    """Wait until the node at ``url`` has finished its warm-up (``GET /health`` ready): memory read before then
    would count the kernels still compiling in its background thread."""
    deadline = time.monotonic() + timeout
    while not httpx.get(f"{url}/health", timeout=10, trust_env=False).json()["ready"]:
        if time.monotonic() > deadline:
            raise RuntimeError(f"{url} did not finish its warm-up in {timeout:.0f} s")
        time.sleep(0.5)


def rss_bytes(pid: int) -> int:
    """Resident set size of process ``pid`` (from /proc)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise RuntimeError(f"no VmRSS for {pid}")
