"""The functional API of the 2D field: potential, gradient and the clamped command at a few points.

Run: ``python examples/mobile/field_api.py [--output-dir DIR]``. What to look at: the printed table (the
raw −∇V grows without bound near the hill and far from the goal; the clamped command never exceeds
max_spd_norm = 1 m/s and never falls below min_spd_norm = 0.1 m/s in free space) and the field PNG for a
handful of obstacle points with both attraction laws side by side.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from pfield.mobile import VectorFieldParams, gradient, potential, velocity
from pfield.viz.plots2d import plot_field

OBSTACLES = np.array([[1.0, 0.0], [1.0, 0.6], [1.0, -0.6], [-1.5, 1.5]])
GOAL = np.array([3.0, 0.0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=Path("demo_output") / "examples")
    args = parser.parse_args()
    args.output_dir.mkdir(parents=True, exist_ok=True)
    params = VectorFieldParams(ka=2.0, kr_dist=0.3, kr_height=1.5, kr_slope=4.0)
    points = np.array([[-3.0, 0.0], [0.6, 0.0], [0.95, 0.0], [2.9, 0.0], [10.0, 5.0]])
    values = potential(points, GOAL, OBSTACLES, params)
    raw = -gradient(points, GOAL, OBSTACLES, params)
    command = velocity(points, GOAL, OBSTACLES, params)
    print(f"{'point':>14} {'V':>10} {'|−∇V|':>10} {'|command|':>10}")
    for p, v, g, c in zip(points, values, raw, command, strict=True):
        print(f"{np.array2string(p, precision=2):>14} {v:10.3f} {np.linalg.norm(g):10.3f} {np.linalg.norm(c):10.3f}")
    fig = Figure(figsize=(13, 5.5), layout="constrained")
    for ax, law in zip(fig.subplots(1, 2), ("power", "linear"), strict=True):
        plot_field(ax, VectorFieldParams(**{**params.as_dict(), "attraction": law}), GOAL, OBSTACLES,
                   (-4.0, 4.0, -3.0, 3.0), resolution=160)
        ax.set_title(f"attraction = {law!r}")
    path = args.output_dir / "mobile_field_api.png"
    fig.savefig(path, dpi=100)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
