"""``pfield ros2 node``: serve pfield's nodes as a ROS 2 node (rclpy) instead of over HTTP.

Builds exactly the nodes ``pfield serve`` builds (the manager, plus the base controller and costmap
server when their options are given), with the same options and the same ``ros__parameters`` YAML, and
hands them to :mod:`pfield.transport.ros2`. Arguments after ``--ros-args`` go to rclpy unchanged
(``-p name:=value``, ``-r __ns:=/robot1``, ``--params-file``). Needs the ``ros2`` extra and the built
interface package (docs/ros2.md).
"""

from __future__ import annotations

import importlib.util
import logging
from pathlib import Path
from typing import Annotated

import typer

from pfield.errors import PfieldError

__all__ = ["register"]

ros2_app = typer.Typer(name="ros2", help="Run pfield inside ROS 2 (rclpy; needs the ros2 extra).",
                       no_args_is_help=True)

_MISSING = {
    "rclpy": "rclpy is not installed: pip install 'pfield[ros2]' (ROS 2 Jazzy wheels, x86_64 Linux)",
    "potential_fields_interfaces": "the interface package is not built: run `make ros2-interfaces`, or "
                                   "pip install ./ros/potential_fields_interfaces (docs/ros2.md)",
}


def _check_ros2() -> None:
    for module, advice in _MISSING.items():
        if importlib.util.find_spec(module) is None:
            typer.echo(f"error: {advice}", err=True)
            raise typer.Exit(2)


@ros2_app.command(context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def node(
    ctx: typer.Context,
    robot: Annotated[str, typer.Option(help="xarm7, panda or a URDF file")] = "xarm7",
    end_effector: Annotated[str | None, typer.Option(help="end-effector link of a URDF robot")] = None,
    params: Annotated[Path | None, typer.Option(help="ROS 2 parameters YAML (node: ros__parameters: ...)")] = None,
    package_path: Annotated[list[str] | None, typer.Option(help="NAME=DIR for package:// URIs (repeatable)")] = None,
    mesh_root: Annotated[list[Path] | None, typer.Option(help="directory meshes may be read from (repeatable)")]
    = None,
    map: Annotated[Path | None, typer.Option(help="map_server YAML for the costmap node")] = None,
    footprint: Annotated[str | None, typer.Option(help="nav2 footprint polygon string for the costmap")] = None,
    csv_dir: Annotated[Path | None, typer.Option(help="save every planned path as CSV here")] = None,
    log_level: Annotated[str, typer.Option(help="debug, info, warning or error")] = "info",
) -> None:
    """Serve /pfield_manager (and the other configured nodes) over ROS 2 until Ctrl-C.

    Example: pfield ros2 node --params pfield.yaml --package-path my_robot_description=./desc
    --ros-args -p influence_distance:=0.15
    """
    from pfield.cli._node import ServeContext, build_nodes, load_robot, load_ros_parameters, parse_package_paths
    from pfield.node._base import Bus

    logging.basicConfig(level=log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    _check_ros2()
    try:
        packages = parse_package_paths(package_path or [])
        parameters = load_ros_parameters(params) if params else {}
        context = ServeContext(Bus(), load_robot(robot, end_effector, packages), packages,
                               [p.resolve() for p in mesh_root or []], map, footprint)
        nodes = build_nodes(context, parameters, csv_dir)
    except PfieldError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    from pfield.transport.ros2 import run

    typer.echo(f"pfield ROS 2 nodes: {', '.join(n.name for n in nodes)} (Ctrl-C stops)", err=True)
    try:
        run(nodes, args=list(ctx.args))
    except PfieldError as exc:  # a bad --ros-args parameter value
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    finally:
        for pfield_node in nodes:
            pfield_node.close()


def register(app: typer.Typer) -> None:
    """Add the ``ros2`` command group to ``app``."""
    app.add_typer(ros2_app, name="ros2")
