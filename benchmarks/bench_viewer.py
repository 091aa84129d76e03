"""3D viewer: the node's ``compute_autonomy_vector`` round trip with and without a viewer following it.

A real ``pfield serve`` runs in its own process on 127.0.0.1 with the seed's five obstacles and goal; a
keep-alive client posts the seed's task-space request (as in ``bench_http``). Rounds alternate: the round
trip p50 without a viewer, then with ``pfield view`` (its own process) following the node; in the last
round also with a headless chromium showing the page (when installed). The figure is the median of the
rounds' p50(with) / p50(without). Target: ≤ 1.10 (the viewer costs the node at most
10 %). The page row is informative: software WebGL competes with the node for the CPU, which a browser on
another machine or with a GPU does not.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import numpy as np

from benchmarks._common import BenchRow
from benchmarks.bench_http import GOAL, OBSTACLES, QUERY

SECTION = "3D viewer"
ROOT = Path(__file__).resolve().parents[1]


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _pfield(*args: str) -> subprocess.Popen[bytes]:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    return subprocess.Popen([sys.executable, "-c", "from pfield.cli import app; app()", *args], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _wait_http(url: str, process: subprocess.Popen[bytes], timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"process for {url} exited")
        try:
            httpx.get(url, trust_env=False, timeout=2.0)
            return
        except httpx.HTTPError:
            time.sleep(0.2)
    raise RuntimeError(f"{url} did not answer")


@contextmanager
def _running(process: subprocess.Popen[bytes]) -> Iterator[subprocess.Popen[bytes]]:
    try:
        yield process
    finally:
        process.terminate()
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()


def _p50(client: httpx.Client, calls: int) -> float:
    for _ in range(50):
        client.post("/srv/pfield/compute_autonomy_vector", json=QUERY).raise_for_status()
    samples = np.empty(calls)
    for i in range(calls):
        start = time.perf_counter()
        client.post("/srv/pfield/compute_autonomy_vector", json=QUERY).raise_for_status()
        samples[i] = time.perf_counter() - start
    return float(np.percentile(samples, 50)) * 1e3


@contextmanager
def _page(url: str) -> Iterator[bool]:
    """A headless chromium showing ``url`` (True), or nothing when chromium is not installed (False)."""
    if shutil.which("chromium") is None:
        yield False
        return
    sys.path.insert(0, str(ROOT / "tests" / "viz"))
    from _chromium import Browser

    browser = Browser()
    try:
        browser.open(url)
        time.sleep(10.0)  # let the page load and draw the scene
        yield True
    finally:
        browser.close()


def run(quick: bool) -> list[BenchRow]:
    calls, rounds = (300, 2) if quick else (1000, 4)
    port = _free_port()
    url = f"http://127.0.0.1:{port}"
    without, with_viewer, ratios = [], [], []
    with _running(_pfield("serve", "--port", str(port), "--log-level", "warning")) as node:
        _wait_http(f"{url}/nodes", node)
        with httpx.Client(base_url=url, timeout=300.0, trust_env=False) as client:
            client.post("/topic/pfield/obstacles", json=OBSTACLES).raise_for_status()
            client.post("/topic/pfield/planning_goal_pose", json=GOAL).raise_for_status()
            # Alternate rounds without and with a viewer, so that load from elsewhere on the machine
            # falls on both alike; each round's ratio compares neighbours in time.
            for index in range(rounds):
                without.append(_p50(client, calls))
                view_port = _free_port()
                viewer = _pfield("view", "--url", url, "--port", str(view_port))
                with _running(viewer):
                    _wait_http(f"http://127.0.0.1:{view_port}", viewer)
                    time.sleep(5.0)  # the viewer has connected and drawn the node's state
                    with_viewer.append(_p50(client, calls))
                    if index == rounds - 1:
                        with _page(f"http://127.0.0.1:{view_port}") as shown:
                            with_page = _p50(client, calls) if shown else float("nan")
                ratios.append(with_viewer[-1] / without[-1])
    rows = [
        BenchRow(SECTION, "compute_autonomy_vector p50 without viewer", float(np.median(without)), "ms",
                 note=f"{rounds} rounds of {calls} calls: " + ", ".join(f"{v:.2f}" for v in without)),
        BenchRow(SECTION, "compute_autonomy_vector p50 with viewer", float(np.median(with_viewer)), "ms",
                 note="pfield view (own process) following the node: " + ", ".join(f"{v:.2f}" for v in with_viewer)),
        BenchRow(SECTION, "round trip with / without viewer", float(np.median(ratios)), "ratio", target=1.10,
                 note="median of the rounds' ratios: " + ", ".join(f"{r:.2f}" for r in ratios)),
    ]
    if shown:
        rows.append(BenchRow(SECTION, "round trip with viewer and a page open / without",
                             with_page / float(np.median(without)), "ratio",
                             note="headless chromium drawing WebGL in software on the same 2 cores"))
    return rows
