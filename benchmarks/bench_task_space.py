"""Task-space planning on the REFERENCE.md §2 scenes, next to the C++ original's figures (§3).

Start (0.3, 0, 0.5), goal (0.6, 0.3, 0.3), identity orientations, dt 0.01, tolerance 0.01 m, at most
30000 iterations; 0, 5 or 20 spheres (r 0.02 m) along the start–goal line with 5 cm lateral offset;
parameters "default" (the C++ library's) and "rosYaml" (pfield's defaults). Median wall time of the
whole ``PotentialField.plan`` call after warm-up, the iteration count and whether the goal was reached.
Also the seed's task-space example through its six obstacles (no C++ figure). Notes add the median
CPU time of this process (the machine is shared; wall time includes waiting for a core).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from benchmarks._common import BenchRow, cpu_time, median_time
from pfield.field import FieldConfig, PotentialField
from pfield.planning import PlannedPath
from pfield.planning.scenes import (
    BENCH_GOAL,
    BENCH_START,
    DEFAULT_PARAMS,
    SEED_GOAL,
    SEED_PLAN,
    SEED_START,
    seed_obstacles,
    sphere_line_scene,
)

SECTION = "task-space planning (ms per plan)"
# C++ original (REFERENCE §3): ms, iterations, outcome.
CPP = {
    (0, "default"): (0.27, 398, "reached"), (5, "default"): (71.0, 30000, "stuck 8.6 cm away"),
    (20, "default"): (205.0, 30000, "stuck 14 cm away"), (0, "rosYaml"): (1.57, 1839, "reached"),
    (5, "rosYaml"): (7.0, 3052, "reached"), (20, "rosYaml"): (201.0, 30000, "stuck 1.6 cm away"),
}
PARAMS = {"default": DEFAULT_PARAMS, "rosYaml": FieldConfig()}


def _outcome(field: PotentialField, path: PlannedPath) -> str:
    distance = float(np.linalg.norm(path.positions[-1] - field.goal.position))
    state = "reached" if path.success else path.failure_reason.split(":")[0]
    return f"{path.iterations} iterations, {state} ({distance * 100:.2f} cm from goal, min clearance " \
           f"{path.min_clearance * 100:.2f} cm)"


def run(quick: bool) -> list[BenchRow]:
    rows = []
    repeat = 3 if quick else 9
    for params_name, config in PARAMS.items():
        for count in (0, 5, 20):
            field = PotentialField(config, BENCH_GOAL, sphere_line_scene(count))
            seconds = median_time(lambda field=field: field.plan(BENCH_START), repeat=repeat)  # type: ignore[misc]
            cpu = cpu_time(lambda field=field: field.plan(BENCH_START), repeat)  # type: ignore[misc]
            path = field.plan(BENCH_START)
            cpp_ms, cpp_iterations, cpp_outcome = CPP[(count, params_name)]
            target = cpp_ms if (count, params_name) in ((0, "default"), (5, "rosYaml")) else None
            rows.append(BenchRow(
                SECTION, f"{count} spheres / {params_name}", seconds * 1e3, "ms", cpp_ms, target=target,
                note=f"CPU {cpu * 1e3:.3g} ms; {_outcome(field, path)}; C++: {cpp_iterations} iterations, "
                     f"{cpp_outcome}",
            ))
    with tempfile.TemporaryDirectory() as directory:
        field = PotentialField(FieldConfig(), SEED_GOAL, seed_obstacles(Path(directory)))
        seconds = median_time(lambda: field.plan(SEED_START, **SEED_PLAN), repeat=repeat)
        cpu = cpu_time(lambda: field.plan(SEED_START, **SEED_PLAN), repeat)
        path = field.plan(SEED_START, **SEED_PLAN)
        rows.append(BenchRow(SECTION, "seed example, six seed obstacles / rosYaml, dt 0.02", seconds * 1e3, "ms",
                             note=f"CPU {cpu * 1e3:.3g} ms; {_outcome(field, path)}"))
    return rows
