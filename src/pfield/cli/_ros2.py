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

import typer

from pfield.cli._node import (
    CsvDirOption,
    FootprintOption,
    LogLevel,
    LogLevelOption,
    MapOption,
    MeshRootOption,
    ParamsOption,
    StaticTransformOption,
    cli_errors,
    nodes_from_options,
    stopped_quietly,
)
from pfield.cli._robot_options import (
    EndEffectorOption,
    LockedJointOption,
    PackagePathOption,
    RobotOption,
    SrdfOption,
    robot_description,
)
from pfield.errors import InvalidInput

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


def ros_arguments(ctx: typer.Context) -> list[str]:
    """The arguments after ``--ros-args`` that a ROS 2 command passes to rclpy; anything else it was not given as one
    of its own options is refused (a misspelled ``--params`` would otherwise be handed to rclpy, which ignores it,
    and the node would start without the parameters)."""
    extra = list(ctx.args)
    if extra and extra[0] != "--ros-args":
        raise InvalidInput("argument", extra[0], f"not an option of {ctx.command_path} (see --help); ROS 2 "
                                                 f"arguments go after --ros-args, e.g. --ros-args -p name:=value")
    return extra


@ros2_app.command(context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def node(
    ctx: typer.Context,
    robot: RobotOption = "xarm7",
    srdf: SrdfOption = None,
    end_effector: EndEffectorOption = None,
    package_path: PackagePathOption = None,
    locked_joint: LockedJointOption = None,
    params: ParamsOption = None,
    mesh_root: MeshRootOption = None,
    map: MapOption = None,
    footprint: FootprintOption = None,
    static_transform: StaticTransformOption = None,
    csv_dir: CsvDirOption = None,
    log_level: LogLevelOption = LogLevel.info,
) -> None:
    """Serve /pfield_manager (and the other configured nodes) over ROS 2 until Ctrl-C.

    Example: pfield ros2 node --robot ur5.urdf --srdf ur5.srdf --end-effector tool0 --package-path meshes=./meshes
    --params pfield.yaml --ros-args -p influence_distance:=0.15
    """
    logging.basicConfig(level=log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    with stopped_quietly():
        _check_ros2()
        with cli_errors():
            ros_args = ros_arguments(ctx)
            description = robot_description(robot, srdf, end_effector, package_path, locked_joint)
            nodes = nodes_from_options(description, params, mesh_root, map, footprint, csv_dir, static_transform)
        from pfield import warmup
        from pfield.transport.ros2 import run

        warmup.start_background()  # logs "self-check passed" (pfield.warmup, INFO) once the engine has planned
        def announce() -> None:  # after the signal handlers: from this line on, Ctrl-C or SIGTERM stops cleanly
            typer.echo(f"pfield ROS 2 nodes: {', '.join(n.name for n in nodes)} (Ctrl-C stops)", err=True)

        with cli_errors():  # a bad --ros-args parameter value
            try:
                run(nodes, args=ros_args, on_ready=announce)
            finally:
                for pfield_node in nodes:
                    pfield_node.close()


def register(app: typer.Typer) -> None:
    """Add the ``ros2`` command group to ``app``."""
    app.add_typer(ros2_app, name="ros2")
