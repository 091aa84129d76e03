"""Run one ROS 2 test session inside the current (private) network namespace.

Usage: ``unshare -n -m python netns_session.py OUT_DIR --node NODE_ARGV... --client CLIENT_ARGV...``

Brings the loopback interface up and mounts a private, empty ``/dev/shm`` (so that what Fast DDS leaves
there is this session's alone and cannot touch other processes), starts the node process, runs the
client process to its end, then stops the node with SIGINT as a user's Ctrl-C would. Writes
``OUT_DIR/node.log``, ``client.log`` and ``session.json`` (both exit codes, whether the node had to be
killed, and the Fast DDS entries left in ``/dev/shm``). The client writes its own observations to
``OUT_DIR/results.json`` (``ROS2_TEST_OUT`` names the directory).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

CLIENT_TIMEOUT = 400.0
"""s: long enough for a slow ROS 2 start and a robot's first fit on a loaded machine, short of pytest's timeout."""
NODE_STOP_TIMEOUT = 20.0
DDS_SHM_PREFIXES = ("fastrtps_", "fast_datasharing", "sem.fastrtps_")
"""Fast DDS's segments and locks (LTTng's ``lttng-ust-wait-*`` files, made by every ROS process, are not)."""


def _split(argv: list[str]) -> tuple[Path, list[str], list[str]]:
    out_dir = Path(argv[0])
    node_at, client_at = argv.index("--node"), argv.index("--client")
    return out_dir, argv[node_at + 1:client_at], argv[client_at + 1:]


def _run_client(client_argv: list[str], node: subprocess.Popen[bytes], log: Path, env: dict[str, str]) -> int | None:
    """The client's exit code, or None if the node died first or the client timed out (client killed)."""
    with log.open("wb") as out:
        client = subprocess.Popen(client_argv, stdout=out, stderr=subprocess.STDOUT, env=env)
        deadline = time.monotonic() + CLIENT_TIMEOUT
        while client.poll() is None:
            if node.poll() is not None or time.monotonic() > deadline:
                client.kill()
                client.wait()
                return None
            time.sleep(0.05)
    return client.returncode


def main(argv: list[str]) -> None:
    out_dir, node_argv, client_argv = _split(argv)
    out_dir.mkdir(parents=True, exist_ok=True)
    subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64m", "tmpfs", "/dev/shm"], check=True)
    env = dict(os.environ, ROS2_TEST_OUT=str(out_dir))
    with (out_dir / "node.log").open("wb") as node_log:
        node = subprocess.Popen(node_argv, stdout=node_log, stderr=subprocess.STDOUT, env=env)
        client_code = _run_client(client_argv, node, out_dir / "client.log", env)
        node_died_early = node.poll() is not None
        killed = False
        if not node_died_early:
            node.send_signal(signal.SIGINT)
            try:
                node.wait(NODE_STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                node.kill()
                node.wait()
                killed = True
    session = {"client_returncode": client_code, "node_returncode": node.returncode,
               "node_died_early": node_died_early, "node_killed": killed,
               "shm_left": sorted(p.name for p in Path("/dev/shm").iterdir() if p.name.startswith(DDS_SHM_PREFIXES))}
    (out_dir / "session.json").write_text(json.dumps(session))


if __name__ == "__main__":
    main(sys.argv[1:])
