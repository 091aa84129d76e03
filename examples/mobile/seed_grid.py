"""The seed's simulation: a 5×5 grid of repulsive points, two parameter sets, two drive types.

Run: ``python examples/mobile/seed_grid.py [--output-dir DIR]``. What to look at: the printed outcomes —
``stuck`` in front of the grid with kr_dist 0, kr_height 2, kr_slope 1 ("cannot go through") and
``goal_reached`` with kr_dist −1, kr_height 3, kr_slope 1, ka 3 ("can go through") — and the four PNGs: the
potential as an image, the clamped command as arrows, and the trajectory.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pfield.mobile.scenarios import BUILTIN_SCENARIOS
from pfield.mobile.sim import simulate
from pfield.viz.plots2d_sim import render_png


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=Path("demo_output") / "examples")
    args = parser.parse_args()
    args.output_dir.mkdir(parents=True, exist_ok=True)
    for name in ("grid_blocked", "grid_pass"):
        for drive in ("holonomic", "diff_drive"):
            result = simulate(BUILTIN_SCENARIOS[name].with_drive(drive))
            path = render_png(result, args.output_dir / f"mobile_{name}_{drive}.png")
            print(f"{name:<13} {drive:<11} {result.outcome:<13} after {result.times[-1]:5.1f} s, "
                  f"{result.final_distance_to_goal:5.2f} m from the goal -> {path}")


if __name__ == "__main__":
    main()
