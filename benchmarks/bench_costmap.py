"""Costmap FindValidPose: the no-solution worst case and a typical query (REFERENCE.md §5).

Map: 400×400 cells at 5 cm (20 m), 8 % random single-cell obstacles (seed 0), nav2 inflation
(inflation_radius 0.55 m, cost_scaling_factor 10) for a 0.8×0.5 m rectangular robot (no padding);
requests at the map centre, yaw 0, 5° yaw steps.

* no solution: 1 m & ±90° (C++ Move Base Flex-style loop ≈ 0.43 s; target ≤ 50 ms), 1 m & ±180° (≈ 1.2 s),
  2 m & ±90° (≈ 3.9 s). Every candidate is LETHAL, so every candidate is examined.
* the same with the robot's centre outside its footprint (same 0.8×0.5 m rectangle, shifted 0.45 m
  forward), which disables the lethal-distance prefilter: every candidate is rasterised and scanned
  until its first lethal cell.
* the same with the obstacles turned into unknown cells, which the lethal-distance prefilter cannot
  skip: every candidate is scanned cell by cell (answer UNKNOWN; no C++ figure).
* typical: a 3×3 m cleared area around the request, one obstacle under the robot's centre, 1 m and
  ±90°; the answer (INSCRIBED: next to an obstacle) lies within 0.3 m (C++ 0.1–11 ms when a solution
  is near; target ≤ 2 ms).
"""

from __future__ import annotations

import math

import numpy as np

from benchmarks._common import BenchRow, median_time
from pfield.costmap import (
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
    CostmapParams,
    Footprint,
    OccupancyMap,
    PoseState,
    build_costmap,
    find_valid_pose,
)
from pfield.spatial import Pose

SECTION = "costmap find_valid_pose"
ROBOT = "[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25], [0.4, -0.25]]"


def _random_map(seed: int = 0) -> OccupancyMap:
    rng = np.random.default_rng(seed)
    data = np.where(rng.random((400, 400)) < 0.08, 100, 0).astype(np.int8)
    return OccupancyMap(data, 0.05)


def _params() -> CostmapParams:
    return CostmapParams(footprint=ROBOT, footprint_padding=0.0)


def _time(costmap: Costmap2D, pose: Pose, dist: float, angle: float, quick: bool,
          footprint: Footprint | None = None) -> tuple[float, PoseState, float]:
    footprint = footprint or _params().robot_footprint()

    def call() -> object:
        return find_valid_pose(costmap, footprint, pose, dist_tolerance=dist, angle_tolerance=angle)

    seconds = median_time(call, repeat=3 if quick else 9, warmup=1)
    result = find_valid_pose(costmap, footprint, pose, dist_tolerance=dist, angle_tolerance=angle)
    return seconds * 1e3, result.state, result.distance if result.distance is not None else math.nan


def run(quick: bool) -> list[BenchRow]:
    occupancy = _random_map()
    costmap = build_costmap(occupancy, _params())
    build_ms = median_time(lambda: build_costmap(occupancy, _params()), repeat=3, warmup=1) * 1e3
    centre = Pose.planar(10.0 + 0.013, 10.0 + 0.021, 0.0)
    rows = [BenchRow(SECTION, "build + inflate 400×400 costmap", build_ms, "ms", note="scipy exact EDT")]
    cases = [("no solution, 1 m ±90°", 1.0, math.pi / 2, 430.0, 50.0),
             ("no solution, 1 m ±180°", 1.0, math.pi, 1200.0, None),
             ("no solution, 2 m ±90°", 2.0, math.pi / 2, 3900.0, None)]
    for name, dist, angle, reference, target in cases:
        ms, state, _ = _time(costmap, centre, dist, angle, quick)
        rows.append(BenchRow(SECTION, name, ms, "ms", reference, target, note=f"answer {state.name}"))
    behind = Footprint.from_points([[0.85, 0.25], [0.05, 0.25], [0.05, -0.25], [0.85, -0.25]])
    ms, state, _ = _time(costmap, centre, 1.0, math.pi / 2, quick, behind)
    rows.append(BenchRow(SECTION, "no solution, 1 m ±90°, prefilter off", ms, "ms", 430.0,
                         note=f"answer {state.name}; robot centre outside its footprint"))
    unknown = Costmap2D(np.where(costmap.costs == LETHAL_OBSTACLE, NO_INFORMATION, 0).astype(np.uint8), 0.05)
    ms, state, _ = _time(unknown, centre, 1.0, math.pi / 2, quick)
    rows.append(BenchRow(SECTION, "all candidates scanned (obstacles unknown), 1 m ±90°", ms, "ms",
                         note=f"answer {state.name}; prefilter cannot help"))
    data = np.array(occupancy.data)
    data[170:230, 170:230] = 0
    data[200, 200] = 100  # under the robot's centre: no rotation helps, the robot must move
    typical = build_costmap(OccupancyMap(data, 0.05), _params())
    ms, state, distance = _time(typical, centre, 1.0, math.pi / 2, quick)
    rows.append(BenchRow(SECTION, "typical: valid pose within 0.3 m", ms, "ms", None, 2.0,
                         note=f"answer {state.name} at {distance:.2f} m"))
    return rows
