"""``pfield find-valid-pose`` (one-shot FindValidPose with a PNG) and the ``/costmap`` node of ``pfield serve``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer
import yaml

from pfield.cli._node import ServeContext, load_ros_parameters, register_node_factory
from pfield.errors import PfieldError
from pfield.node._base import Bus, Node

__all__ = ["register", "run_find_valid_pose"]


def _serve_costmap(context: ServeContext) -> list[Node]:
    """``pfield serve`` serves ``/costmap`` (``/pfield/find_valid_pose``), with ``--map``/``--footprint`` applied."""
    from pfield.node.costmap_server import costmap_node_from_options

    return [costmap_node_from_options(context.bus, context.map_file, context.footprint)]


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


def register(app: typer.Typer) -> None:
    """Add ``find-valid-pose`` to ``app`` and the ``/costmap`` node to ``pfield serve``."""
    register_node_factory(_serve_costmap)

    @app.command("find-valid-pose")
    def find_valid_pose(
        x: Annotated[float, typer.Option(help="requested x (m, map frame)")],
        y: Annotated[float, typer.Option(help="requested y (m, map frame)")],
        yaw: Annotated[float, typer.Option(help="requested heading (rad)")] = 0.0,
        map_file: Annotated[Path | None, typer.Option("--map", help="map_server YAML (default: the shipped "
                                                      "example map)")] = None,
        dist_tolerance: Annotated[float, typer.Option(help="search radius (m)")] = 0.5,
        angle_tolerance: Annotated[float, typer.Option(help="yaw search range ± (rad)")] = math.pi / 4,
        safety_dist: Annotated[float, typer.Option(help="extra footprint padding (m)")] = 0.0,
        use_padded_fp: Annotated[bool, typer.Option(help="include footprint_padding")] = False,
        footprint: Annotated[str | None, typer.Option(help="nav2 footprint '[\\[x, y], ...]'")] = None,
        params: Annotated[Path | None, typer.Option(help="ROS 2 parameters YAML (section costmap)")] = None,
        output: Annotated[Path, typer.Option("--output", "-o", help="PNG to write")] = Path("find_valid_pose.png"),
    ) -> None:
        """Find the closest valid pose for a footprint on a map (FindValidPose) and draw the search."""
        from pfield.costmap._example import example_map_path

        try:
            values = (load_ros_parameters(params).get("/costmap", {}) if params else {})
            if footprint:
                values["footprint"] = footprint
            request = {"dist_tolerance": dist_tolerance, "angle_tolerance": angle_tolerance,
                       "safety_dist": safety_dist, "use_padded_fp": use_padded_fp}
            answer, png = run_find_valid_pose(map_file or example_map_path(), (x, y, yaw), request, values, output)
        except PfieldError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2) from None
        typer.echo(yaml.safe_dump(answer, sort_keys=False).rstrip())
        typer.echo(f"wrote {png}", err=True)
