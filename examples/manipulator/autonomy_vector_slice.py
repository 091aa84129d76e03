"""The task-space autonomy vector on a grid: a batch evaluation of the constrained twist around a table.

Run: ``python examples/manipulator/autonomy_vector_slice.py [--output-dir DIR] [--resolution N]``. What to
look at: the quiver plot of the twist in the plane z = 0.4 through the seed's goal, which lies 8.5 cm in front
of the table face. Arrow length and colour give the speed (the key: 0.05 m/s; the colour bar). Far away the
arrows are the saturated attraction (≤ 0.05 m/s); within the influence distance (0.1 m, dashed) the component
toward the table shrinks to zero at the safety distance and the arrows turn to run along the face, yet at the
goal itself nothing pushes it away from the table, so the goal stays an equilibrium. The printed timing is one
batch call for the whole grid.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from pfield import Box, FieldConfig, Obstacle, PotentialField
from pfield.spatial import Pose

SPEED_COLOURS = ListedColormap(colormaps["viridis"](np.linspace(0.85, 0.0, 256)))
"""Slow arrows light green, full-speed arrows dark violet (readable on white)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--output-dir", type=Path, default=Path("demo_output") / "examples")
    parser.add_argument("--resolution", type=int, default=41)
    args = parser.parse_args()
    table = Obstacle("table", Box(length=0.15, width=0.7, height=0.6), Pose((0.66, 0.0, 0.3)))
    goal = Pose((0.5, 0.2, 0.4))
    field = PotentialField(FieldConfig(), goal, [table])
    xs, ys = np.meshgrid(np.linspace(0.2, 0.8, args.resolution), np.linspace(-0.1, 0.5, args.resolution))
    points = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, 0.4)], axis=1)
    field.twists(points)  # the first call loads the compiled kernel
    start = time.perf_counter()
    twists = field.twists(points)
    print(f"{len(points)} constrained twists in {(time.perf_counter() - start) * 1e3:.2f} ms (one batch call)")
    at_goal = field.twist(goal)
    print(f"twist at the goal: {at_goal.linear} m/s (zero: the goal stays an equilibrium next to the table)")
    inside = field.clearances(points) < 0.0
    figure = Figure(figsize=(7, 6), layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    speeds = np.linalg.norm(twists[:, :2], axis=1)
    spacing = 0.6 / (args.resolution - 1)
    # Scale: an arrow of 0.05 m/s (the speed limit) is 0.9 grid spacings long, in the plot's metres.
    arrows = ax.quiver(points[~inside, 0], points[~inside, 1], twists[~inside, 0], twists[~inside, 1],
                       speeds[~inside], cmap=SPEED_COLOURS, clim=(0.0, 0.05), angles="xy", scale_units="xy",
                       scale=0.05 / (0.9 * spacing), width=0.003)
    ax.quiverkey(arrows, 0.83, 1.03, 0.05, "0.05 m/s", labelpos="E", coordinates="axes")
    figure.colorbar(arrows, ax=ax, label="speed in the plane (m/s)", fraction=0.04)
    ax.add_patch(Rectangle((0.585, -0.35), 0.15, 0.7, color="tab:orange", alpha=0.4, label="table"))
    ax.add_patch(Rectangle((0.485, -0.45), 0.35, 0.9, fill=False, linestyle="--", label="influence distance"))
    ax.plot(*goal.position[:2], "r*", markersize=14, label="goal")
    ax.set(xlim=(0.2, 0.8), ylim=(-0.1, 0.5), aspect="equal", xlabel="x (m)", ylabel="y (m)",
           title="constrained twist at z = 0.4 m")
    ax.legend(loc="lower left")
    args.output_dir.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.output_dir / "example_autonomy_vector_slice.png", dpi=120, bbox_inches="tight")
    print(f"wrote {args.output_dir / 'example_autonomy_vector_slice.png'}")


if __name__ == "__main__":
    main()
