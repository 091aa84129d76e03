"""Start a real ``pfield serve`` process on a free 127.0.0.1 port for the transport tests, and read its RSS."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from pfield_node_server import PFIELD, REPO, free_port

__all__ = ["PFIELD", "pfield_serve", "rss_bytes"]


@contextmanager
def pfield_serve(*options: str, log: Path) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """``pfield serve --port P *options``; yields its URL and process once ``GET /nodes`` answers."""
    port = free_port()
    with log.open("wb") as sink:
        process = subprocess.Popen([str(PFIELD), "serve", "--port", str(port), *options], stdout=sink,
                                   stderr=subprocess.STDOUT, cwd=REPO)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 240
    try:
        while True:
            if process.poll() is not None:
                raise RuntimeError(f"pfield serve exited: {log.read_text()}")
            try:
                if httpx.get(f"{url}/nodes", timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError(f"pfield serve did not start: {log.read_text()}")
            time.sleep(0.2)
        yield url, process
    finally:
        process.terminate()
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def rss_bytes(pid: int) -> int:
    """Resident set size of process ``pid`` (from /proc)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise RuntimeError(f"no VmRSS for {pid}")
