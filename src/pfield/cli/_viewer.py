"""``pfield view``: the 3D web viewer, live from a running node or offline from a plan CSV and a scene YAML."""

from __future__ import annotations

import contextlib
import io
import logging
import tempfile
import time
from pathlib import Path
from typing import Annotated

import typer

from pfield.cli._node import LogLevel, LogLevelOption, MeshRootOption, cli_errors
from pfield.cli._robot_options import (
    EndEffectorOption,
    LockedJointOption,
    PackagePathOption,
    SrdfOption,
    build_robot,
    parse_package_paths,
    robot_description,
)
from pfield.errors import InvalidInput
from pfield.transport import DEFAULT_URL

__all__ = ["register", "view"]


def view(
    url: Annotated[str, typer.Option(envvar="PFIELD_URL", help="address of the running node")] = DEFAULT_URL,
    token: Annotated[str | None, typer.Option(envvar="PFIELD_TOKEN", help="bearer token of the node")] = None,
    plan: Annotated[Path | None, typer.Option(help="offline: a plan CSV written by pfield (no node)")] = None,
    scene: Annotated[Path | None, typer.Option(help="offline: a scene YAML as for pfield plan --scene")] = None,
    map: Annotated[Path | None, typer.Option(help="offline: a map_server YAML shown as the ground")] = None,
    export: Annotated[Path | None, typer.Option(help="write a self-contained HTML page here and exit")] = None,
    robot: Annotated[str, typer.Option("--robot", help="a built-in robot (panda, xarm7), a URDF file, or none")
                     ] = "xarm7",
    srdf: SrdfOption = None,
    end_effector: EndEffectorOption = None,
    package_path: PackagePathOption = None,
    locked_joint: LockedJointOption = None,
    mesh_root: MeshRootOption = None,
    host: Annotated[str, typer.Option(help="address the page is served on; other than loopback needs "
                                           "--page-token")] = "127.0.0.1",
    page_token: Annotated[str | None, typer.Option(envvar="PFIELD_VIEW_TOKEN",
                                                   help="token the page's visitors must give (?token=...)")] = None,
    port: Annotated[int, typer.Option(help="TCP port of the page")] = 8080,
    log_level: LogLevelOption = LogLevel.warning,
) -> None:
    """Open the 3D viewer: obstacles, influence zones, goal gizmo, plans, the robot and the field arrows."""
    logging.basicConfig(level=log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    with cli_errors():
        from pfield._files import check_writable
        from pfield.geometry import ResourceResolver
        from pfield.scene.files import load_scene
        from pfield.viz.viewer import Viewer, read_plan_csv

        if export is not None:
            check_writable("--export", export)
        if robot.strip().lower() != "none":
            model = build_robot(robot_description(robot, srdf, end_effector, package_path, locked_joint))
        elif srdf is not None or end_effector is not None or locked_joint:
            raise InvalidInput("--robot", robot, "--srdf, --end-effector and --locked-joint describe a robot: give "
                                                 "--robot NAME|FILE.urdf, or leave them out")
        else:
            model = None
        packages = parse_package_paths(package_path)  # after the robot's own flags (its URDF is named first)
        roots = [p.resolve() for p in mesh_root or []]
        resolver = ResourceResolver(package_paths=packages, allowed_roots=[*roots, *packages.values(), Path.cwd()])
        offline = plan is not None or scene is not None or map is not None
        path = read_plan_csv(plan) if plan is not None else None
        scene_data = load_scene(scene, Path(tempfile.mkdtemp(prefix="pfield-view-"))) if scene is not None else {}
        grid = None
        if map is not None:
            from pfield.costmap.map_io import load_map

            grid = load_map(map)
        try:
            with _throwaway(export):
                viewer = Viewer(model, packages, host=host, port=0 if export is not None else port, token=page_token)
        except InvalidInput as exc:
            raise InvalidInput("--host", host, "serving the page beyond this machine needs --page-token "
                                               "(or PFIELD_VIEW_TOKEN)") if exc.field == "host" else exc from None
    try:
        if offline:
            viewer.config = scene_data.get("config", viewer.config)
            obstacles = scene_data.get("obstacles", [])
            viewer.set_obstacles(obstacles)
            viewer.scene.set_influence(distance=viewer.config.influence_distance)
            viewer.set_goal(scene_data.get("goal"))
            if path is not None:
                viewer.show_plan(path, obstacles, scene_data.get("goal"))
            if grid is not None:
                viewer.show_costmap(grid)
        else:
            viewer.connect(url, token=token, resolver=resolver)
        if export is not None:
            viewer.refresh_field()
            typer.echo(f"wrote {viewer.export_html(export)}")
            return
        typer.echo(f"pfield viewer on {viewer.url} ({'offline' if offline else 'following ' + url}); Ctrl-C stops",
                   err=True)
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        with _throwaway(export):
            viewer.close()


def _throwaway(export: Path | None) -> contextlib.AbstractContextManager[object]:
    """For ``--export``, this command's standard output held back while the page's throwaway server starts and
    stops: viser 1.1 prints its banner and "Server stopped" whatever its ``verbose``, naming a port that is gone once
    the file is written. (Only here, a command with no other thread printing: the swap is process-wide.)"""
    return contextlib.redirect_stdout(io.StringIO()) if export is not None else contextlib.nullcontext()


def register(app: typer.Typer) -> None:
    app.command("view")(view)
