"""Assisted teleoperation: an operator drives straight at a wall, the repulsion stops the robot short of it.

Run: ``python examples/mobile/assisted_teleop.py [--output-dir DIR] [--seconds S]``. What to look at: the
printed table — the commanded speed never exceeds the operator's 0.5 m/s and falls to zero while the gap
to the wall settles at 0.70 m, where the summed repulsion of the wall's scan points (the nearest return of
each 5° sector) equals the operator's speed. One obstacle point alone would stop the robot at
kr_dist + ln(kr_height/0.5)/kr_slope = 0.47 m; the neighbouring sectors of the wall push too, so it stops
farther away. The PNG shows the speed and the gap over time, for both drive types.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from pfield.mobile import VectorFieldParams
from pfield.mobile.config import ControllerConfig
from pfield.mobile.controller import BaseController
from pfield.mobile.scan import compose_pose2d, scan_ranges_obstacles
from pfield.mobile.sim import integrate_pose
from pfield.mobile.world import World2D

WALL_X = 3.0
BEAMS = 720
RATE = 20.0


def drive_at_wall(drive: str, seconds: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, commanded speeds and gaps to the wall for one drive type."""
    world = World2D.build(polygons=[[(WALL_X, -5.0), (WALL_X + 0.2, -5.0), (WALL_X + 0.2, 5.0), (WALL_X, 5.0)]])
    params = VectorFieldParams(kr_dist=0.4, kr_height=1.0, kr_slope=10.0, max_spd_norm=1.0)
    config = ControllerConfig(drive=drive)
    controller = BaseController(params, config)
    angles = -math.pi + np.arange(BEAMS) * (2 * math.pi / BEAMS)
    pose = np.array([0.0, 0.2, 0.0])
    times, speeds, gaps = [], [], []
    for k in range(round(seconds * RATE)):
        now = k / RATE
        sensor = compose_pose2d(pose, config.sensor_pose)
        ranges = world.raycast(sensor[:2], angles + sensor[2], 8.0)
        controller.set_obstacles(scan_ranges_obstacles(ranges, -math.pi, 2 * math.pi / BEAMS, 0.05, 8.0, sensor))
        controller.set_teleop(0.5, 0.0, 0.0, now)  # the operator keeps pushing forward at 0.5 m/s
        command = controller.step(pose, now)
        times.append(now)
        speeds.append(command.speed)
        gaps.append(WALL_X - pose[0])
        pose = integrate_pose(pose, np.array([command.linear_x, command.linear_y, command.angular_z]), 1 / RATE)
    return np.array(times), np.array(speeds), np.array(gaps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=Path("demo_output") / "examples")
    parser.add_argument("--seconds", type=float, default=15.0)
    args = parser.parse_args()
    args.output_dir.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(9, 4), layout="constrained")
    ax_speed, ax_gap = fig.subplots(1, 2)
    print(f"{'drive':<11} {'max speed':>10} {'final speed':>12} {'final gap':>10}")
    for drive in ("holonomic", "diff_drive"):
        times, speeds, gaps = drive_at_wall(drive, args.seconds)
        print(f"{drive:<11} {speeds.max():10.3f} {speeds[-1]:12.4f} {gaps[-1]:10.3f}")
        ax_speed.plot(times, speeds, label=drive)
        ax_gap.plot(times, gaps, label=drive)
    ax_speed.axhline(0.5, color="k", ls="--", lw=0.8, label="operator's speed")
    ax_speed.set(xlabel="t (s)", ylabel="commanded speed (m/s)")
    ax_gap.set(xlabel="t (s)", ylabel="gap to the wall (m)")
    for ax in (ax_speed, ax_gap):
        ax.legend()
        ax.grid(alpha=0.3)
    path = args.output_dir / "mobile_assisted_teleop.png"
    fig.savefig(path, dpi=100)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
