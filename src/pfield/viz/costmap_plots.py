"""Pictures of costmaps and FindValidPose searches (matplotlib object API, headless, no pyplot state).

:func:`plot_find_valid_pose` draws the costmap (white free, blue inflation fading out with distance, whose
cost values the colour bar gives, violet inscribed, black lethal, grey unknown, and red hatching where the map
ends, so cells outside the map never look like free space), the candidate positions the search tried (coloured
by the best state found there; pink: ruled out once a fallback answer was known), the requested footprint
(dashed red) and the answer's footprint (green) with heading arrows.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.cm import ScalarMappable
from matplotlib.colors import ListedColormap, Normalize, to_hex
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle
from matplotlib.patches import Polygon as PolygonPatch

from pfield.costmap import Costmap2D, Footprint, PoseState, ValidPoseResult
from pfield.spatial import Pose

__all__ = ["add_cost_colorbar", "cost_legend_handles", "costmap_colormap", "plot_costmap", "plot_find_valid_pose",
           "plot_footprint"]

_OUTSIDE_FACE, _OUTSIDE_HATCH = "#fbe3e3", "#d62728"
"""Cells outside the map: the axes' background, hatched in red."""

_STATE_COLOURS = {PoseState.FREE: "#2ca02c", PoseState.INSCRIBED: "#bcbd22", PoseState.UNKNOWN: "#17becf",
                  PoseState.OUTSIDE: "#ff7f0e", PoseState.LETHAL: "#d62728"}
_PREFERENCE = (PoseState.FREE, PoseState.INSCRIBED, PoseState.UNKNOWN, PoseState.OUTSIDE, PoseState.LETHAL)
_REJECTED_COLOUR = "#e377c2"  # neither FREE nor INSCRIBED, not examined further (a fallback was known)


def costmap_colormap() -> ListedColormap:
    """256 colours indexed by cost value."""
    colours = np.ones((256, 4))
    fade = np.linspace(0.0, 1.0, 252)[:, None]
    colours[1:253, :3] = (1.0 - fade) * np.array([0.85, 0.92, 1.0]) + fade * np.array([0.25, 0.4, 0.85])
    colours[253, :3] = (0.55, 0.3, 0.75)
    colours[254, :3] = (0.0, 0.0, 0.0)
    colours[255, :3] = (0.6, 0.6, 0.6)
    return ListedColormap(colours)


def plot_costmap(ax: Axes, costmap: Costmap2D) -> None:
    """The costmap in map-frame metres (row 0 at the bottom); everything beyond the map is hatched red."""
    extent = (costmap.origin_x, costmap.origin_x + costmap.size_x * costmap.resolution,
              costmap.origin_y, costmap.origin_y + costmap.size_y * costmap.resolution)
    # A huge hatched rectangle behind the image: whatever of it shows is outside the map.
    ax.add_patch(Rectangle((extent[0] - 1e4, extent[2] - 1e4), 2e4 + extent[1] - extent[0], 2e4 + extent[3] - extent[2],
                           zorder=-10, facecolor=_OUTSIDE_FACE, edgecolor=_OUTSIDE_HATCH, hatch="///",
                           linewidth=0.0))
    ax.imshow(costmap.costs, origin="lower", extent=extent, cmap=costmap_colormap(), vmin=0, vmax=255,
              interpolation="nearest", zorder=0)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")


def cost_legend_handles() -> list[Patch]:
    """Legend entries of the special cost values (nav2's) and of the cells outside the map."""
    colours = [to_hex(row) for row in np.asarray(costmap_colormap().colors)]
    return [Patch(facecolor=colours[0], edgecolor="0.5", label="FREE (0)"),
            Patch(facecolor=colours[253], label="INSCRIBED (253)"),
            Patch(facecolor=colours[254], label="LETHAL (254)"),
            Patch(facecolor=colours[255], label="NO_INFORMATION (255)"),
            Patch(facecolor=_OUTSIDE_FACE, edgecolor=_OUTSIDE_HATCH, hatch="///", linewidth=0.0,
                  label="outside the map")]


def add_cost_colorbar(figure: Figure, ax: Axes) -> None:
    """A colour bar of the inflation costs 1–252 (they fall off exponentially with the distance to the
    nearest lethal cell beyond the inscribed radius)."""
    colours = np.asarray(costmap_colormap().colors)[1:253]
    mappable = ScalarMappable(norm=Normalize(1, 252), cmap=ListedColormap(colours))
    bar = figure.colorbar(mappable, ax=ax, fraction=0.04, pad=0.02)
    bar.set_label("inflation cost (1–252)")
    bar.set_ticks([1, 50, 100, 150, 200, 252])


def plot_footprint(ax: Axes, footprint: Footprint, pose: Pose, colour: str, linestyle: str = "-",
                   label: str | None = None) -> None:
    """The footprint outline at ``pose`` and an arrow along its heading."""
    x, y, yaw = float(pose.position[0]), float(pose.position[1]), pose.yaw
    ax.add_patch(PolygonPatch(footprint.posed(x, y, yaw), closed=True, fill=False, edgecolor=colour,
                              linestyle=linestyle, linewidth=2.0, label=label, zorder=5))
    length = 0.8 * footprint.circumscribed_radius
    ax.arrow(x, y, length * math.cos(yaw), length * math.sin(yaw), color=colour, width=0.01,
             length_includes_head=True, head_width=0.08, zorder=5)


def _tried(result: ValidPoseResult) -> tuple[np.ndarray, list[str]]:
    """Positions with at least one evaluated candidate and the colour of the best state found there."""
    states = result.trace.states
    evaluated = (states != 255).any(axis=1)
    colours = []
    for row in states[evaluated]:
        present = {int(s) for s in row}
        best = next((s for s in _PREFERENCE if int(s) in present), None)
        colours.append(_STATE_COLOURS[best] if best is not None else _REJECTED_COLOUR)
    return result.trace.positions[evaluated], colours


def plot_find_valid_pose(costmap: Costmap2D, footprint: Footprint, request: Pose, result: ValidPoseResult,
                         path: Path, title: str = "FindValidPose", margin: float = 1.0) -> Path:
    """Write a PNG of one search (see the module docstring); zoomed on the searched area ± ``margin`` m."""
    fig = Figure(figsize=(8.5, 7.5), layout="constrained")
    ax = fig.subplots()
    plot_costmap(ax, costmap)
    add_cost_colorbar(fig, ax)
    positions, colours = _tried(result)
    if len(positions):
        ax.scatter(positions[:, 0], positions[:, 1], s=6, c=colours, zorder=3)
    plot_footprint(ax, footprint, request, "#d62728", "--", "requested")
    if result.pose is not None:
        plot_footprint(ax, footprint, result.pose, "#2ca02c", "-", f"answer: {result.state.name}")
    reach = margin + footprint.circumscribed_radius + (float(np.abs(result.trace.positions - request.position[:2])
                                                             .max()) if len(result.trace.positions) else 0.0)
    ax.set_xlim(request.position[0] - reach, request.position[0] + reach)
    ax.set_ylim(request.position[1] - reach, request.position[1] + reach)
    handles, _ = ax.get_legend_handles_labels()
    handles += [Patch(color=c, label=f"tried: best {s.name}") for s, c in _STATE_COLOURS.items()]
    handles.append(Patch(color=_REJECTED_COLOUR, label="tried: not FREE/INSCRIBED (fallback known)"))
    ax.legend(handles=handles, loc="upper left", fontsize=7, framealpha=0.85)
    fig.legend(handles=cost_legend_handles(), loc="outside lower center", ncols=5, fontsize=8, frameon=False)
    summary = f"state {result.state.name}, cost {result.cost}"
    if result.distance is not None and result.yaw_offset is not None:
        summary += f", moved {result.distance:.2f} m, turned {math.degrees(result.yaw_offset):.0f}°"
    ax.set_title(f"{title}\n{summary}; {result.trace.evaluated} candidates evaluated", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path
