"""Start-up: compiling every kernel with an empty numba cache, and a new process's first whole-body plan.

* cold compile — ``pfield.warmup.warm()`` in a new process whose ``NUMBA_CACHE_DIR`` is an empty temporary
  directory (so nothing is cached, whatever the source tree's own cache holds). Reported as CPU time of
  that process (user + system; it does not grow when other processes share the machine) and wall time.
* warm first plan — a new process with that cache filled: ``import pfield``, load the xArm7, build the
  seed's six-obstacle field and plan the seed's whole-body example (the node's first ``plan_path``).
  Measured from spawning the interpreter to its exit; the issue's target is 1.5 s.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks._common import BenchRow

SECTION = "start-up (numba compile and first plan)"
REPO = Path(__file__).resolve().parents[1]

COLD = "from pfield import warmup; report = warmup.warm(); assert not report.failures, report.failures"
FIRST_PLAN = """
import tempfile
from pathlib import Path
from pfield.field import FieldConfig, PotentialField
from pfield.planning.scenes import SEED_GOAL, seed_obstacles
from pfield.robot import RobotModel
robot = RobotModel.builtin("xarm7")
field = PotentialField(FieldConfig(), SEED_GOAL, seed_obstacles(Path(tempfile.mkdtemp()) / "meshes"))
path = field.plan_whole_body(robot, [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], 0.02, 0.01, 25000)
print(path.status.name, path.iterations)
"""


def _run(code: str, cache: Path) -> tuple[float, float]:
    """(wall s, CPU s) of ``python -c code`` with numba's cache in ``cache``."""
    env = os.environ | {"NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(REPO / "src")}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], env=env, check=True, cwd=REPO, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run(quick: bool) -> list[BenchRow]:
    with tempfile.TemporaryDirectory(prefix="pfield-numba-cache-") as directory:
        cache = Path(directory)
        cold_wall, cold_cpu = _run(COLD, cache)
        firsts = [_run(FIRST_PLAN, cache) for _ in range(1 if quick else 3)]
    first_wall = statistics.median(w for w, _ in firsts)
    first_cpu = statistics.median(c for _, c in firsts)
    return [
        BenchRow(SECTION, "cold compile of every kernel (empty cache), CPU", cold_cpu, "s",
                 note="pfield.warmup.warm() in a new process; user + system time"),
        BenchRow(SECTION, "cold compile of every kernel (empty cache), wall", cold_wall, "s",
                 note="grows with the machine's load; the CPU row does not"),
        BenchRow(SECTION, "new process to first whole-body plan (warm cache), wall", first_wall, "s", target=1.5,
                 note="import + xArm7 load + seed whole-body plan, interpreter start to exit"),
        BenchRow(SECTION, "new process to first whole-body plan (warm cache), CPU", first_cpu, "s", target=1.5,
                 note="median of 3 processes (1 with --quick)"),
    ]
