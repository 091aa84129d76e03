"""``pfield serve`` (the standalone node) and the ros2-like client verbs (topic, service, param, interface).

Other areas add their nodes to ``serve`` with :func:`register_node_factory`: a factory receives the
:class:`ServeContext` (bus, robot, options such as ``--map``/``--footprint``) and returns the nodes to
serve (none when its options are absent).
"""

from __future__ import annotations

import enum
import logging
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from pfield._validation import is_loopback_host, nearest_name
from pfield.cli import _node_client
from pfield.cli._exit_codes import FAILED, USAGE
from pfield.cli._port import check_port_free
from pfield.cli._robot_options import (
    EndEffectorOption,
    LockedJointOption,
    PackagePathOption,
    RobotOption,
    SrdfOption,
    build_robot,
    parse_package_paths,
    robot_description,
)
from pfield.errors import InvalidInput, PfieldError, Unreachable
from pfield.transport import DEFAULT_HOST, DEFAULT_PORT, ServerLimits

if TYPE_CHECKING:
    from pfield.node import Bus, Node
    from pfield.robot.description import RobotDescription

__all__ = ["ServeContext", "cli_errors", "nodes_from_options", "parse_package_paths", "register",
           "register_node_factory"]

_log = logging.getLogger(__name__)

# The options ``pfield serve`` and ``pfield ros2 node`` share (typer reads their help from these annotations); the
# robot's flags are :mod:`pfield.cli._robot_options`'s, shared with ``view``, ``plan`` and ``batch``.
ParamsOption = Annotated[Path | None, typer.Option(help="ROS 2 parameters YAML (node: ros__parameters: ...)")]
MeshRootOption = Annotated[list[Path] | None, typer.Option(help="directory meshes may be read from (repeatable)")]
MapOption = Annotated[Path | None, typer.Option(help="map_server YAML for the costmap node")]
FootprintOption = Annotated[str | None, typer.Option(help="nav2 footprint '[\\[x, y], ...]' for the costmap")]
CsvDirOption = Annotated[Path | None, typer.Option(help="save every planned path as CSV here")]


class LogLevel(enum.StrEnum):
    """The values of ``--log-level``: a misspelled one is a usage error (exit status 2) before anything starts."""

    debug = "debug"
    info = "info"
    warning = "warning"
    error = "error"


LogLevelOption = Annotated[LogLevel, typer.Option(case_sensitive=False, help="how much the command logs")]
StaticTransformOption = Annotated[list[str] | None, typer.Option(
    help="FRAME=x,y,z[,qx,qy,qz,qw]: pose of FRAME in the fixed frame; messages in FRAME are accepted and "
         "transformed (repeatable; the static_transforms parameter)")]


@dataclass
class ServeContext:
    """What ``pfield serve`` knows when it builds the nodes."""

    bus: Bus
    robot: Any
    package_paths: dict[str, Path]
    mesh_roots: list[Path]
    map_file: Path | None = None
    footprint: str | None = None
    static_transforms: dict[str, Any] = field(default_factory=dict)
    """``--static-transform`` values in the ``static_transforms`` parameter form (frame → translation, rotation)."""


NodeFactory = Callable[[ServeContext], "list[Node]"]
_FACTORIES: list[NodeFactory] = []


def register_node_factory(factory: NodeFactory) -> None:
    """Have ``pfield serve`` also serve the nodes ``factory(context)`` returns."""
    if factory not in _FACTORIES:
        _FACTORIES.append(factory)


def parse_static_transforms(values: list[str]) -> dict[str, Any]:
    """The ``static_transforms`` parameter of ``--static-transform FRAME=x,y,z[,qx,qy,qz,qw]`` options."""
    from pfield.node import parse_transform_option

    table: dict[str, Any] = {}
    for value in values:
        frame, data = parse_transform_option(value)
        if frame in table:
            raise InvalidInput("--static-transform", value, f"frame {frame!r} is given twice")
        table[frame] = data
    return table


def load_ros_parameters(path: Path, option: str = "--params") -> dict[str, dict[str, Any]]:
    """``{node name: {parameter: value}}`` of a ROS 2 parameters file (``node: {ros__parameters: {...}}``);
    errors name ``option``, the command-line argument the file came from."""
    from pfield.interfaces import load_yaml_file

    data = load_yaml_file(path, option) or {}
    if not isinstance(data, dict):
        raise InvalidInput(option, str(path), "expected a mapping of node names")
    result = {}
    for node, section in data.items():
        params = section.get("ros__parameters") if isinstance(section, dict) else None
        if not isinstance(params, dict):
            raise InvalidInput(f"{node}.ros__parameters", section, "expected a ros__parameters mapping")
        result["/" + str(node).lstrip("/")] = params
    return result


def build_nodes(context: ServeContext, params: dict[str, dict[str, Any]], csv_dir: Path | None) -> list[Node]:
    """The manager plus every registered factory's nodes, with ``--params`` applied (``/**`` to all);
    ``context.static_transforms`` is the manager's initial ``static_transforms`` (``--params`` may replace it)."""
    from pfield.node import make_resolver
    from pfield.node.manager import ManagerNode, ManagerParameters
    from pfield.node.servo_node import SERVO_NODE_NAMES, servo_from_parameters

    resolver = make_resolver(context.package_paths, context.mesh_roots)
    manager_params = ManagerParameters(static_transforms=context.static_transforms)
    manager = ManagerNode(context.bus, context.robot, parameters=manager_params, resolver=resolver, csv_dir=csv_dir)
    nodes: list[Node] = [manager]
    for factory in _FACTORIES:
        nodes.extend(factory(context))
    by_name = {node.name: node for node in nodes}
    for name, values in params.items():
        if name in SERVO_NODE_NAMES:  # a MoveIt Servo section: builds the servo loop below, on the manager as set
            continue
        targets = list(by_name.values()) if name == "/**" else [by_name[name]] if name in by_name else []
        if not targets:  # another node's section of a shared file, or a misspelling
            near = nearest_name(name, [*by_name, *SERVO_NODE_NAMES])
            _log.warning("--params: no node %s here; its parameters are ignored%s", name,
                         f" (did you mean {near}?)" if near else "")
        for node in targets:
            node.set_parameters(values if name != "/**" else {k: v for k, v in values.items()
                                                              if k in node.get_parameters()})
    servo = servo_from_parameters(manager, params)
    return nodes + ([servo] if servo is not None else [])


def _check_host(host: str, token: str | None) -> None:
    if not is_loopback_host(host) and not token:
        raise InvalidInput("--host", host, "serving beyond this machine needs --token (or PFIELD_TOKEN)")


@contextmanager
def stopped_quietly() -> Iterator[None]:
    """A server command's body: Ctrl-C before its signal handlers are in place (while the robot loads, a second
    after start) is the same asked-for stop as after, so it ends with status 0 and one line, not a traceback."""
    try:
        yield
    except KeyboardInterrupt:
        typer.echo("stopped", err=True)
        raise typer.Exit(0) from None


@contextmanager
def cli_errors() -> Iterator[None]:
    """Turn a :class:`PfieldError` raised inside into one line ``error: ...`` on stderr and exit status 2
    (``USAGE``: the command is wrong as given), or 1 (``FAILED``) for :class:`Unreachable` (a service that may
    answer later)."""
    try:
        yield
    except PfieldError as exc:
        typer.echo("error: " + " ".join(str(exc).splitlines()), err=True)
        raise typer.Exit(FAILED if isinstance(exc, Unreachable) else USAGE) from None


def nodes_from_options(robot: RobotDescription, params: Path | None, mesh_root: list[Path] | None,
                       map_file: Path | None, footprint: str | None, csv_dir: Path | None,
                       static_transform: list[str] | None = None) -> list[Node]:
    """The nodes of the options ``pfield serve`` and ``pfield ros2 node`` share (one new :class:`Bus`):
    the robot (its description's package paths also serve obstacle meshes), ``--mesh-root`` for mesh URIs,
    ``--map``/``--footprint`` for the
    factories' nodes, ``--static-transform`` for the manager's frames and the ``--params`` YAML applied to
    them. Bad options raise :class:`InvalidInput`. The robot's link model is then fitted in the background
    (:func:`pfield.warmup.fit_in_background`: ``GET /health`` is ready once it is)."""
    from pfield.node import Bus

    packages = robot.package_path_map
    transforms = parse_static_transforms(static_transform or [])
    parameters = load_ros_parameters(params) if params else {}
    context = ServeContext(Bus(), build_robot(robot), packages,
                           [p.resolve() for p in mesh_root or []], map_file, footprint,
                           static_transforms=transforms)
    nodes = build_nodes(context, parameters, csv_dir)
    from pfield import warmup

    warmup.fit_in_background(context.robot)
    return nodes


def serve(
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
    host: Annotated[str, typer.Option(help="address to bind; other than loopback needs --token")] = DEFAULT_HOST,
    port: Annotated[int, typer.Option(min=1, max=65535, help="TCP port (checked free before anything starts)")]
    = DEFAULT_PORT,
    token: Annotated[str | None, typer.Option(envvar="PFIELD_TOKEN", help="bearer token clients must send")]
    = None,
    csv_dir: CsvDirOption = None,
    log_level: LogLevelOption = LogLevel.info,
    allow_origin: Annotated[list[str] | None, typer.Option(
        help="ORIGIN (scheme://host:port) of a web page allowed to change state and open WebSockets "
             "(repeatable; the server's own loopback origin is always allowed)")] = None,
    max_connections: Annotated[int, typer.Option(help="open connections at most; more are answered 429")]
    = ServerLimits.max_connections,
    header_timeout: Annotated[float, typer.Option(help="s a client may take to send a request head")]
    = ServerLimits.header_timeout,
) -> None:
    """Start the pfield node (HTTP + WebSocket) with the ROS names of potential_fields_interfaces.

    Exit status 2, before anything is printed or started, for bad options or a port in use."""
    logging.basicConfig(level=log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    with stopped_quietly():
        from pfield.transport.http import create_app, run_server

        with cli_errors():
            _check_host(host, token)
            check_port_free(host, port)
            limits = ServerLimits(max_connections=max_connections, header_timeout=header_timeout)
            description = robot_description(robot, srdf, end_effector, package_path, locked_joint)
            nodes = nodes_from_options(description, params, mesh_root, map, footprint, csv_dir, static_transform)
        from pfield import warmup

        warmup.start_background()  # GET /health says "ready" once the self-check has run and the robot is fitted
        app = create_app(nodes, token=token, ready=warmup.ready, errors=warmup.start_up_errors,
                         allowed_origins=allow_origin or ())
        typer.echo(f"pfield node on http://{host}:{port} ({', '.join(n.name for n in nodes)})", err=True)
        sys.stderr.flush()
        run_server(app, host, port, limits=limits, log_level="warning" if log_level != "debug" else "debug")


def register(app: typer.Typer) -> None:
    """Add ``serve`` and the ``topic``/``service``/``param``/``interface`` verbs to ``app``."""
    app.command("serve")(serve)
    _node_client.register(app)
