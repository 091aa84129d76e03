"""``pfield ros2 execute``: send a joint trajectory to a ros2_control controller's FollowJointTrajectory action.

The trajectory file (YAML or JSON; ``-`` reads standard input) holds a ``trajectory_msgs/JointTrajectory``, or
a document with a ``joint_trajectory`` field: the ``PlanPath`` response ``pfield service call /pfield/plan_path``
prints, whose trajectory is already time-parameterised. Progress follows the controller's feedback; Ctrl-C
cancels the goal. Exit status (:mod:`pfield.cli._exit_codes`): 0 when the controller reports SUCCESSFUL, 1 for
any other outcome (rejected, aborted with its code, cancelled) or no server/answer within the timeouts, 2 for a
bad file or option (nothing is sent).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from pfield.cli._exit_codes import FAILED, OK, USAGE
from pfield.cli._node import cli_errors
from pfield.cli._ros2 import _check_ros2, ros_arguments
from pfield.errors import InvalidInput

__all__ = ["register"]

_HELP_ACTION = "the controller's FollowJointTrajectory action"


def _parse_tolerances(option: str, values: list[str] | None) -> dict[str, tuple[float, float, float]]:
    """``JOINT=POSITION`` or ``JOINT=POSITION,VELOCITY,ACCELERATION`` (rad, rad/s, rad/s² or m…) per item."""
    from pfield import _validation

    parsed: dict[str, tuple[float, float, float]] = {}
    for item in values or []:
        joint, sep, numbers = item.partition("=")
        parts = numbers.split(",")
        if not sep or not joint or len(parts) not in (1, 3):
            raise InvalidInput(option, item, "expected JOINT=POSITION or JOINT=POSITION,VELOCITY,ACCELERATION")
        triple = [_validation.finite(f"{option} {joint}", part) for part in parts] + [0.0, 0.0]
        parsed[joint] = (triple[0], triple[1], triple[2])
    return parsed


def _load_trajectory(source: str) -> Any:
    """The JointTrajectory model of the file (or stdin for ``-``), from either document shape."""
    from pfield.interfaces import load_yaml, load_yaml_file, message_from_data
    from pfield.interfaces.trajectory_msgs import JointTrajectory

    data = load_yaml(sys.stdin.read(), "TRAJECTORY") if source == "-" else load_yaml_file(Path(source), "TRAJECTORY")
    if isinstance(data, dict) and "joint_trajectory" in data:
        data = data["joint_trajectory"]
    return message_from_data(JointTrajectory, data)


def execute(
    ctx: typer.Context,
    trajectory: Annotated[str, typer.Argument(metavar="TRAJECTORY", help="YAML/JSON file of a "
                                              "trajectory_msgs/JointTrajectory or a PlanPath response; - for stdin")],
    action: Annotated[str, typer.Option("--action", "-a", help=_HELP_ACTION)]
        = "/joint_trajectory_controller/follow_joint_trajectory",
    goal_time_tolerance: Annotated[float, typer.Option(help="s after the trajectory's end to meet the goal "
                                                       "tolerance (0: the controller's default)")] = 0.0,
    path_tolerance: Annotated[list[str] | None, typer.Option(
        help="JOINT=POS[,VEL,ACC] while moving (repeat; 0 the default, -1 no limit)")] = None,
    goal_tolerance: Annotated[list[str] | None, typer.Option(help="JOINT=POS[,VEL,ACC] at the end (repeat)")] = None,
    server_timeout: Annotated[float, typer.Option(help="s to wait for the action server")] = 5.0,
    accept_timeout: Annotated[float, typer.Option(help="s to wait for the goal's accept/reject answer")] = 5.0,
) -> None:
    """Execute a joint trajectory on a ros2_control joint_trajectory_controller (FollowJointTrajectory).

    Example: pfield service call /pfield/plan_path "{...}" > plan.yaml && pfield ros2 execute plan.yaml
    --action /joint_trajectory_controller/follow_joint_trajectory --path-tolerance joint1=0.05
    """
    _check_ros2()
    if importlib.util.find_spec("control_msgs") is None:
        typer.echo("error: control_msgs (FollowJointTrajectory) is not built: run `make ros2-interfaces` "
                   "(docs/ros2.md, Trajectories out)", err=True)
        raise typer.Exit(USAGE)
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from pfield._console import console as make_console
    from pfield.transport.trajectory_client import (
        ExecutionOptions,
        TrajectoryClient,
        TrajectoryExecutionError,
        as_timed_trajectory,
        build_goal,
    )

    with cli_errors():
        ros_args = ros_arguments(ctx)  # a misspelled option first: it may be why the rest looks wrong
        message = _load_trajectory(trajectory)
        options = ExecutionOptions(path_tolerance=_parse_tolerances("--path-tolerance", path_tolerance),
                                   goal_tolerance=_parse_tolerances("--goal-tolerance", goal_tolerance),
                                   goal_time_tolerance=goal_time_tolerance, server_timeout=server_timeout,
                                   accept_timeout=accept_timeout)
        duration = as_timed_trajectory(message).duration
        build_goal(message, options)  # every refusal before ROS starts
    console = make_console(stderr=True)
    try:
        client = TrajectoryClient(action, args=ros_args)
    except InvalidInput as exc:
        console.print(f"error: {exc}")
        raise typer.Exit(USAGE) from None
    try:
        columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed:.2f}/{task.total:.2f} s"),
                   TimeElapsedColumn())
        with Progress(*columns, console=console, transient=True) as progress:
            task = progress.add_task(f"executing on {client.action_name}", total=max(duration, 1e-9))
            execution = client.send(message, options,
                                    feedback=lambda f: progress.update(task, completed=f.time_from_start))
            try:
                result = execution.result()
            except KeyboardInterrupt:
                execution.cancel()
                result = execution.result()
    except TrajectoryExecutionError as exc:
        console.print(f"[red]error[/red]: {exc}")
        raise typer.Exit(FAILED) from None
    finally:
        client.close()
    colour = "green" if result.success else "red"
    console.print(f"[{colour}]{result.describe()}[/{colour}] after {result.duration:.2f} s "
                  f"({result.feedback_count} feedback messages)")
    raise typer.Exit(OK if result.success else FAILED)


def register(app: typer.Typer) -> None:
    """Add ``execute`` to the ``pfield ros2`` group (:mod:`pfield.cli._ros2`)."""
    from pfield.cli._ros2 import ros2_app

    ros2_app.command("execute", context_settings={"allow_extra_args": True, "ignore_unknown_options": True})(execute)
