"""``pfield warmup``, the first-compile notice, ``pfield.warmup.ready()`` and ``GET /health``."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from pfield_node_server import REPO, NodeServer

from pfield import warmup
from pfield.robot._fit import cache_directory


def _python(code: str, cache: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=REPO,
                          timeout=3000, check=False)


WARMUP_COMMAND = """
import sys
from pfield.cli import app
from pfield import warmup
sys.argv = ["pfield", "warmup"]
try:
    app()
except SystemExit as exit:
    print("EXIT", exit.code)
kernels = warmup.kernels()
# what numba's on-disk cache holds for each kernel (its index file), whichever process compiled it
held = {name: len(kernel._cache._cache_file._load_index()) for name, kernel in kernels.items()}
# the compiled core's numba twins, which no plan calls any more (tests/planning/test_core_whole_body.py holds the
# core equal to them until they go)
twins = {"pfield.planning._whole_body_loop.plan_loop", "pfield.planning._whole_body_loop.autonomy_step",
         "pfield.planning._whole_body_kernel.joint_velocity_step", "pfield.planning._whole_body_flat.flat_step",
         "pfield.planning._whole_body_flat.bound_step"}
held = {name: count for name, count in held.items() if name not in twins}
print("KERNELS", len(kernels))
print("UNCOMPILED", sorted(name for name, count in held.items() if count == 0))
print("SPECIALISATIONS", sorted((count, name) for name, count in held.items() if count > 1))
"""


def _empty_default_cache() -> Path | None:
    """numba's cache directory for pfield's kernels when it holds no kernel and no robot fit yet (a fresh
    checkout), else None. Without ``NUMBA_CACHE_DIR`` numba writes each module's cache into the ``__pycache__``
    beside it, and the fitted robot models go next to them (:func:`pfield.robot._fit.cache_directory`)."""
    root = os.environ.get("NUMBA_CACHE_DIR")
    where = Path(root) if root else Path(warmup.__file__).parent
    fits = cache_directory()
    if not os.access(where, os.W_OK) or any(where.rglob("*.nbi")) or (fits is not None and fits.exists()
                                                                      and any(fits.iterdir())):
        return None
    return where


@pytest.mark.slow
@pytest.mark.timeout(1800)  # a cold compile: 5-10 minutes of CPU
def test_warmup_command_compiles_every_kernel_with_progress(tmp_path: Path) -> None:
    """With an empty cache, ``pfield warmup`` compiles every kernel (the first area in its own process, the
    others in two processes side by side on a machine with two or more cores), reports each area and the total
    time, and afterwards numba's cache holds every kernel of pfield, each for one signature.

    The test runs first (tests/conftest.py): when numba's own cache is still empty, the compile goes there and
    the rest of the run loads the kernels; otherwise into an empty directory of its own."""
    default = _empty_default_cache()
    cache = None if default is not None else tmp_path / "numba-cache"
    assert not any((default or tmp_path).rglob("*.nbi"))
    done = _python(WARMUP_COMMAND, cache)
    if default is not None:  # it filled the cache the rest of the run loads from
        assert any(default.rglob("*.nbi"))
    assert done.returncode == 0, done.stderr
    lines = dict(line.split(" ", 1) for line in done.stdout.splitlines() if " " in line)
    assert lines["EXIT"] in ("0", "None")
    assert int(lines["KERNELS"]) > 80
    assert lines["UNCOMPILED"] == "[]"
    assert "compiling kernels" in done.stderr and f"{len(warmup.STEPS)}/{len(warmup.STEPS)}" in done.stderr
    assert "warm-up done in" in done.stderr and "Traceback" not in done.stderr
    assert "compiling numba kernels (first use" not in done.stderr  # warmup reports progress itself
    side_by_side = "2 processes compiled side by side" in " ".join(done.stderr.split())  # rich wraps lines
    assert side_by_side == ((os.cpu_count() or 1) >= 2)
    # each kernel compiles once: every caller passes the same array types (see docs/node.md)
    assert lines["SPECIALISATIONS"] == "[]", lines["SPECIALISATIONS"]


PLANS_WITH_AND_WITHOUT_A_TOKEN = """
import numpy as np
from pfield import FieldConfig, PotentialField, Pose
from pfield.planning import CancelToken, PlanOptions
from pfield.planning import _whole_body_kernel, _whole_body_loop
from pfield.robot import RobotModel
xarm = RobotModel.builtin("xarm7")
q0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
field = PotentialField(FieldConfig(), xarm.forward_kinematics(q0 + 0.05))
for options in (None, PlanOptions(cancel=CancelToken())):
    field.plan(Pose((0.2, 0.0, 0.2)), max_iterations=5, options=options)
    field.plan_whole_body(xarm, q0, max_iterations=5, options=options)
print("LOOPS", [len(k.signatures) for k in (_whole_body_loop.plan_loop, _whole_body_kernel.joint_velocity_step)])
"""


def test_a_plan_with_or_without_a_cancel_token_compiles_no_planning_loop() -> None:
    """The node cancels plans (a :class:`CancelToken` per request), ``pfield warmup`` plans without one: both
    planners' loops are the compiled core's (C++), so neither plan compiles the numba loops they replaced."""
    done = _python(PLANS_WITH_AND_WITHOUT_A_TOKEN)
    assert done.returncode == 0, done.stderr
    assert "LOOPS [0, 0]" in done.stdout, done.stdout


def test_first_compile_says_so_once(tmp_path: Path) -> None:
    code = ("import numpy as np; from pfield._spatial_kernels import matrix_to_quat; "
            "matrix_to_quat(np.eye(3)); matrix_to_quat(np.eye(3))")
    cache = tmp_path / "numba-cache"
    first = _python(code, cache)
    assert first.returncode == 0, first.stderr
    assert first.stderr.count("compiling numba kernels (first use of pfield._spatial_kernels.matrix_to_quat") == 1
    assert "`pfield warmup` compiles them ahead of time" in first.stderr
    cached = _python(code, cache)
    assert cached.returncode == 0 and "compiling" not in cached.stderr


READY = """
import threading
from pfield import warmup
assert not warmup.ready()
thread = warmup.start_background()
assert warmup.start_background() is thread and thread.daemon
reports = []
others = [threading.Thread(target=lambda: reports.append(warmup.warm())) for _ in range(2)]
for other in others:
    other.start()
thread.join()
for other in others:
    other.join()
assert warmup.ready()
assert reports[0] is reports[1] is warmup.warm(), "warm() runs once per process"
assert not reports[0].failures, reports[0].failures
assert list(reports[0].seconds) == [step.name for step in warmup.STEPS]
print("OK")
"""


def test_ready_turns_true_once_and_warm_runs_once() -> None:
    done = _python(READY)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "OK"


def test_a_failing_step_is_reported_and_the_others_run() -> None:
    ran: list[str] = []

    def fail(_: Path) -> None:
        raise RuntimeError("broken area")

    steps = (warmup.WarmupStep("broken", fail), warmup.WarmupStep("fine", lambda _: ran.append("fine")))
    progress: list[tuple[int, int, str]] = []
    report = warmup.warm(lambda *args: progress.append(args), steps=steps)
    assert report.failures == {"broken": "RuntimeError: broken area"}
    assert ran == ["fine"] and list(report.seconds) == ["broken", "fine"]
    assert progress == [(0, 2, "broken"), (1, 2, "fine"), (2, 2, "fine")]


def test_health_says_ready_once_the_node_is_warm(node_server: NodeServer) -> None:
    deadline = time.monotonic() + 1200
    health = httpx.get(f"{node_server.url}/health").json()
    assert health["ready"] in (True, False)
    while not health["ready"]:
        assert time.monotonic() < deadline, "the node never became ready"
        time.sleep(0.5)
        health = httpx.get(f"{node_server.url}/health").json()
    assert "kernels ready" in node_server.log.read_text()
