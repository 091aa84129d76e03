"""Demo section: whole-body planning with the Franka Panda around a table and a pitcher, and the xArm7 seed
example through the six seed obstacles.

Writes ``whole_body_panda.png`` (link capsules at several waypoints, the end-effector path, the obstacles)
and ``whole_body_panda.csv`` (joint trajectory) into the output folder, and prints a short table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Cylinder, Obstacle
from pfield.planning import PlannedPath
from pfield.planning.scenes import SEED_GOAL, seed_obstacles
from pfield.planning.whole_body import joint_velocity_sign_flips
from pfield.robot import RobotModel
from pfield.robot.ik import solve_ik
from pfield.spatial import Pose
from pfield.viz.arm import save_arm_plot

TITLE = "robots: whole-body planning"

TOOL_DOWN = (1.0, 0.0, 0.0, 0.0)
PANDA_OBSTACLES = [
    Obstacle("table", Box(length=0.6, width=1.2, height=0.05), Pose((0.55, 0.0, 0.1))),
    Obstacle("pitcher", Cylinder(radius=0.07, height=0.28), Pose((0.5, 0.0, 0.265))),
]
PANDA_START = Pose((0.45, -0.3, 0.3), TOOL_DOWN)
PANDA_GOAL = Pose((0.45, 0.3, 0.3), TOOL_DOWN)
PANDA_CONFIG = FieldConfig(max_linear_velocity=0.2, max_angular_velocity=0.8, rotational_attractive_gain=0.6,
                           max_angular_acceleration=1.0)
"""Faster than the seed's 5 cm/s; the joint acceleration limit (= max_angular_acceleration) raised to match."""


def plan_panda_demo(robot: RobotModel) -> tuple[PlannedPath, np.ndarray]:
    """The Panda scene: IK of the start pose from the ready pose, then a whole-body plan to the goal."""
    start = solve_ik(robot, PANDA_START, robot.named_configuration("ready"))
    if not start.success:
        raise RuntimeError("no IK solution for the demo's start pose")
    field = PotentialField(PANDA_CONFIG, PANDA_GOAL, PANDA_OBSTACLES)
    return field.plan_whole_body(robot, start.q, dt=0.02, goal_tolerance=0.01, max_iterations=10000), start.q


def _table(path: PlannedPath, robot: RobotModel, rows: int = 7) -> Table:
    table = Table(title="Panda whole-body plan (every few waypoints)", title_justify="left")
    for column in ("t (s)", "x", "y", "z", "clearance (m)", *(f"q{i + 1}" for i in range(robot.n_joints))):
        table.add_column(column, justify="right")
    assert path.joint_positions is not None
    for i in sorted(set(np.linspace(0, len(path) - 1, rows).round().astype(int).tolist())):
        x, y, z = path.positions[i]
        table.add_row(f"{path.times[i]:.2f}", f"{x:.3f}", f"{y:.3f}", f"{z:.3f}", f"{path.clearances[i]:.3f}",
                      *(f"{v:+.2f}" for v in path.joint_positions[i]))
    return table


def _summary(path: PlannedPath, goal: Pose) -> str:
    error = float(np.linalg.norm(path.positions[-1] - goal.position))
    state = "[green]reached[/green]" if path.success else f"[red]failed[/red]: {path.failure_reason}"
    return (f"{state} in {path.iterations} steps ({path.duration:.1f} s), final error {error * 100:.2f} cm, "
            f"min link clearance {path.min_clearance * 100:.1f} cm, "
            f"{joint_velocity_sign_flips(path)} joint-velocity sign flips")


def run(out_dir: Path, console: Console) -> None:
    panda = RobotModel.builtin("panda")
    path, _ = plan_panda_demo(panda)
    console.print(f"Panda from {PANDA_START!r} (IK from the ready pose) to {PANDA_GOAL!r} around a table and a "
                  "pitcher, dt 0.02 s")
    console.print(_table(path, panda))
    console.print(_summary(path, PANDA_GOAL))
    if not path.success:
        raise RuntimeError(f"the Panda whole-body demo failed: {path.failure_reason}")
    picture = save_arm_plot(path, panda, PANDA_OBSTACLES, out_dir / "whole_body_panda.png",
                            "Panda whole-body plan past a pitcher on a table (link capsules)", goal=PANDA_GOAL)
    path.to_csv(out_dir / "whole_body_panda.csv")
    console.print(f"wrote {picture.name} and whole_body_panda.csv")

    xarm = RobotModel.builtin("xarm7")
    field = PotentialField(FieldConfig(), SEED_GOAL, seed_obstacles(out_dir / "meshes"))
    seed = field.plan_whole_body(xarm, [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], 0.02, 0.01, 25000)
    console.print(f"xArm7 whole_body example through the six example obstacles: {_summary(seed, SEED_GOAL)}")
