"""``pfield plan``: a plan in the built-in seed scene or a scene YAML, written as a PNG (and CSV).

Without ``--robot`` the plan is the end effector's, in task space. With ``--robot`` (the robot flags every command
shares, :mod:`pfield.cli._robot_options`) it is the robot's whole-body plan from ``--start-joints`` to the
scene's goal pose (the scene's start pose is then not used). The scene file format is
:mod:`pfield.scene.files`'s (documented in docs/field.md, "Scene files").
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from pfield._files import check_picture, check_writable
from pfield.cli._node import cli_errors
from pfield.cli._robot_options import (
    EndEffectorOption,
    LockedJointOption,
    PackagePathOption,
    SrdfOption,
    build_robot,
    robot_description,
)
from pfield.errors import InvalidInput

if TYPE_CHECKING:
    from rich.console import Console

    from pfield.robot import RobotModel

__all__ = ["register"]


def start_joints(robot: RobotModel, value: str | None) -> Any:
    """The joint positions of ``--start-joints``: comma-separated values (rad or m, in the robot's joint order)
    or the name of one of its named configurations (the SRDF's group states, e.g. ``home``)."""
    named = robot.named_configurations()
    if value is None or not value.strip():
        raise InvalidInput("--start-joints", value, f"a whole-body plan (--robot) starts from joint positions: give "
                           f"{robot.n_joints} comma-separated values (rad or m) for {', '.join(robot.joint_names)}"
                           + (f", or a named state ({', '.join(named)})" if named else ""))
    if value.strip() in named:
        return named[value.strip()]
    if value.strip() in robot.skipped_group_states:
        raise InvalidInput("--start-joints", value, robot.skipped_group_states[value.strip()])
    try:
        values = [float(part) for part in value.split(",")]
    except ValueError:
        known = f"; named states: {', '.join(named)}" if named else "; the robot has no named states (an SRDF's)"
        raise InvalidInput("--start-joints", value, f"expected {robot.n_joints} comma-separated numbers or a named "
                                                    f"state{known}") from None
    if len(values) != robot.n_joints:  # say which joints (a --locked-joint takes one away)
        raise InvalidInput("--start-joints", value, f"expected {robot.n_joints} numbers, for "
                                                    f"{', '.join(robot.joint_names)} (locked joints excluded), "
                                                    f"got {len(values)}")
    return robot.check_joint_angles(values, "--start-joints")


def _plan(scene_file: Path | None, output: Path, csv: Path | None, console: Console,
          robot: RobotModel | None = None, start: str | None = None) -> int:
    from pfield.field import PotentialField
    from pfield.planning.scenes import SEED_START
    from pfield.scene.files import load_scene
    from pfield.viz.arm import save_arm_plot
    from pfield.viz.plots import save_path_plot

    with tempfile.TemporaryDirectory() as meshes:
        scene = load_scene(scene_file, Path(meshes))
        field = PotentialField(scene["config"], scene["goal"], scene["obstacles"])
        settings = {"dt": scene["dt"], "goal_tolerance": scene["goal_tolerance"],
                    "max_iterations": scene["max_iterations"]}
        if robot is None:
            path = field.plan(scene["start"], **settings)
            save_path_plot(path, output, scene["obstacles"], scene["goal"])
        else:  # the arm at key moments, its end effector's path and the clearance (viz.save_arm_plot)
            path = field.plan_whole_body(robot, start_joints(robot, start), **settings)
            status = "reached the goal" if path.success else path.failure_reason
            save_arm_plot(path, robot, scene["obstacles"], output, f"{robot.name} whole-body plan: {status}",
                          goal=scene["goal"])
    if csv is not None:
        path.to_csv(csv)
    state = "[green]reached the goal[/green]" if path.success else f"[red]failed[/red]: {path.failure_reason}"
    who = "" if robot is None else f"{robot.name} ({path.planner}): "
    executed = "" if path.trajectory_duration is None else (
        f"; joint path {path.joint_path_length:.2f} rad, trajectory {path.trajectory_duration:.2f} s within the "
        f"joint limits")
    model = "" if robot is None else " (link model)"  # whole body: the planner's cover of the meshes, a lower bound
    clearance = "no obstacles" if math.isinf(path.min_clearance) else \
        f"min clearance {path.min_clearance:.4g} m{model}"
    # one line per message however narrow the terminal or a pipe (rich would cut numbers from their units)
    console.print(f"{who}{state}: {len(path)} waypoints over {path.duration:.2f} s{executed}, {clearance}; plot "
                  f"written to {output}" + (f", waypoints to {csv}" if csv else ""), soft_wrap=True)
    if robot is not None and scene_file is not None and scene["start"] is not SEED_START:
        console.print("the scene file's start pose is not used: a whole-body plan starts from --start-joints",
                      soft_wrap=True)
    return 0 if path.success else 1


def register(app: typer.Typer) -> None:
    """Add ``pfield plan`` to ``app``."""

    @app.command("plan")
    def plan(
        scene: Path | None = typer.Option(None, "--scene", "-s", help="Scene YAML (default: the example scene)."),
        output: Path = typer.Option(Path("plan.png"), "--output", "-o", help="PNG of the path and obstacles."),
        csv: Path | None = typer.Option(None, "--csv", help="Also write the waypoints as CSV."),
        robot: str | None = typer.Option(None, "--robot", help="Plan this robot's whole body: a built-in robot "
                                                               "(panda, xarm7) or a URDF file."),
        srdf: SrdfOption = None,
        end_effector: EndEffectorOption = None,
        package_path: PackagePathOption = None,
        locked_joint: LockedJointOption = None,
        start: str | None = typer.Option(None, "--start-joints", help="With --robot: the start, V1,V2,... (rad or "
                                                                      "m, joint order) or a named state (home)."),
    ) -> None:
        """Plan a path with the potential field and plot it: the end effector's (task space), or with --robot a
        robot's whole body from --start-joints to the scene's goal. Exit 1 when the goal is not reached, 2 for a
        bad scene file, robot, start or output path, checked before planning."""
        from pfield._console import console as make_console

        with cli_errors():
            check_picture("--output", output)
            if csv is not None:
                check_writable("--csv", csv)
            model = None
            if robot is not None:
                model = build_robot(robot_description(robot, srdf, end_effector, package_path, locked_joint))
                start_joints(model, start)  # judged before planning
            elif start is not None or srdf is not None or end_effector is not None or package_path or locked_joint:
                raise InvalidInput("--robot", None, "--start-joints, --srdf, --end-effector, --package-path and "
                                                    "--locked-joint describe a robot: give --robot NAME|FILE.urdf")
            code = _plan(scene, output, csv, make_console(), model, start)
        raise typer.Exit(code)
