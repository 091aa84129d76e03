"""Headless matplotlib figures of 3D scenes: obstacles, planned paths and their clearance.

Every function builds a :class:`matplotlib.figure.Figure` with the object API (no pyplot state, no
display needed) so it works in tests, servers and CI. Obstacles are drawn from their exact shape
parameters (DESIGN §2) in the world frame; meshes from their (scaled) triangles. Axes share one scale
(1 cm is as long on x, y and z), the limits hold every obstacle, obstacle ids are in the legend (never on
top of each other in the scene), and paths show the tool orientation as x/y/z triads.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection
from numpy.typing import ArrayLike, NDArray

from pfield.errors import InvalidInput
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, Sphere
from pfield.planning.result import PlannedPath
from pfield.spatial import Pose, matrix_from_quaternion

__all__ = ["LEGEND_OBSTACLES", "TRIADS", "draw_frames", "draw_obstacles", "obstacle_bounds", "plot_path_3d",
           "save_path_plot", "set_equal_box"]

TRIADS = 8
"""About this many orientation triads are drawn along a 3D path (plus the last waypoint and the goal)."""

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


def _obstacle_geometry(obstacle: Obstacle) -> tuple[str, Any]:
    """World geometry to draw: ``("faces", (F, k, 3))`` polygons or ``("surface", (X, Y, Z))`` grids."""
    shape, pose = obstacle.shape, obstacle.pose
    if isinstance(shape, Box):
        faces = _box_faces(shape.length, shape.width, shape.height)
        return "faces", pose.transform_points(faces.reshape(-1, 3)).reshape(faces.shape)
    if isinstance(shape, Mesh):
        return "faces", pose.transform_points(shape.data.triangles.reshape(-1, 3)).reshape(-1, 3, 3)
    if isinstance(shape, Sphere):
        local = _ellipsoid_surface(shape.radius, shape.radius, shape.radius)
    elif isinstance(shape, Ellipsoid):
        local = _ellipsoid_surface(shape.semi_x, shape.semi_y, shape.semi_z)
    elif isinstance(shape, Cylinder):
        local = _cylinder_surface(shape.radius, shape.height)
    elif isinstance(shape, Capsule):
        local = _capsule_surface(shape.radius, shape.height)
    else:
        raise TypeError(f"no picture for obstacle shape {type(shape).__name__}")
    return "surface", _to_world(pose, *local)


def _geometry_points(kind: str, geometry: Any) -> NDArray[Any]:
    if kind == "faces":
        return np.asarray(geometry).reshape(-1, 3)
    return np.stack([np.ravel(c) for c in geometry], axis=1)


def obstacle_bounds(obstacles: Sequence[Obstacle]) -> NDArray[np.float64]:
    """(2, 3) lower and upper corners of the drawn obstacles (world frame, m); (0, 3) without obstacles."""
    points = [_geometry_points(*_obstacle_geometry(o)) for o in obstacles]
    if not points:
        return np.zeros((0, 3))
    cloud = np.concatenate(points)
    return np.stack([cloud.min(axis=0), cloud.max(axis=0)])


LEGEND_OBSTACLES = 12
"""Obstacles are listed by id in the legend up to this many; more become one "N obstacles" entry."""


def draw_obstacles(ax: Any, obstacles: Sequence[Obstacle], alpha: float = 0.25) -> list[Patch]:
    """Draw each obstacle on a 3D axes (``projection="3d"``) in its own colour.

    Returns legend handles naming each obstacle by id in its colour (one entry for more than
    :data:`LEGEND_OBSTACLES`), so the ids never overlap in the scene; add them to the axes' legend.
    """
    handles = []
    for index, obstacle in enumerate(obstacles):
        colour = _COLOURS[index % len(_COLOURS)]
        kind, geometry = _obstacle_geometry(obstacle)
        if kind == "faces":
            edge = 0.1 if isinstance(obstacle.shape, Mesh) else 0.3
            ax.add_collection3d(Poly3DCollection(geometry, facecolor=colour, edgecolor="k", linewidths=edge,
                                                 alpha=alpha))
        else:
            ax.plot_surface(*geometry, color=colour, alpha=alpha, linewidth=0)
        handles.append(Patch(facecolor=colour, edgecolor="k", linewidth=0.3, alpha=min(1.0, 2 * alpha),
                             label=f"{obstacle.id} ({obstacle.shape.type_name})"))
    if len(handles) > LEGEND_OBSTACLES:
        return [Patch(facecolor=_COLOURS[0], alpha=min(1.0, 2 * alpha), label=f"{len(handles)} obstacles")]
    return handles


def draw_frames(ax: Any, positions: ArrayLike, orientations: ArrayLike, length: float,
                label: str | None = "orientation (x red, y green, z blue)") -> None:
    """Orientation triads: the x, y and z axes of each pose, ``length`` m long, in red, green and blue (RViz's
    axis colours). ``orientations`` are (x, y, z, w) quaternions."""
    origins = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    quaternions = np.asarray(orientations, dtype=np.float64).reshape(-1, 4)
    rotations = np.asarray(matrix_from_quaternion(quaternions)).reshape(-1, 3, 3)
    for axis, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
        ends = origins + length * rotations[:, :, axis]
        segments = np.stack([origins, ends], axis=1)
        ax.add_collection3d(Line3DCollection(segments, colors=colour, linewidths=1.6))
    if label:
        ax.plot([], [], color="tab:red", linewidth=1.6, label=label)


def set_equal_box(ax: Any, points: ArrayLike, margin: float = 0.02) -> None:
    """Axis limits around ``points`` (N, 3) with one scale on every axis: the box aspect follows the ranges,
    so 1 cm is as long along x, y and z (spheres look round, capsules have their real radius)."""
    cloud = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    lower, upper = cloud.min(axis=0) - margin, cloud.max(axis=0) + margin
    span = np.maximum(upper - lower, 1e-3)
    ax.set_xlim(lower[0], lower[0] + span[0])
    ax.set_ylim(lower[1], lower[1] + span[1])
    ax.set_zlim(lower[2], lower[2] + span[2])
    ax.set_box_aspect(tuple(span))


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
    figure = Figure(figsize=(12.5, 6), layout="constrained")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot(1, 2, 1, projection="3d")
    handles = draw_obstacles(ax, obstacles)
    positions = path.positions
    ax.computed_zorder = False  # drawn in this order: obstacles, path, triads, then the start and goal markers
    ax.plot(*positions.T, color="black", linewidth=2.0, label="path", zorder=10)
    extent = [positions, obstacle_bounds(obstacles)]
    if goal is not None:
        extent.append(goal.position[None, :])
    cloud = np.concatenate(extent)
    size = float(np.max(np.ptp(cloud, axis=0)))
    every = max(1, round((len(path) - 1) / TRIADS)) if len(path) > 1 else 1
    shown = np.unique(np.r_[np.arange(0, len(path), every), len(path) - 1])
    if goal is not None and len(shown) > 1:  # the goal's own triad stands at the end: no second one under it
        shown = shown[:-1]
    draw_frames(ax, positions[shown], path.orientations[shown], 0.06 * size,
                f"orientation every {every} waypoints (x red, y green, z blue)")
    ax.scatter(*positions[0], color="tab:green", s=60, edgecolors="k", depthshade=False, label="start", zorder=30)
    if goal is not None:
        draw_frames(ax, goal.position, goal.orientation, 0.09 * size, label=None)
        ax.scatter(*goal.position, color="gold", marker="*", s=320, edgecolors="k", linewidths=0.8,
                   depthshade=False, label="goal", zorder=31)
    set_equal_box(ax, cloud)
    ax.view_init(elev=22, azim=-120)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    lines, _ = ax.get_legend_handles_labels()
    figure.legend(handles=[*lines, *handles], loc="outside lower center", ncols=4, fontsize=8, frameon=False)
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
