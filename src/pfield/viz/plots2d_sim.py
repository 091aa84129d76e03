"""Pictures of a 2D simulation run: a PNG of the whole run and an animated GIF (matplotlib + Pillow).

The static parts (field image for point-obstacle scenarios, walls and circles, goal) are drawn once by
matplotlib; each GIF frame then draws the robot, its path so far and the obstacle points it senses with
Pillow onto a copy of that background, using the axes' data→pixel transform.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Polygon
from numpy.typing import NDArray
from PIL import Image, ImageDraw

from pfield.mobile.sim import SimResult
from pfield.viz.plots2d import plot_field

__all__ = ["render_gif", "render_png"]

FrameProgress = Callable[[int, int], None]


def _draw_world(ax: Axes, result: SimResult, trajectory: bool) -> None:
    scenario = result.scenario
    if scenario.sensor == "points":
        plot_field(ax, scenario.params, scenario.goal, scenario.world.points, scenario.extent,
                   trajectory=result.poses if trajectory else None)
    else:
        xmin, xmax, ymin, ymax = scenario.extent
        ax.set(xlim=(xmin, xmax), ylim=(ymin, ymax), xlabel="x (m)", ylabel="y (m)", aspect="equal")
        ax.plot(*scenario.goal, "*", color="gold", ms=16, mec="k", label="goal")
        if trajectory:
            ax.plot(result.poses[:, 0], result.poses[:, 1], "-", color="tab:orange", lw=2, label="trajectory")
            sensed = result.sensed[-1]
            ax.plot(sensed[:, 0], sensed[:, 1], ".", color="tab:red", ms=4, label="last scan (sector points)")
        ax.legend(loc="upper left", fontsize=7)
        ax.grid(alpha=0.3)
    for poly in scenario.world.polygons:
        ax.add_patch(Polygon(poly, closed=True, color="0.35"))
    for cx, cy, r in scenario.world.circles:
        ax.add_patch(Circle((cx, cy), r, color="0.35"))
    x, y, _ = scenario.start
    ax.add_patch(Circle((x, y), scenario.robot_radius, fill=False, color="tab:orange", lw=1.5))


def _figure(result: SimResult, trajectory: bool) -> tuple[Figure, Axes]:
    fig = Figure(figsize=(7.0, 6.0), layout="constrained")
    ax = fig.subplots()
    _draw_world(ax, result, trajectory)
    scenario = result.scenario
    ax.set_title(f"{scenario.name} ({scenario.config.drive}): {result.outcome} after {result.times[-1]:.1f} s, "
                 f"min clearance {result.min_clearance:.2f} m", fontsize=9)
    return fig, ax


def render_png(result: SimResult, path: Path) -> Path:
    """The whole run (field or walls, trajectory, goal) as one PNG."""
    fig, _ = _figure(result, trajectory=True)
    fig.savefig(path, dpi=110)
    return path


def _to_pixels(ax: Axes, height: int, xy: NDArray[np.float64]) -> NDArray[np.float64]:
    display = ax.transData.transform(np.asarray(xy, dtype=float).reshape(-1, 2))
    display[:, 1] = height - display[:, 1]
    return display


def _frame(background: Image.Image, ax: Axes, result: SimResult, k: int, scale: float) -> Image.Image:
    image = background.copy()
    draw = ImageDraw.Draw(image)
    height = image.height
    path = _to_pixels(ax, height, result.poses[: k + 1, :2])
    if len(path) > 1:
        draw.line([tuple(p) for p in path], fill=(255, 140, 0), width=3)
    for px, py in _to_pixels(ax, height, result.sensed[k]):
        draw.ellipse([px - 2, py - 2, px + 2, py + 2], fill=(220, 30, 30))
    x, y, yaw = result.poses[k]
    cx, cy = _to_pixels(ax, height, np.array([x, y]))[0]
    radius = result.scenario.robot_radius * scale
    draw.ellipse([cx - radius, cy - radius, cx + radius, cy + radius], outline=(0, 0, 0), fill=(255, 170, 60),
                 width=2)
    hx, hy = _to_pixels(ax, height, np.array([x + 1.4 * result.scenario.robot_radius * math.cos(yaw),
                                              y + 1.4 * result.scenario.robot_radius * math.sin(yaw)]))[0]
    draw.line([(cx, cy), (hx, hy)], fill=(0, 0, 0), width=3)
    draw.text((10, 10), f"t = {result.times[k]:5.1f} s  {result.states[k]}", fill=(0, 0, 0))
    return image


def render_gif(result: SimResult, path: Path, max_frames: int = 80, frame_ms: int = 80,
               progress: FrameProgress | None = None) -> Path:
    """Animated GIF of the run: at most ``max_frames`` evenly spaced frames, the last one included."""
    fig, ax = _figure(result, trajectory=False)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    background = Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy())
    origin, unit = _to_pixels(ax, background.height, np.array([[0.0, 0.0], [1.0, 0.0]]))
    scale = float(np.hypot(*(unit - origin)))
    indices = np.unique(np.linspace(0, len(result.times) - 1, min(max_frames, len(result.times))).astype(int))
    # one shared palette (from the background plus the drawing colours) keeps frames small and flicker-free
    palette = _frame(background, ax, result, int(indices[-1]), scale).quantize(colors=128)
    frames = []
    for n, k in enumerate(indices):
        frames.append(_frame(background, ax, result, int(k), scale).quantize(palette=palette,
                                                                              dither=Image.Dither.NONE))
        if progress is not None:
            progress(n + 1, len(indices))
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=frame_ms, loop=0, optimize=True)
    return path
