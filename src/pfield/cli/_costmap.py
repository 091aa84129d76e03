"""``pfield find-valid-pose`` (one-shot FindValidPose with a PNG) and the ``/costmap`` node of ``pfield serve``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from pfield.cli._exit_codes import FAILED, USAGE
from pfield.cli._node import ServeContext, load_ros_parameters, register_node_factory
from pfield.errors import PfieldError

if TYPE_CHECKING:
    from pfield.node import Node

__all__ = ["register"]


def _serve_costmap(context: ServeContext) -> list[Node]:
    """``pfield serve`` serves ``/costmap`` (``/pfield/find_valid_pose``), with ``--map``/``--footprint`` applied."""
    from pfield.node.costmap_server import costmap_node_from_options

    return [costmap_node_from_options(context.bus, context.map_file, context.footprint)]


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
        """Find the closest valid pose for a footprint on a map (FindValidPose) and draw the search.

        Exit status 1 when no pose was found (state LETHAL), 2 for bad options or files."""
        import yaml

        from pfield._files import check_picture
        from pfield._validation import finite
        from pfield.costmap import PoseState, example_map_path
        from pfield.demo.tools import run_find_valid_pose

        try:
            check_picture("--output", output)
            finite("--yaw", yaw)
            values = (load_ros_parameters(params).get("/costmap", {}) if params else {})
            if footprint:
                values["footprint"] = footprint
            request = {"dist_tolerance": dist_tolerance, "angle_tolerance": angle_tolerance,
                       "safety_dist": safety_dist, "use_padded_fp": use_padded_fp}
            answer, png = run_find_valid_pose(map_file or example_map_path(), (x, y, yaw), request, values, output)
        except PfieldError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(USAGE) from None
        typer.echo(yaml.safe_dump(answer, sort_keys=False).rstrip())
        typer.echo(f"wrote {png}", err=True)
        if answer["state"] == PoseState.LETHAL:  # FindValidPose's "no pose": the search found none
            raise typer.Exit(FAILED)
