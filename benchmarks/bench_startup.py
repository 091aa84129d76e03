"""Start-up: ``pfield warmup`` on a new machine, and a new process's first whole-body plan.

Nothing compiles at run time (the kernels are the compiled core, built at install), and the built-in robots' link
models ship with pfield (:data:`pfield.robot._fit.SHIPPED_DIRECTORY`): a new machine with an empty cache
(``PFIELD_CACHE_DIR``, :func:`pfield.robot._fit.cache_root`) reads them and fits nothing.

* self-check, empty cache — ``pfield.warmup.check()`` (what ``pfield warmup`` runs) in a new process whose
  ``PFIELD_CACHE_DIR`` is an empty temporary directory (the shipped fits are read). CPU time of that process
  (user + system; it does not grow when other processes share the machine) and wall time.
* first plan — a new process with that cache filled: ``import pfield``, load the xArm7, build a field
  of five primitive obstacles (one of each shape) and plan the seed's whole-body example from the seed's
  start (the node's first ``plan_path``). Measured from spawning the interpreter to its exit; target 1.5 s.
  Once more with the seed's six obstacles, the mesh included (importing trimesh costs most of the difference),
  and once with an empty cache (a new machine's first plan: the xArm7's shipped fits read in that process).
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
"""The numba engine's name of this section, kept so that its first-plan rows pair with the new engine's."""
REPO = Path(__file__).resolve().parents[1]

CHECK = "from pfield import warmup; report = warmup.check(); assert report.ok, report.failures"
FIRST_PLAN = """
import tempfile
from pathlib import Path
from pfield.field import FieldConfig, PotentialField
from pfield.planning.scenes import SEED_GOAL, seed_obstacles
from pfield.robot import RobotModel
robot = RobotModel.builtin("xarm7")
obstacles = seed_obstacles(Path(tempfile.mkdtemp()) / "meshes") if WITH_MESH else [
    Obstacle(id, shape, Pose(position, orientation)) for id, shape, position, orientation in PRIMITIVES]
field = PotentialField(FieldConfig(), SEED_GOAL, obstacles)
path = field.plan_whole_body(robot, [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], 0.02, 0.01, 25000)
assert path.success, path.failure_reason
"""
PRIMITIVES = """
from pfield import Box, Capsule, Cylinder, Ellipsoid, Obstacle, Pose, Sphere
PRIMITIVES = [("ball", Sphere(radius=0.1), (0.4, 0.0, 0.1), (0, 0, 0, 1)),
              ("table", Box(length=0.6, width=1.2, height=0.05), (0.6, 0.0, -0.05), (0, 0, 0, 1)),
              ("pitcher", Cylinder(radius=0.05, height=0.2), (0.5, -0.3, 0.1), (0, 0, 0, 1)),
              ("egg", Ellipsoid(semi_x=0.05, semi_y=0.08, semi_z=0.12), (0.3, 0.35, 0.2), (0, 0, 0, 1)),
              ("pole", Capsule(radius=0.03, height=0.3), (0.35, -0.35, 0.3), (0, 0, 0, 1))]
"""


def _run(code: str, cache: Path) -> tuple[float, float]:
    """(wall s, CPU s) of ``python -c code`` with pfield's cache in ``cache``."""
    env = os.environ | {"PFIELD_CACHE_DIR": str(cache), "PYTHONPATH": str(REPO / "src")}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], env=env, check=True, cwd=REPO, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run(quick: bool) -> list[BenchRow]:
    repeats = 1 if quick else 3
    with tempfile.TemporaryDirectory(prefix="pfield-cache-") as directory:
        cache = Path(directory)
        check_wall, check_cpu = _run(CHECK, cache)
        primitives = [_run(f"WITH_MESH = False\n{PRIMITIVES}{FIRST_PLAN}", cache) for _ in range(repeats)]
        with_mesh = [_run(f"WITH_MESH = True\n{FIRST_PLAN}", cache) for _ in range(repeats)]
    cold = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory(prefix="pfield-cache-") as empty:
            cold.append(_run(f"WITH_MESH = False\n{PRIMITIVES}{FIRST_PLAN}", Path(empty)))
    first_wall = statistics.median(w for w, _ in primitives)
    first_cpu = statistics.median(c for _, c in primitives)
    mesh_cpu = statistics.median(c for _, c in with_mesh)
    cold_wall = statistics.median(w for w, _ in cold)
    return [
        BenchRow(SECTION, "pfield warmup self-check (empty cache), CPU", check_cpu, "s",
                 note="pfield.warmup.check() in a new process, empty user cache; user + system time"),
        BenchRow(SECTION, "pfield warmup self-check (empty cache), wall", check_wall, "s",
                 note="grows with the machine's load; the CPU row does not"),
        BenchRow(SECTION, "new process to first whole-body plan (warm cache), wall", first_wall, "s", target=1.5,
                 note="import + xArm7 + 5 primitive obstacles + seed whole-body plan; interpreter start to exit"),
        BenchRow(SECTION, "new process to first whole-body plan (warm cache), CPU", first_cpu, "s", target=1.5,
                 note=f"the same, CPU time; median of {repeats} processes (3, 1 with --quick)"),
        BenchRow(SECTION, "the same with the seed's mesh obstacle too, CPU", mesh_cpu, "s",
                 note="adds importing trimesh (+scipy) and loading the mesh"),
        BenchRow(SECTION, "new process to first whole-body plan (empty cache), wall", cold_wall, "s",
                 note="a new machine's first plan: the xArm7's shipped fits are read in that process"),
    ]
