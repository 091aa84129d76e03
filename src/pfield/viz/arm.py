"""Pictures of whole-body plans: the arm's link capsules at several waypoints, to scale, among the obstacles.

Each link is drawn as the capsule pfield plans with (:attr:`RobotModel.geometry`): a cylinder of the
capsule's radius around its segment with hemispherical caps, as a 3D surface in the world frame, so what
the picture shows is what the planner keeps clear of the obstacles. The kinematic chain (base, joint
origins, end effector) is drawn as a thin line with dots so each snapshot reads as one arm. The axes share
one scale and hold the whole arm and every obstacle.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from pfield.errors import InvalidInput
from pfield.geometry import Obstacle
from pfield.planning.result import PlannedPath
from pfield.viz.plots import draw_obstacles, obstacle_bounds, set_equal_box

if TYPE_CHECKING:
    from pfield.robot import RobotModel

__all__ = ["capsule_surface", "draw_arm", "plot_arm_plan", "save_arm_plot"]


def capsule_surface(a: ArrayLike, b: ArrayLike, radius: float, n: int = 14) -> tuple[NDArray[Any], ...]:
    """(X, Y, Z) grids of the capsule of ``radius`` (m) around the segment a–b (world frame, m)."""
    start, end = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    axis = end - start
    length = float(np.linalg.norm(axis))
    w = axis / length if length > 1e-12 else np.array([0.0, 0.0, 1.0])
    helper = np.array([1.0, 0.0, 0.0]) if abs(w[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(w, helper)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    theta, phi = np.meshgrid(np.linspace(0.0, 2.0 * np.pi, n), np.linspace(0.0, np.pi, n))
    along = radius * np.cos(phi)
    along = np.where(along >= 0.0, along + length, along)  # caps at the two ends, the shaft between
    ring = radius * np.sin(phi)
    points = (start + along[..., None] * w + (ring * np.cos(theta))[..., None] * u
              + (ring * np.sin(theta))[..., None] * v)
    return points[..., 0], points[..., 1], points[..., 2]


def draw_arm(ax: Any, robot: RobotModel, q: ArrayLike, colour: Any, alpha: float = 0.22) -> NDArray[np.float64]:
    """Draw the link capsules and the kinematic chain of ``robot`` at joint angles ``q`` on a 3D axes.

    Returns the drawn points (for axis limits)."""
    from pfield.robot.geometry import world_segment

    angles = robot.check_joint_angles(q)
    rotations, origins = robot.joint_frames(angles)
    drawn = []
    for capsule in robot.geometry.capsules:
        a, b = world_segment(capsule, rotations, origins)
        surface = capsule_surface(a, b, capsule.radius)
        ax.plot_surface(*surface, color=colour, alpha=alpha, linewidth=0, shade=True)
        drawn.append(np.stack([np.ravel(c) for c in surface], axis=1))
    chain = np.vstack([np.zeros(3), origins, robot.forward_kinematics(angles).position])
    ax.plot(*chain.T, color=colour, linewidth=1.2, marker="o", markersize=2.5)
    return np.concatenate([*drawn, chain])


def plot_arm_plan(path: PlannedPath, robot: RobotModel, obstacles: Sequence[Obstacle] = (), title: str = "",
                  snapshots: int = 5) -> Figure:
    """3D figure of a whole-body plan: the arm at ``snapshots`` evenly spaced waypoints (colour = time), the
    end-effector path and the obstacles (legend by id)."""
    if not isinstance(path, PlannedPath) or path.joint_positions is None:
        raise InvalidInput("path", type(path).__name__, "expected a whole-body pfield.PlannedPath (joint positions)")
    if isinstance(snapshots, bool) or not isinstance(snapshots, int) or snapshots < 1:
        raise InvalidInput("snapshots", snapshots, "must be an integer >= 1")
    figure = Figure(figsize=(9, 7.5), layout="constrained")
    FigureCanvasAgg(figure)
    ax: Any = figure.add_subplot(projection="3d")
    handles = draw_obstacles(ax, obstacles)
    colours = colormaps["viridis"](np.linspace(0.0, 0.9, snapshots))
    cloud = [path.positions, obstacle_bounds(obstacles)]
    steps = np.unique(np.linspace(0, len(path) - 1, snapshots).round().astype(int))
    for colour, i in zip(colours, steps, strict=False):
        cloud.append(draw_arm(ax, robot, path.joint_positions[i], colour))
        ax.plot([], [], color=colour, linewidth=6, alpha=0.6, label=f"link capsules at t = {path.times[i]:.1f} s")
    ax.plot(*path.positions.T, color="crimson", linewidth=2, label="end-effector path")
    set_equal_box(ax, np.concatenate(cloud))
    ax.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)")
    ax.set_title(title or ("whole-body plan: reached the goal" if path.success else path.failure_reason),
                 fontsize=10)
    ax.view_init(elev=25, azim=-60)
    lines, _ = ax.get_legend_handles_labels()
    ax.legend(handles=[*lines, *handles], loc="upper left", fontsize=8, framealpha=0.85)
    return figure


def save_arm_plot(path: PlannedPath, robot: RobotModel, obstacles: Sequence[Obstacle], file: str | Path,
                  title: str = "", snapshots: int = 5) -> Path:
    """Write :func:`plot_arm_plan` as a PNG (110 dpi); return the file path."""
    figure = plot_arm_plan(path, robot, obstacles, title, snapshots)
    target = Path(file)
    target.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(target, dpi=110)
    return target
