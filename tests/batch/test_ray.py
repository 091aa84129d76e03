"""The Ray backend against a real local cluster (``ray start --head``) in a private network namespace:
the records equal the process backend's."""

from __future__ import annotations

import importlib.util
import json
import os
import secrets
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "transport"))
from ros2_helpers.support import missing, require_netns, run_session

from pfield.batch import TIMING_FIELDS

PORT = 6390
"""The head's port: inside the test's own network namespace, so no other cluster can clash with it."""


def _untimed(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in records]


@pytest.fixture(scope="module")
def session(problem_paths: list[Path], tmp_path_factory: pytest.TempPathFactory,
            request: pytest.FixtureRequest) -> dict[str, Any]:
    """One cluster for the module: the head runs until the client has planned on it and locally."""
    if importlib.util.find_spec("ray") is None:
        missing("ray is not installed: pip install -e '.[ray]'")
    require_netns()
    out = tmp_path_factory.mktemp("ray")
    # Ray's sockets live under its temp dir and a Unix socket path has at most 107 bytes: the session folder Ray
    # adds takes ~70 of them, so the dir must be short (a pytest-xdist worker's tmp_path is not)
    ray_temp = Path(tempfile.mkdtemp(prefix="ray", dir="/tmp"))
    request.addfinalizer(lambda: shutil.rmtree(ray_temp, ignore_errors=True))
    ray = str(Path(sys.executable).parent / "ray")
    head = [ray, "start", "--head", "--block", "--node-ip-address=127.0.0.1", f"--port={PORT}", "--num-cpus=2",
            "--include-dashboard=false", "--disable-usage-stats", f"--temp-dir={ray_temp}"]
    client = [sys.executable, str(Path(__file__).with_name("ray_client.py")), f"127.0.0.1:{PORT}",
              *map(str, problem_paths)]
    # token authentication with the test's own token, and a private HOME: nothing read from or left in ~/.ray
    home = out / "home"
    home.mkdir()
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0", PYTHONPATH=os.environ.get("PYTHONPATH", ""), HOME=str(home),
               RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(32))
    done = run_session(head, client, out, timeout=500.0, env=env)
    state = json.loads((out / "session.json").read_text())
    logs = "\n".join((out / name).read_text(errors="replace")[-3000:] for name in ("node.log", "client.log"))
    assert done.returncode == 0 and state["client_returncode"] == 0, f"{done.stderr}\n{logs}"
    return json.loads((out / "results.json").read_text())


def test_ray_gives_the_process_backends_records(session: dict[str, Any]) -> None:
    assert [(r["scene"], r["index"], r["status"]) for r in session["ray"]] == [
        ("box_panda", 1, "reached"), ("box_panda", 2, "reached"), ("box_panda", 3, "error"), ("scene", 0, "reached")]
    assert _untimed(session["ray"]) == _untimed(session["process"])
