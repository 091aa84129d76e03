"""Field evaluation on the REFERENCE.md §2 scenes, next to the C++ original's per-call figures (§3).

Query pose (0.3, 0, 0.5) rotated 0.3 rad about +z, goal (0.6, 0.3, 0.3), the C++ library's default
parameters. For every scene:

* **wrench / twist from Python**: one ``PotentialField.wrench(pose)`` / ``twist(pose, previous, dt)`` call,
  including Python's call overhead (the C++ figures are in-process calls; the issue's target is the
  limited twist ≤ 10 µs with 10 spheres);
* **wrench / twist compiled**: per pose inside a compiled batch (what planners pay per evaluation);
* **RK4 step compiled**: one RK4 step in the core (four constrained twists), per step of 2000 from the same pose
  (the numba engine's row timed this: old and new time the same thing);
* **plan-loop step compiled**: one step of the task-space plan loop (the RK4 step, the clearance, the segment
  check and the advance), per step of a 2000-step plan (no numba row: its bench timed the RK4 step alone).

* **floor** (spheres_10 only): a call of the core with ``twist``'s arguments that does nothing, and a call that
  computes nothing but answers as ``twist`` does (a new :class:`~pfield.spatial.Twist` of two new read-only arrays,
  made in the core): what ``twist`` from Python cannot go below without changing its API or value types;
* **prepared limited twist**: :class:`pfield.field.PreparedTwist` (bound arrays, validated once, one compiled
  call per pose; target ≤ 1 µs with 10 spheres), previous twist and dt 0.01 as above.

The C++ column is the anchor program (``pf_anchor_bench``, :mod:`benchmarks._anchor`) run in the same
``make bench``: its limited twist with the previous twist and dt 0.01 for the twist rows; REFERENCE §3 when
the program is not built.

Plus batch evaluation of 100 000 poses against 10 spheres (target ≤ 50 ms).

Values are median wall times (the harness's rule). The machine is shared, so each note adds the median
CPU time of this process (``time.process_time``) over the same calls: wall time above CPU time means
the process was waiting for a core, not computing.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from benchmarks._anchor import cpp_figures, cpp_median
from benchmarks._common import BenchRow, auto_number, cpu_time, median_time
from pfield._core import field as core_field
from pfield.field import PotentialField, PreparedTwist
from pfield.geometry import Mesh, Obstacle, ResourceResolver
from pfield.planning.scenes import BENCH_GOAL, DEFAULT_PARAMS, EVALUATION_SCENES, evaluation_query, evaluation_scene
from pfield.spatial import Pose, Twist

SECTION = "field evaluation (µs per call)"
# C++ original (REFERENCE §3): wrench, limited twist, one RK4 step, µs.
CPP = {
    "empty": (0.03, 0.09, 1.0), "spheres_1": (0.09, 0.15, 1.35), "spheres_10": (0.64, 0.75, 3.6),
    "spheres_100": (6.4, 6.4, 25.7), "boxes_10": (0.78, 0.86, 4.0), "cylinders_10": (0.84, 0.93, 4.4),
    "ellipsoids_10": (0.79, 0.85, 4.1), "capsules_10": (0.78, 0.84, 3.7), "mesh_cube12": (3.4, 3.9, 16.8),
    "mesh_448": (8.2, 8.6, 41.0),
}
MESH_448 = Path(__file__).resolve().parents[1] / "tests" / "data" / "meshes" / "cylinder_448.stl"


def _plan_steps(field: PotentialField, count: int, pose: Pose) -> float:
    """``count`` steps of the task-space plan loop from ``pose`` (no tolerance is met, no stagnation window ends:
    every step is one RK4 step with its clearance and segment checks); returns the waypoints made."""
    start = np.concatenate([pose.position, pose.orientation])
    poses, twists, clearances = np.empty((count + 1, 7)), np.empty((count + 1, 6)), np.empty(count + 1)
    made, _, _ = field.compiled.plan(start, 0.01, 0.0, 0.0, count, count + 1, 0.0, np.zeros(1, np.uint8), poses, twists,
                                  clearances)
    return float(made)


def _rk4_steps(field: PotentialField, count: int, pose: Pose) -> float:
    """``count`` RK4 steps from ``pose`` with a zero previous twist (the numba engine's row: the planner's step
    without its bookkeeping); returns the sum of their mean v_x."""
    start = np.concatenate([pose.position, pose.orientation])
    return float(field.compiled.rk4_steps(start, np.zeros(6), 0.01, count))


def _mesh_scene(name: str, directory: Path) -> list[Obstacle]:
    import trimesh

    if name == "mesh_cube12":
        path = directory / "unit_cube.stl"
        trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(path)
    else:
        path = MESH_448
    mesh = Mesh(str(path), resolver=ResourceResolver(allowed_roots=(path.parent,)))
    return [Obstacle(name, mesh, Pose((1.0, 0.0, 0.5)))]


def _scene_rows(name: str, field: PotentialField, quick: bool) -> list[BenchRow]:
    pose = evaluation_query()
    previous = Twist((0.1, 0.0, 0.0), (0.0, 0.0, 0.1))
    repeat = 3 if quick else 9
    wrench_c, twist_c, rk4_c = CPP[name]
    poses = np.tile(pose.position, (1000, 1))
    quats = np.tile(pose.orientation, (1000, 1))

    def timed(fn: Callable[[], object], per: int = 1) -> tuple[float, str]:
        number = max(auto_number(fn, 0.02), 1)
        wall = median_time(fn, repeat=repeat, number=number) * 1e6 / per
        cpu = cpu_time(fn, repeat, max(number, 50 if per == 1 else 1)) * 1e6 / per
        return wall, f"CPU {cpu:.3g} µs"

    steps = 2000
    measured = cpp_figures(("field",))
    wrench_c, source = cpp_median(measured, ("field", name, "default", "wrench"), wrench_c)
    twist_c, _ = cpp_median(measured, ("field", name, "default", "limited_twist_prev_dt0.01"), twist_c)
    rk4_c, _ = cpp_median(measured, ("field", name, "default", "rk4_step"), rk4_c)
    prepared = PreparedTwist(field)
    prepared.pose[:3], prepared.pose[3:], prepared.previous[:] = pose.position, pose.orientation, previous.as_array()
    figures = [
        ("wrench from Python", lambda: field.wrench(pose), 1, wrench_c),
        ("limited twist from Python", lambda: field.twist(pose, previous, 0.01), 1, twist_c),
        ("prepared limited twist from Python", lambda: prepared.evaluate(0.01), 1, twist_c),
        ("wrench compiled", lambda: field.wrenches(poses, quats), 1000, wrench_c),
        ("twist compiled", lambda: field.twists(poses, quats), 1000, twist_c),
        ("one RK4 step compiled", lambda: _rk4_steps(field, steps, pose), steps, rk4_c),
        ("one plan-loop step compiled", lambda: _plan_steps(field, steps, pose), steps, rk4_c),
    ]
    if name == "spheres_10":  # the floor under "limited twist from Python" (docs/core.md, issue 32)
        core = field.compiled
        figures += [
            ("floor: a call with twist's arguments that does nothing",
             lambda: core.call_floor(pose, previous, 0.01), 1, twist_c),
            ("floor: a call answering as twist does (a new Twist)",
             lambda: core.call_floor_value(pose, previous, 0.01), 1, twist_c),
        ]
    rows = []
    for label, fn, per, reference in figures:
        value, note = timed(fn, per)
        target = None
        if name == "spheres_10" and label == "limited twist from Python":
            target, note = 10.0, note + "; target ≤ 10 µs with 10 spheres"
        if name == "spheres_10" and label.startswith("prepared"):
            target, note = 1.0, note + "; target ≤ 1 µs with 10 spheres"
        note += f"; {source}"
        rows.append(BenchRow(SECTION, f"{name}: {label}", value, "µs", reference, target=target, note=note))
    return rows


def _batch_rows(quick: bool) -> list[BenchRow]:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("spheres_10"))
    rng = np.random.default_rng(0)
    positions = rng.uniform((0.0, -0.3, 0.0), (1.0, 0.7, 1.0), (100_000, 3))
    orientations = np.tile(evaluation_query().orientation, (100_000, 1))
    repeat = 3 if quick else 7
    rows = []
    for label, fn in (("limited twists", lambda: field.twists(positions, orientations)),
                      ("wrenches", lambda: field.wrenches(positions, orientations))):
        wall = median_time(fn, repeat=repeat) * 1e3
        cpu = cpu_time(fn, repeat) * 1e3
        rows.append(BenchRow("field batch (ms)", f"100 000 {label} vs 10 spheres", wall, "ms",
                             target=5.0 if label == "limited twists" else 50.0,
                             note=f"CPU {cpu:.3g} ms; {os.cpu_count()} threads (the core's, from "
                                  f"{core_field.PARALLEL_FROM} poses)"))
    return rows


def run(quick: bool) -> list[BenchRow]:
    rows: list[BenchRow] = []
    with tempfile.TemporaryDirectory() as directory:
        scenes = [(name, evaluation_scene(name)) for name in EVALUATION_SCENES]
        scenes.append(("mesh_cube12", _mesh_scene("mesh_cube12", Path(directory))))
        if MESH_448.exists():
            scenes.append(("mesh_448", _mesh_scene("mesh_448", Path(directory))))
        for name, obstacles in scenes:
            rows += _scene_rows(name, PotentialField(DEFAULT_PARAMS, BENCH_GOAL, obstacles), quick)
    return rows + _batch_rows(quick)
