"""Demo section: a simulated operator drives the end effector straight at a target through spheres and a moving
sphere, with pfield's assistance (``compute_assistance``, arbitration ``linear_goal``) and, for comparison, without.

Writes ``assisted_teleop.png``: the operator's and the executed speed, the autonomy share α and the nearest
distance over time (see :mod:`pfield.demo._teleop_sim` for the operator and the modes).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from rich.console import Console

from pfield.demo._teleop_sim import TeleopRun, simulate
from pfield.geometry import Obstacle, Sphere
from pfield.spatial import Pose

TITLE = "shared control: an assisted teleoperation run"
START, GOAL = np.array([0.3, 0.0, 0.5]), np.array([0.6, 0.3, 0.3])


def _scene() -> tuple[list[Obstacle], dict[str, object]]:
    line = GOAL - START
    across = np.cross(line, [0.0, 0.0, 1.0])
    across /= np.linalg.norm(across)
    spheres = [Obstacle(f"sphere_{i}", Sphere(0.03), Pose(START + f * line)) for i, f in enumerate((0.3, 0.75))]
    centre = START + 0.5 * line
    mover = Obstacle("mover", Sphere(0.04), Pose(centre), group="Dynamic")
    return [*spheres, mover], {"mover": lambda t: centre + 0.12 * math.sin(0.6 * t) * across}


def save_assisted_plot(assisted: TeleopRun, unassisted: TeleopRun, path: Path) -> Path:
    """Speeds, α and the nearest distance over time of an assisted run (and the operator alone)."""
    figure = Figure(figsize=(8, 7), constrained_layout=True)
    FigureCanvasAgg(figure)
    speed, share, distance = figure.subplots(3, 1, sharex=True)
    t = assisted.times
    speed.plot(t, np.linalg.norm(assisted.operator, axis=1), label="operator's command")
    speed.plot(t, np.linalg.norm(assisted.executed, axis=1), label="executed (assisted)")
    speed.set_ylabel("speed (m/s)")
    speed.legend(loc="upper right")
    share.plot(t, assisted.alpha, color="tab:green")
    share.set_ylabel("α (autonomy share)")
    share.set_ylim(-0.05, 1.05)
    distance.plot(t, assisted.clearance, label="assisted")
    distance.plot(unassisted.times, unassisted.clearance, "--", label="no assistance")
    distance.axhline(0.0, color="black", linewidth=0.8)
    distance.set_ylabel("nearest distance (m)")
    distance.set_xlabel("time (s)")
    distance.legend(loc="upper right")
    figure.suptitle("assisted teleoperation: the operator aims straight at the target")
    figure.savefig(path, dpi=110)
    return path


def run(out_dir: Path, console: Console) -> None:
    obstacles, motion = _scene()
    assisted = simulate(obstacles, START, GOAL, "pfield", seed=0, motion=motion)  # type: ignore[arg-type]
    alone = simulate(obstacles, START, GOAL, "none", seed=0, motion=motion)  # type: ignore[arg-type]
    for name, result in (("assisted", assisted), ("no assistance", alone)):
        console.print(f"{name}: collision {result.collided}, reached {result.success} in {result.time_to_goal:.2f} s, "
                      f"min distance {result.clearance.min():.4f} m, agreement {result.agreement:.3f}")
    if assisted.collided or not assisted.success:
        raise RuntimeError("the assisted run collided or did not reach the target")
    picture = save_assisted_plot(assisted, alone, out_dir / "assisted_teleop.png")
    console.print(f"wrote {picture.name}")
