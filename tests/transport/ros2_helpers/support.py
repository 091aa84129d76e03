"""Availability of the ROS 2 pieces the tests need; missing pieces fail in CI and skip elsewhere.

``make test`` installs the ``ros2`` extra and builds ``potential_fields_interfaces`` (``make
ros2-interfaces``); a private network namespace (``unshare -n``) keeps DDS traffic off the machine's
networks. When a piece is missing the test says which one and how to get it: in CI (``CI`` set) that is
a failure, so the ROS 2 tests can never pass by not running; elsewhere the test is skipped.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

HELPERS = Path(__file__).resolve().parent
REPO = HELPERS.parents[2]
DOMAIN_ID = "57"
"""Fixed ROS_DOMAIN_ID of the tests (inside their own network namespace, so no clash is possible)."""


def missing(reason: str) -> None:
    """Fail in CI, skip elsewhere, with ``reason``."""
    if os.environ.get("CI"):
        pytest.fail(f"{reason} (CI is set, so this is a failure, not a skip)")
    pytest.skip(reason, allow_module_level=True)


def require_ros2_python() -> None:
    """rclpy and the built interface package are importable in this interpreter."""
    if importlib.util.find_spec("rclpy") is None:
        missing("rclpy is not installed: pip install -e '.[ros2]'")
    if importlib.util.find_spec("potential_fields_interfaces") is None:
        missing("potential_fields_interfaces is not built: run `make ros2-interfaces`")


def require_netns() -> None:
    """A private network and mount namespace can be created (``unshare -n -m``: root or user namespaces)."""
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        missing("`unshare`/`ip` not found: the ROS 2 tests need a private network namespace")
    probe = subprocess.run(["unshare", "-n", "-m", "sh", "-c", "ip link set lo up && mount -t tmpfs tmpfs /dev/shm"],
                           capture_output=True, text=True, check=False, timeout=30)
    if probe.returncode != 0:
        missing(f"`unshare -n -m` is not available here ({probe.stderr.strip() or probe.returncode}): "
                "the ROS 2 tests need a private network namespace (root or user namespaces)")


def ros_environment() -> dict[str, str]:
    """Environment of every rclpy process of the tests: localhost discovery, fixed domain, no shared memory."""
    env = dict(os.environ)
    env.update({
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_DOMAIN_ID": DOMAIN_ID,
        "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4",
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
        "PYTHONUNBUFFERED": "1",
    })
    return env


def run_session(node_argv: list[str], client_argv: list[str], out_dir: Path, timeout: float = 120.0,
                env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``netns_session.py`` in new network and mount namespaces: the node (a ROS 2 node, a Ray head …),
    then the client, then SIGINT. ``env`` defaults to :func:`ros_environment`."""
    command = ["unshare", "-n", "-m", sys.executable, str(HELPERS / "netns_session.py"), str(out_dir),
               "--node", *node_argv, "--client", *client_argv]
    return subprocess.run(command, env=env if env is not None else ros_environment(), capture_output=True, text=True,
                          timeout=timeout, check=False, cwd=REPO)


def run_scenario(node_argv: list[str], client_argv: list[str], out_dir: Path, timeout: float = 600.0) -> dict[str, Any]:
    """:func:`run_session`, then what its client wrote: ``{"results": results.json, "session": session.json,
    "logs": {"node.log": …, "client.log": …}}``. Fails the test, with the logs, when the session failed, the client
    wrote no results or its results carry an ``"error"``."""
    process = run_session(node_argv, client_argv, out_dir, timeout=timeout)
    assert process.returncode == 0, process.stderr
    logs = {name: (out_dir / name).read_text() for name in ("node.log", "client.log")}
    assert (out_dir / "results.json").exists(), logs
    results = json.loads((out_dir / "results.json").read_text())
    assert "error" not in results, str(results["error"]) + "\n--- node log ---\n" + logs["node.log"]
    return {"results": results, "session": json.loads((out_dir / "session.json").read_text()), "logs": logs}
