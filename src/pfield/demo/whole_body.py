"""Demo section: whole-body planning with the Franka Panda around a table and a pitcher, and the xArm7 seed
example through the six seed obstacles.

Writes ``whole_body_panda.png`` (link capsules at several waypoints, the end-effector path, the obstacles)
and ``whole_body_panda.csv`` (joint trajectory) into the output folder, and prints a short table.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Cylinder, Obstacle
from pfield.planning import PlannedPath
from pfield.planning.scenes import SEED_GOAL, seed_obstacles
from pfield.planning.whole_body import joint_velocity_sign_flips
from pfield.robot import RobotModel
from pfield.robot.geometry import world_segment
from pfield.robot.ik import solve_ik
from pfield.spatial import Pose

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


def _capsule_lines(robot: RobotModel, q: np.ndarray) -> list[tuple[np.ndarray, float]]:
    rotations, origins = robot.joint_frames(q)
    return [(np.stack(world_segment(capsule, rotations, origins)), capsule.radius)
            for capsule in robot.geometry.capsules]


def save_arm_plot(path: PlannedPath, robot: RobotModel, obstacles: list[Obstacle], target: Path, title: str,
                  snapshots: int = 5) -> Path:
    """3D picture: link capsules (thick segments) at ``snapshots`` waypoints, the EE path, the obstacles."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pfield.viz.plots import draw_obstacles

    figure = plt.figure(figsize=(8, 7))
    ax: Any = figure.add_subplot(projection="3d")
    draw_obstacles(ax, obstacles)
    assert path.joint_positions is not None
    colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.9, snapshots))
    points = [path.positions]
    for colour, i in zip(colours, np.linspace(0, len(path) - 1, snapshots).round().astype(int), strict=True):
        q = path.joint_positions[i]
        for segment, radius in _capsule_lines(robot, q):
            ax.plot(*segment.T, color=colour, linewidth=radius * 70, alpha=0.35, solid_capstyle="round")
            points.append(segment)
        # The kinematic chain (base, joint origins, end effector) makes each snapshot read as one arm.
        chain = np.vstack([np.zeros(3), robot.joint_frames(q)[1], robot.forward_kinematics(q).position])
        ax.plot(*chain.T, color=colour, linewidth=1.5, marker="o", markersize=2.5)
        ax.plot([], [], color=colour, linewidth=4, label=f"links at t = {path.times[i]:.1f} s")
    ax.plot(*path.positions.T, color="crimson", linewidth=2, label="end-effector path")
    ax.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title=title)
    cloud = np.concatenate(points)
    centre, half = 0.5 * (cloud.min(axis=0) + cloud.max(axis=0)), 0.55 * float(np.ptp(cloud, axis=0).max())
    ax.set(xlim=(centre[0] - half, centre[0] + half), ylim=(centre[1] - half, centre[1] + half),
           zlim=(max(centre[2] - half, 0.0), max(centre[2] - half, 0.0) + 2 * half))
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=25, azim=-60)
    ax.legend(loc="upper left", fontsize=8)
    figure.tight_layout()
    figure.savefig(target, dpi=110)
    plt.close(figure)
    return target


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
                            "Panda whole-body plan: link capsules at 5 waypoints")
    path.to_csv(out_dir / "whole_body_panda.csv")
    console.print(f"wrote {picture.name} and whole_body_panda.csv")

    xarm = RobotModel.builtin("xarm7")
    field = PotentialField(FieldConfig(), SEED_GOAL, seed_obstacles(out_dir / "meshes"))
    seed = field.plan_whole_body(xarm, [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], 0.02, 0.01, 25000)
    console.print(f"xArm7 seed whole_body example through the six seed obstacles: {_summary(seed, SEED_GOAL)}")
