"""Mobile base: the 2D vector field against a 720-beam scan, field images, controller and simulation.

Targets (issue 5): one field evaluation against a 720-beam scan ≤ 20 µs; a 200×200 field image with 720
obstacle points ≤ 100 ms. The C++ original has no 2D controller, so there are no reference figures.
"""

from __future__ import annotations

import math

import numpy as np

from benchmarks._common import BenchRow, auto_number, median_time
from pfield.mobile import VectorFieldParams, potential, velocity
from pfield.mobile.controller import BaseController
from pfield.mobile.field2d import velocity_at
from pfield.mobile.scan import scan_ranges_obstacles
from pfield.mobile.scenarios import BUILTIN_SCENARIOS
from pfield.mobile.sim import simulate

SECTION = "mobile"
BEAMS = 720


def _scan_ranges() -> np.ndarray:
    """A 720-beam scan in a 6 m × 4 m room with the robot off-centre (ranges to the walls)."""
    angles = -math.pi + np.arange(BEAMS) * (2 * math.pi / BEAMS)
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (4.0 - 0.0) / c, np.where(c < 0, -2.0 / c, np.inf))
        ty = np.where(s > 0, 1.5 / s, np.where(s < 0, -2.5 / s, np.inf))
    return np.minimum(tx, ty)


def _timed(fn, quick: bool) -> float:  # type: ignore[no-untyped-def]
    return median_time(fn, repeat=3 if quick else 9, number=auto_number(fn, 0.02 if quick else 0.1))


def _scan_rows(quick: bool) -> list[BenchRow]:
    params = VectorFieldParams()
    ranges = _scan_ranges()
    inc = 2 * math.pi / BEAMS
    every_beam = scan_ranges_obstacles(ranges, -math.pi, inc, 0.05, 10.0, weighting="sum")
    goal = np.array([3.0, 1.0])
    columns = (np.ascontiguousarray(every_beam.points[:, 0]), np.ascontiguousarray(every_beam.points[:, 1]))
    args = (goal, True, *columns, every_beam.weights, params.core_field, params.core_limits)
    kernel = _timed(lambda: velocity_at(0.1, -0.2, *args), quick)

    sector = scan_ranges_obstacles(ranges, -math.pi, inc, 0.05, 10.0)
    sector_args = (goal, True, np.ascontiguousarray(sector.points[:, 0]), np.ascontiguousarray(sector.points[:, 1]),
                   sector.weights, *args[5:])
    sector_kernel = _timed(lambda: velocity_at(0.1, -0.2, *sector_args), quick)
    conversion = _timed(lambda: scan_ranges_obstacles(ranges, -math.pi, inc, 0.05, 10.0), quick)
    controller = BaseController(params)
    controller.set_goal(goal)
    controller.set_obstacles(every_beam)
    clock = iter(range(10**9))
    step = _timed(lambda: controller.step((0.1, -0.2, 0.0), next(clock) * 0.05), quick)
    return [
        BenchRow(SECTION, "field evaluation, 720 weighted scan points (compiled call)", kernel * 1e6, "µs",
                 target=20.0, note="velocity_at, every beam kept ('sum')"),
        BenchRow(SECTION, f"field evaluation, sector points of the same scan ({len(sector.weights)} points)",
                 sector_kernel * 1e6, "µs", target=20.0, note="velocity_at, default 'sector' weighting"),
        BenchRow(SECTION, "scan conversion, 720 beams → sector points (Python API)", conversion * 1e6, "µs",
                 note="once per scan: validation + compiled kernel"),
        BenchRow(SECTION, "controller step, 720 scan points (object layer)", step * 1e6, "µs",
                 note="BaseController.step, holonomic"),
    ]


def _image_rows(quick: bool) -> list[BenchRow]:
    rng = np.random.default_rng(1)
    obstacles = rng.uniform(-5.0, 5.0, size=(BEAMS, 2))
    grid = np.stack(np.meshgrid(np.linspace(-6, 6, 200), np.linspace(-6, 6, 200)), axis=-1).reshape(-1, 2)
    rows = []
    for label, params in (("seed plot set (kr_slope 1)", VectorFieldParams(ka=3.0, kr_dist=0.0, kr_height=2.0,
                                                                             kr_slope=1.0)),
                          ("Gazebo set (kr_slope 30)", VectorFieldParams())):
        image = _timed(lambda p=params: potential(grid, (3.0, 3.0), obstacles, p), quick)
        rows.append(BenchRow(SECTION, f"200×200 potential image, 720 obstacle points, {label}", image * 1e3, "ms",
                             target=100.0, note="potential(), V only, single thread"))
    commands = _timed(lambda: velocity(grid, (3.0, 3.0), obstacles, VectorFieldParams()), quick)
    rows.append(BenchRow(SECTION, "200×200 clamped command image, 720 obstacle points", commands * 1e3, "ms",
                         target=100.0, note="velocity()"))
    return rows


def _sim_row() -> BenchRow:
    scenario = BUILTIN_SCENARIOS["doorway"]
    steps = len(simulate(scenario).times)  # also the warm-up (compilation, caches)
    seconds = median_time(lambda: simulate(scenario), repeat=3, number=1, warmup=0)
    return BenchRow(SECTION, "simulation step: 360-beam ray cast + scan + controller (doorway)",
                    seconds / steps * 1e6, "µs", note=f"{steps} steps per run")


def run(quick: bool) -> list[BenchRow]:
    """The mobile base's figures (see the module docstring)."""
    return [*_scan_rows(quick), *_image_rows(quick), _sim_row()]
