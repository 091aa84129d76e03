"""Runs that both ``pfield`` commands and the built-in demo perform: one FindValidPose on a map with its
picture (``pfield find-valid-pose``, the costmap section) and one simulated 2D scenario with its pictures
(``pfield sim2d``, the mobile section).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from pfield.node import Bus

if TYPE_CHECKING:
    from pfield.mobile.sim import SimResult

__all__ = ["run_find_valid_pose", "run_sim2d"]


def run_find_valid_pose(map_path: Path, pose: tuple[float, float, float], request: dict[str, Any],
                        parameters: dict[str, Any], output: Path | None) -> tuple[dict[str, Any], Path | None]:
    """Answer one request on a map with a fresh ``/costmap`` node; return (response as data, PNG path)."""
    from pfield.costmap import PoseState
    from pfield.interfaces.potential_fields_interfaces import FindValidPose_Request
    from pfield.node.costmap_server import costmap_node_from_options
    from pfield.spatial import Pose
    from pfield.viz.costmap_plots import plot_find_valid_pose

    node = costmap_node_from_options(Bus(), map_path, None, parameters)
    x, y, yaw = pose
    body = {"pose": {"header": {"frame_id": node.params.global_frame},
                     "pose": {"position": {"x": x, "y": y},
                              "orientation": {"z": math.sin(0.5 * yaw), "w": math.cos(0.5 * yaw)}}},
            "costmap": 2} | request
    response = node.on_find_valid_pose(FindValidPose_Request.model_validate(body))
    result, costmap = node.last_result, node.costmap
    png = None
    if output is not None and result is not None and costmap is not None:
        params = node.params
        footprint = params.padded_footprint() if request.get("use_padded_fp") else params.robot_footprint()
        footprint = footprint.padded(float(request.get("safety_dist", 0.0)))
        png = plot_find_valid_pose(costmap, footprint, Pose.planar(x, y, yaw), result, output,
                                   title=f"FindValidPose on {map_path.name}")
    answer = response.model_dump(mode="json")
    answer["state_name"] = PoseState(response.state).name
    return answer, png


def _progress(console: Console) -> Progress:
    return Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TextColumn("{task.fields[note]}"), TimeElapsedColumn(), console=console, transient=True)


def run_sim2d(scenario_name: str, output_dir: Path, drive: str | None, gif: bool, console: Console) -> SimResult:
    """Simulate one scenario with a progress bar, write its PNG (and GIF); return the run."""
    from pfield.mobile.scenarios import load_scenario
    from pfield.mobile.sim import simulate
    from pfield.viz.plots2d_sim import render_gif, render_png

    scenario = load_scenario(scenario_name)
    if drive is not None:
        scenario = scenario.with_drive(drive)
    output_dir.mkdir(parents=True, exist_ok=True)
    stem = output_dir / f"sim2d_{scenario.name}_{scenario.config.drive}"
    steps = round(scenario.duration * scenario.rate)
    with _progress(console) as progress:
        task = progress.add_task(f"simulating {scenario.name}", total=steps, note="")
        result = simulate(scenario, lambda t, _: progress.update(
            task, completed=round(t * scenario.rate) + 1, note=f"t = {t:5.1f} s"))
        progress.update(task, completed=steps)
        png = render_png(result, stem.with_suffix(".png"))
        if gif:
            frames = progress.add_task("rendering GIF", total=None, note="")
            render_gif(result, stem.with_suffix(".gif"),
                       progress=lambda n, total: progress.update(frames, completed=n, total=total))
    console.print(f"[bold]{scenario.name}[/bold] ({scenario.config.drive}): [bold]{result.outcome}[/bold] after "
                  f"{result.times[-1]:.1f} s, {result.final_distance_to_goal:.2f} m from the goal, min clearance "
                  f"{result.min_clearance:.2f} m (expected: {scenario.expected})")
    console.print(f"wrote {png}" + (f" and {stem.with_suffix('.gif')}" if gif else ""))
    return result
