"""``pfield warmup`` (the self-check), ``pfield.warmup.ready()`` and ``GET /health``."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from pfield_node_server import REPO, NodeServer
from typer.testing import CliRunner

from pfield import warmup
from pfield.cli import app


def _python(code: str, cache: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, COLUMNS="250")  # rich wraps table cells at the terminal's width (80 in a pipe)
    if cache is not None:
        env["PFIELD_CACHE_DIR"] = str(cache)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=REPO,
                          timeout=600, check=False)


WARMUP_COMMAND = """
import sys
from pfield.cli import app
sys.argv = ["pfield", "warmup"]
try:
    app()
except SystemExit as exit:
    print("EXIT", exit.code)
print("NUMBA", "numba" in sys.modules)
"""


@pytest.mark.timeout(300)
def test_warmup_checks_each_step_and_reads_the_shipped_robot_fits(tmp_path: Path) -> None:
    """In a new process with an empty cache, ``pfield warmup`` passes every step and says what each checked; the
    built-in robots' link models are the fits shipped with pfield (``pfield/data/robot_fits``): nothing is fitted
    into the cache; numba is nowhere (the kernels are the compiled core)."""
    cache = tmp_path / "cache"
    first = _python(WARMUP_COMMAND, cache)
    assert first.returncode == 0, first.stderr
    assert "EXIT 0" in first.stdout or "EXIT None" in first.stdout, first.stdout + first.stderr
    assert "NUMBA False" in first.stdout
    text = " ".join(first.stderr.split())
    for step in warmup.STEPS:
        assert step.name in text
    assert f"self-check passed: {len(warmup.STEPS)}/{len(warmup.STEPS)} steps" in text
    assert "xarm7 8 links" in text and "panda 11 links" in text and "reached in" in text
    assert "Traceback" not in first.stderr
    assert not list((cache / "robot-fits").glob("*.npz"))  # read from the shipped fits, none fitted


def test_a_failing_step_exits_1_and_names_its_error(monkeypatch: pytest.MonkeyPatch) -> None:
    def fail(_: Path) -> str:
        raise RuntimeError("broken area")

    steps = (warmup.CheckStep("broken", fail), warmup.CheckStep("fine", lambda _: "all good"))
    monkeypatch.setattr(warmup, "STEPS", steps)
    result = CliRunner().invoke(app, ["warmup"], env={"COLUMNS": "200"})
    assert result.exit_code == 1
    output = " ".join(result.output.split())
    assert "RuntimeError: broken area" in output and "all good" in output
    assert "self-check FAILED: 1/2 steps" in output


def test_a_failing_step_is_reported_and_the_others_run() -> None:
    ran: list[str] = []

    def fail(_: Path) -> str:
        raise RuntimeError("broken area")

    def fine(_: Path) -> str:
        ran.append("fine")
        return "checked"

    steps = (warmup.CheckStep("broken", fail), warmup.CheckStep("fine", fine))
    progress: list[tuple[int, int, str]] = []
    report = warmup.check(lambda *args: progress.append(args), steps=steps)
    assert report.failures == {"broken": "RuntimeError: broken area"} and not report.ok
    assert report.checked == {"fine": "checked"}
    assert ran == ["fine"] and list(report.seconds) == ["broken", "fine"]
    assert progress == [(0, 2, "broken"), (1, 2, "fine"), (2, 2, "fine")]


READY = """
import threading
from pfield import warmup
assert not warmup.ready()
reports = []
thread = warmup.start_background(reports.append)
assert warmup.start_background() is thread and not thread.daemon
thread.join()
assert warmup.ready()
assert len(reports) == 1 and reports[0].ok, reports
assert list(reports[0].seconds) == [step.name for step in warmup.NODE_STEPS]
assert "robot link models" not in reports[0].seconds  # the node fits its own robot (fit_in_background)
print("OK", round(reports[0].total_seconds, 2))
"""


def test_ready_turns_true_once_the_background_check_has_run() -> None:
    done = _python(READY)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("OK")


EXIT_WHILE_CHECKING = """
import logging
from pfield import warmup
logging.basicConfig(level="INFO", format="%(message)s")
warmup.start_background()
warmup.fit_in_background(__import__("pfield.robot", fromlist=["RobotModel"]).RobotModel.builtin("panda"))
print("main thread ends", flush=True)
"""


def test_a_process_that_ends_while_the_check_runs_waits_for_it_and_exits_cleanly() -> None:
    # A daemon thread stopped at exit inside a core call that released the GIL aborts the process (exit 134,
    # "terminate called without an active exception", seen on `pfield ros2 node` stopped right after start).
    done = _python(EXIT_WHILE_CHECKING)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "main thread ends"
    assert "self-check passed" in done.stderr and "robot panda: link model ready" in done.stderr, done.stderr
    assert "terminate called" not in done.stderr


FAILED_FIT = """
import sys
from pfield import warmup
from pfield.robot import RobotModel
robot = RobotModel.from_urdf(sys.argv[1], end_effector="tool")
warmup.start_background().join()
warmup.fit_in_background(robot).join()
assert not warmup.ready()
print(warmup.start_up_errors())
"""

NO_VOLUME = (
    "<robot name='flat'><link name='base'/>"
    "<link name='l1'><collision><geometry><box size='0.1 0.1 0'/></geometry></collision></link><link name='tool'/>"
    "<joint name='j1' type='revolute'><parent link='base'/><child link='l1'/><axis xyz='0 0 1'/>"
    "<limit lower='-1' upper='1' velocity='1' effort='1'/></joint>"
    "<joint name='j2' type='fixed'><parent link='l1'/><child link='tool'/><origin xyz='0.1 0 0'/></joint></robot>")


def test_a_robot_whose_link_model_cannot_be_fitted_is_never_ready_and_says_which_link(tmp_path: Path) -> None:
    """A node whose robot cannot be fitted cannot plan: it used to report ready all the same (GET /health reads
    these two)."""
    urdf = tmp_path / "flat.urdf"
    urdf.write_text(NO_VOLUME)
    done = _python(FAILED_FIT.replace("sys.argv[1]", repr(str(urdf))), tmp_path / "cache")
    assert done.returncode == 0, done.stderr
    assert "fitting the link model of robot flat failed: link l1='box': its collision geometry cannot be fitted" \
        in done.stdout, done.stdout
    assert "a shape of no volume" in done.stdout


def test_health_says_ready_once_the_node_has_checked_itself(node_server: NodeServer) -> None:
    deadline = time.monotonic() + 300
    health = httpx.get(f"{node_server.url}/health").json()
    assert health["ready"] in (True, False)
    while not health["ready"]:
        assert time.monotonic() < deadline, "the node never became ready"
        time.sleep(0.2)
        health = httpx.get(f"{node_server.url}/health").json()
    assert "self-check passed" in node_server.log.read_text()
