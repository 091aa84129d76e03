"""Pictures of whole-body plans: the arm at key moments, the end-effector path and the clearance over time.

Small multiples, so the motion reads at a glance: the top row shows the arm alone at each key moment (the
start, the closest approach to an obstacle, the end, and evenly spaced moments between), each panel with the
obstacles and the end-effector path up to that moment; below, the end-effector path large among the
obstacles, coloured by time with the key moments numbered, and the clearance over time with the moments
marked; a goal, when given, is a gold star in every 3D panel. Each link is drawn as the capsule pfield plans
with (:attr:`RobotModel.geometry`): a cylinder of the capsule's radius around its segment with hemispherical
caps, so what the picture shows is what the planner keeps clear of the obstacles. The kinematic chain (joint
origins, end effector) is drawn as a thin line with dots. Every 3D panel has one scale on its three axes.
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
from pfield.spatial import Pose
from pfield.viz.plots import draw_obstacles, obstacle_bounds, set_equal_box

if TYPE_CHECKING:
    from pfield.robot import RobotModel

__all__ = ["capsule_surface", "draw_arm", "key_moments", "plot_arm_plan", "save_arm_plot"]


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
    chain = np.vstack([origins, robot.forward_kinematics(angles).position])  # from the first joint: a base
    # raised on a stand is not joined to the world origin
    ax.plot(*chain.T, color=colour, linewidth=1.2, marker="o", markersize=2.5)
    return np.concatenate([*drawn, chain])


def key_moments(path: PlannedPath, count: int) -> NDArray[np.int64]:
    """Up to ``count`` waypoint indices worth showing, in time order: the start, the end, the closest approach
    to an obstacle (when the plan has clearances), and evenly spaced waypoints between."""
    last = len(path) - 1
    chosen = {0, last}
    clearances = np.asarray(path.clearances, dtype=np.float64)
    if count > 2 and clearances.size == len(path) and np.isfinite(clearances).any():
        chosen.add(int(np.nanargmin(np.where(np.isfinite(clearances), clearances, np.nan))))
    for index in np.linspace(0, last, count + 2).round().astype(int)[1:-1]:
        if len(chosen) >= count:
            break
        chosen.add(int(index))
    return np.array(sorted(chosen)[:count] if count > 1 else [last], dtype=np.int64)


def _scene_cloud(path: PlannedPath, obstacles: Sequence[Obstacle]) -> NDArray[np.float64]:
    return np.concatenate([path.positions, obstacle_bounds(obstacles)])


def plot_arm_plan(path: PlannedPath, robot: RobotModel, obstacles: Sequence[Obstacle] = (), title: str = "",
                  snapshots: int = 4, goal: Pose | None = None) -> Figure:
    """A figure of a whole-body plan (see the module docstring): ``snapshots`` panels of the arm at key
    moments, the end-effector path and the clearance over time. ``figure.axes[:k]`` are the snapshot panels,
    then the path panel and the clearance panel. ``goal``: the end-effector goal, marked where the path should
    have ended (a failed plan's picture shows how far it stayed)."""
    if not isinstance(path, PlannedPath) or path.joint_positions is None:
        raise InvalidInput("path", type(path).__name__, "expected a whole-body pfield.PlannedPath (joint positions)")
    if isinstance(snapshots, bool) or not isinstance(snapshots, int) or not 1 <= snapshots <= 8:
        raise InvalidInput("snapshots", snapshots, "must be an integer in [1, 8]")
    if goal is not None and not isinstance(goal, Pose):
        raise InvalidInput("goal", goal, "expected a pfield.Pose or None")
    target = np.empty((0, 3)) if goal is None else goal.position[None, :]
    moments = key_moments(path, snapshots)
    figure = Figure(figsize=(3.4 * max(len(moments), 3), 9.0), layout="constrained")
    FigureCanvasAgg(figure)
    grid = figure.add_gridspec(2, 2 * len(moments), height_ratios=(1.0, 1.15))
    colours = colormaps["viridis"](np.linspace(0.0, 0.9, len(moments)))
    clearances = np.asarray(path.clearances, dtype=np.float64)
    handles: list[Any] = []
    for k, (index, colour) in enumerate(zip(moments, colours, strict=True)):
        ax: Any = figure.add_subplot(grid[0, 2 * k:2 * k + 2], projection="3d")
        handles = draw_obstacles(ax, obstacles)
        arm = draw_arm(ax, robot, path.joint_positions[index], colour, alpha=0.35)
        ax.plot(*path.positions[:index + 1].T, color="crimson", linewidth=1.5)
        if goal is not None:
            ax.scatter(*goal.position, marker="*", s=90, color="gold", edgecolors="k", depthshade=False)
        set_equal_box(ax, np.concatenate([_scene_cloud(path, obstacles), arm, target]))
        clearance = f" · clearance {100 * clearances[index]:.1f} cm" if clearances.size == len(path) and \
            np.isfinite(clearances[index]) else ""
        ax.set_title(f"({k + 1}) t = {path.times[index]:.2f} s{clearance}", fontsize=9)
        ax.view_init(elev=22, azim=-60)
        ax.tick_params(labelsize=6)
    # the end-effector path, large, coloured by time, the key moments numbered
    ax = figure.add_subplot(grid[1, :len(moments)], projection="3d")
    draw_obstacles(ax, obstacles)
    points = path.positions
    segments = np.stack([points[:-1], points[1:]], axis=1)
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    if len(segments):
        ax.add_collection3d(Line3DCollection(segments, colors=colormaps["viridis"](np.linspace(0.0, 0.9,
                                                                                              len(segments))),
                                             linewidths=2.5))
    for k, (index, colour) in enumerate(zip(moments, colours, strict=True)):
        ax.scatter(*points[index], color=colour, s=40, edgecolors="k", depthshade=False)
        ax.text(*points[index], f" {k + 1}", fontsize=9)
    if goal is not None:
        ax.scatter(*goal.position, marker="*", s=220, color="gold", edgecolors="k", depthshade=False, label="goal")
    else:
        ax.scatter(*points[-1], marker="*", s=160, color="gold", edgecolors="k", depthshade=False, label="end")
    set_equal_box(ax, np.concatenate([points, obstacle_bounds(obstacles), target]), 0.05)
    ax.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)")
    ax.set_title("end-effector path (colour: time)", fontsize=10)
    ax.view_init(elev=25, azim=-60)
    ax.legend(handles=[*ax.get_legend_handles_labels()[0], *handles], loc="upper left", fontsize=8, framealpha=0.85)
    # the clearance over time
    ax2: Any = figure.add_subplot(grid[1, len(moments):])
    if clearances.size == len(path):
        ax2.plot(path.times, 100 * clearances, color="tab:blue", linewidth=1.5, label="link model clearance")
        for k, (index, colour) in enumerate(zip(moments, colours, strict=True)):
            ax2.axvline(path.times[index], color=colour, linewidth=1.0)
            ax2.annotate(f"{k + 1}", (path.times[index], 1.0), xycoords=("data", "axes fraction"), fontsize=9,
                         ha="center", va="bottom")
        ax2.set_ylim(bottom=0.0)
    ax2.set(xlabel="t (s)", ylabel="clearance (cm)")
    ax2.grid(True, alpha=0.3)
    figure.suptitle(title or ("whole-body plan: reached the goal" if path.success else path.failure_reason),
                    fontsize=11)
    return figure


def save_arm_plot(path: PlannedPath, robot: RobotModel, obstacles: Sequence[Obstacle], file: str | Path,
                  title: str = "", snapshots: int = 4, goal: Pose | None = None) -> Path:
    """Write :func:`plot_arm_plan` as a PNG (110 dpi); return the file path."""
    figure = plot_arm_plan(path, robot, obstacles, title, snapshots, goal)
    target = Path(file)
    target.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(target, dpi=110)
    return target
