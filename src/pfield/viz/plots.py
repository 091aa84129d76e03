"""Headless matplotlib figures of 3D scenes: obstacles, planned paths and their clearance.

Every function builds a :class:`matplotlib.figure.Figure` with the object API (no pyplot state, no
display needed) so it works in tests, servers and CI. Obstacles are drawn from their exact shape
parameters (DESIGN §2) in the world frame; meshes from their (scaled) triangles.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from numpy.typing import NDArray

from pfield.errors import InvalidInput
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, Sphere
from pfield.planning.result import PlannedPath
from pfield.spatial import Pose

__all__ = ["draw_obstacles", "plot_path_3d", "save_path_plot"]

_COLOURS = ("tab:gray", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")


def _ellipsoid_surface(a: float, b: float, c: float, n: int = 18) -> tuple[NDArray[Any], ...]:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n), np.linspace(0, np.pi, n))
    return a * np.cos(u) * np.sin(v), b * np.sin(u) * np.sin(v), c * np.cos(v)


def _capsule_surface(radius: float, shaft: float, n: int = 18) -> tuple[NDArray[Any], ...]:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n), np.linspace(0, np.pi, n))
    z = radius * np.cos(v)
    z = np.where(z >= 0, z + shaft / 2, z - shaft / 2)
    return radius * np.cos(u) * np.sin(v), radius * np.sin(u) * np.sin(v), z


def _cylinder_surface(radius: float, height: float, n: int = 24) -> tuple[NDArray[Any], ...]:
    u, h = np.meshgrid(np.linspace(0, 2 * np.pi, n), np.array([-0.5, -0.5, 0.5, 0.5]) * height)
    r = np.array([0.0, radius, radius, 0.0])[:, None] * np.ones_like(u)
    return r * np.cos(u), r * np.sin(u), h


def _box_faces(length: float, width: float, height: float) -> NDArray[Any]:
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    corners = corners * (length, width, height)
    quads = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
    return np.array([[corners[i] for i in quad] for quad in quads])


def _to_world(pose: Pose, x: NDArray[Any], y: NDArray[Any], z: NDArray[Any]) -> tuple[NDArray[Any], ...]:
    points = pose.transform_points(np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1))
    return tuple(points[:, k].reshape(x.shape) for k in range(3))


def draw_obstacles(ax: Any, obstacles: Sequence[Obstacle], alpha: float = 0.25) -> None:
    """Draw each obstacle on a 3D axes (``projection="3d"``) in its own colour, labelled by id."""
    for index, obstacle in enumerate(obstacles):
        colour = _COLOURS[index % len(_COLOURS)]
        shape, pose = obstacle.shape, obstacle.pose
        if isinstance(shape, Box):
            faces = _box_faces(shape.length, shape.width, shape.height)
            world = pose.transform_points(faces.reshape(-1, 3)).reshape(faces.shape)
            ax.add_collection3d(Poly3DCollection(world, facecolor=colour, edgecolor="k", linewidths=0.3, alpha=alpha))
        elif isinstance(shape, Mesh):
            triangles = pose.transform_points(shape.data.triangles.reshape(-1, 3)).reshape(-1, 3, 3)
            ax.add_collection3d(Poly3DCollection(triangles, facecolor=colour, edgecolor="k", linewidths=0.1,
                                                 alpha=alpha))
        else:
            if isinstance(shape, Sphere):
                local = _ellipsoid_surface(shape.radius, shape.radius, shape.radius)
            elif isinstance(shape, Ellipsoid):
                local = _ellipsoid_surface(shape.semi_x, shape.semi_y, shape.semi_z)
            elif isinstance(shape, Cylinder):
                local = _cylinder_surface(shape.radius, shape.height)
            elif isinstance(shape, Capsule):
                local = _capsule_surface(shape.radius, shape.height)
            else:  # pragma: no cover - Obstacle validates its shape
                continue
            ax.plot_surface(*_to_world(pose, *local), color=colour, alpha=alpha, linewidth=0)
        ax.text(*pose.position, obstacle.id, fontsize=7)


def _set_equal_box(ax: Any, points: NDArray[Any]) -> None:
    lower, upper = points.min(axis=0), points.max(axis=0)
    centre, half = (lower + upper) / 2, max(float(np.max(upper - lower)) / 2, 1e-3)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))


def plot_path_3d(
    path: PlannedPath, obstacles: Sequence[Obstacle] = (), goal: Pose | None = None, title: str = ""
) -> Figure:
    """A figure with the 3D path among the obstacles (left) and speed and clearance over time (right)."""
    if not isinstance(path, PlannedPath):
        raise InvalidInput("path", type(path).__name__, "expected a pfield.PlannedPath")
    for index, obstacle in enumerate(obstacles):
        if not isinstance(obstacle, Obstacle):
            raise InvalidInput(f"obstacles[{index}]", type(obstacle).__name__, "expected a pfield.Obstacle")
    if goal is not None and not isinstance(goal, Pose):
        raise InvalidInput("goal", goal, "expected a pfield.Pose or None")
    figure = Figure(figsize=(12, 5.5), layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot(1, 2, 1, projection="3d")
    draw_obstacles(ax, obstacles)
    positions = path.positions
    ax.plot(*positions.T, color="tab:blue", linewidth=2.5, label="path", zorder=10)
    ax.scatter(*positions[0], color="tab:green", s=40, label="start")
    extent = [positions]
    if goal is not None:
        ax.scatter(*goal.position, color="tab:red", marker="*", s=120, label="goal")
        extent.append(goal.position[None, :])
    extent += [o.pose.position + np.array([[-1.0], [1.0]]) * o.bounding_radius() for o in obstacles]
    _set_equal_box(ax, np.concatenate(extent))
    ax.view_init(elev=22, azim=-120)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.legend(loc="upper left", fontsize=8)
    status = "reached the goal" if path.success else path.failure_reason
    ax.set_title(title or f"task-space plan: {status}", fontsize=9)
    _plot_profiles(figure.add_subplot(1, 2, 2), path)
    return figure


def _plot_profiles(ax: Any, path: PlannedPath) -> None:
    speed = np.linalg.norm(path.twists[:, :3], axis=1)
    ax.plot(path.times, speed, color="tab:blue", label="linear speed (m/s)")
    ax.plot(path.times, np.linalg.norm(path.twists[:, 3:], axis=1), color="tab:purple",
            label="angular speed (rad/s)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("speed")
    if np.any(np.isfinite(path.clearances)):
        other = ax.twinx()
        other.plot(path.times, path.clearances, color="tab:red", label="clearance (m)")
        other.set_ylabel("clearance to the nearest obstacle (m)", color="tab:red")
        other.set_ylim(bottom=0.0)
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)


def save_path_plot(
    path: PlannedPath, file: str | Path, obstacles: Sequence[Obstacle] = (), goal: Pose | None = None,
    title: str = "",
) -> Path:
    """Write :func:`plot_path_3d` as a PNG (150 dpi); return the file path."""
    figure = plot_path_3d(path, obstacles, goal, title)
    target = Path(file)
    target.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(target, dpi=150)
    return target
