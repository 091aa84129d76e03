"""Demo section: task-space planning through the seed's six obstacles, and a head-on sphere avoided.

Writes ``manipulator_task_space.png`` (path, obstacles, speed and clearance), ``manipulator_task_space.csv``
(the waypoints) and ``manipulator_head_on.png`` into the output folder.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Obstacle, Sphere
from pfield.planning import PlannedPath
from pfield.planning.scenes import SEED_GOAL, SEED_PLAN, SEED_START, seed_obstacles
from pfield.spatial import Pose
from pfield.viz.plots import save_path_plot

TITLE = "manipulator: task-space planning"


def _table(path: PlannedPath, rows: int = 8) -> Table:
    table = Table(title="example task-space plan (every few waypoints)", title_justify="left")
    for column in ("t (s)", "x", "y", "z", "speed (m/s)", "clearance (m)"):
        table.add_column(column, justify="right")
    picks = sorted(set(np.linspace(0, len(path) - 1, rows).round().astype(int).tolist()))
    for i in picks:
        x, y, z = path.positions[i]
        speed = float(np.linalg.norm(path.twists[i, :3]))
        table.add_row(f"{path.times[i]:.2f}", f"{x:.3f}", f"{y:.3f}", f"{z:.3f}", f"{speed:.4f}",
                      f"{path.clearances[i]:.3f}")
    return table


def _summary(path: PlannedPath, goal: Pose) -> str:
    error = float(np.linalg.norm(path.positions[-1] - goal.position))
    state = "[green]reached[/green]" if path.success else f"[red]failed[/red]: {path.failure_reason}"
    return (f"{state} in {len(path)} waypoints ({path.duration:.2f} s), final error {error * 100:.2f} cm, "
            f"min clearance {path.min_clearance * 100:.1f} cm")


def run(out_dir: Path, console: Console) -> None:
    obstacles = seed_obstacles(out_dir / "meshes")
    field = PotentialField(FieldConfig(), SEED_GOAL, obstacles)
    path = field.plan(SEED_START, **SEED_PLAN)
    console.print(f"example scene: start {SEED_START!r} → goal {SEED_GOAL!r}, dt {SEED_PLAN['dt']} s, "
                  f"obstacles: {', '.join(o.id for o in obstacles)}")
    console.print(_table(path))
    console.print(_summary(path, SEED_GOAL))
    if not path.success:
        raise RuntimeError(f"the example task-space plan failed: {path.failure_reason}")
    picture = save_path_plot(path, out_dir / "manipulator_task_space.png", obstacles, SEED_GOAL,
                             "example task-space plan through the six example obstacles")
    path.to_csv(out_dir / "manipulator_task_space.csv")
    console.print(f"wrote {picture.name} and manipulator_task_space.csv")

    ball, goal = Obstacle("ball", Sphere(radius=0.1), Pose((0.5, 0.0, 0.3))), Pose((0.8, 0.0, 0.3))
    head_on = PotentialField(FieldConfig(), goal, [ball]).plan(Pose((0.2, 0.0, 0.3)))
    console.print(f"head-on sphere (the original drove through it): {_summary(head_on, goal)}")
    save_path_plot(head_on, out_dir / "manipulator_head_on.png", [ball], goal,
                   "a sphere straight between start and goal is circumvented")
    console.print("wrote manipulator_head_on.png")
