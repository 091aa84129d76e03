"""Demo section: FindValidPose on the shipped example map (``pfield/data/maps/example.yaml``)."""

from __future__ import annotations

import math
from pathlib import Path

from rich.console import Console
from rich.table import Table

TITLE = "costmap: FindValidPose on the example map"
ROBOT = "[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25], [0.4, -0.25]]"
# (name, (x, y, yaw), request fields, expected state)
QUERIES = (
    ("goal_on_table", (-1.0, -1.6, 0.0), {"dist_tolerance": 1.0, "angle_tolerance": math.pi / 2}, "INSCRIBED"),
    ("across_the_corridor", (-2.65, 2.0, 0.0), {"dist_tolerance": 0.0, "angle_tolerance": math.pi / 2},
     "INSCRIBED"),
    ("open_floor", (2.5, -3.0, 0.3), {"dist_tolerance": 0.5, "angle_tolerance": 0.5}, "FREE"),
    ("unexplored_corner", (3.6, 2.8, 0.0), {"dist_tolerance": 0.5, "angle_tolerance": 0.5}, "UNKNOWN"),
)


def run(out_dir: Path, console: Console) -> None:
    """Answer four requests with a fresh ``/costmap`` node and write one PNG per search."""
    from pfield.costmap import example_map_path
    from pfield.demo.tools import run_find_valid_pose

    target = out_dir / "costmap"
    table = Table("request", "state", "cost", "answer (x, y, yaw)", "picture")
    for name, pose, request, expected in QUERIES:
        answer, png = run_find_valid_pose(example_map_path(), pose, request, {"footprint": ROBOT},
                                          target / f"find_valid_pose_{name}.png")
        position = answer["pose"]["pose"]["position"]
        q = answer["pose"]["pose"]["orientation"]
        yaw = math.degrees(2.0 * math.atan2(q["z"], q["w"]))
        table.add_row(name, answer["state_name"], str(answer["cost"]),
                      f"({position['x']:.2f}, {position['y']:.2f}, {yaw:.0f}°)", png.name if png else "")
        if answer["state_name"] != expected:
            raise RuntimeError(f"{name}: state {answer['state_name']}, expected {expected}")
    console.print(table)
