"""The robot flags every command that takes a robot shares (``serve``, ``ros2 node``, ``view``, ``plan``, ``batch``).

``--robot NAME|PATH.urdf --srdf PATH --end-effector LINK --package-path NAME=DIR --locked-joint NAME=VALUE``
name one :class:`~pfield.robot.description.RobotDescription` (DESIGN §8). A command declares the five
parameters with these annotations and calls :func:`robot_description`; errors of the description name the
flag the value came from (``--srdf='x.srdf': no such SRDF file``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from pfield.errors import InvalidInput

if TYPE_CHECKING:
    from pfield.robot.description import RobotDescription
    from pfield.robot.model import RobotModel

__all__ = ["EndEffectorOption", "LockedJointOption", "PackagePathOption", "RobotOption", "SrdfOption",
           "build_robot", "parse_locked_joints", "parse_package_paths", "robot_description"]

RobotOption = Annotated[str, typer.Option("--robot", help="a built-in robot (panda, xarm7) or a URDF file")]
SrdfOption = Annotated[Path | None, typer.Option(
    "--srdf", help="SRDF of a URDF robot: disabled collision pairs and named states")]
EndEffectorOption = Annotated[str | None, typer.Option(
    "--end-effector", help="end-effector link of a URDF robot (the link whose pose is planned)")]
PackagePathOption = Annotated[list[str] | None, typer.Option(
    "--package-path", help="NAME=DIR: the root folder of package://NAME/ URIs (repeatable); mesh paths relative "
                           "to the URDF resolve against its folder")]
LockedJointOption = Annotated[list[str] | None, typer.Option(
    "--locked-joint", help="NAME=VALUE: lock this joint at VALUE (rad or m) (repeatable)")]

_FLAGS = {"robot": "--robot", "urdf": "--robot", "srdf": "--srdf", "end_effector": "--end-effector",
          "package_paths": "--package-path", "locked_joints": "--locked-joint"}


def _flag(field: str) -> str:
    """The flag of a description field (``locked_joints['j1']`` → ``--locked-joint j1``)."""
    base, _, rest = field.partition("[")
    flag = _FLAGS.get(base, field)
    return f"{flag} {rest.rstrip(']').strip(chr(39))}" if rest else flag


def parse_package_paths(values: list[str] | None) -> dict[str, Path]:
    """``{NAME: DIR}`` of ``--package-path NAME=DIR`` options (errors name ``--package-path``). Packages not given
    here are looked up in the ament index (``AMENT_PREFIX_PATH``) by the resource resolver."""
    from pfield.geometry.resources import package_path_map

    return package_path_map(values or [], "--package-path")


def parse_locked_joints(values: list[str] | None) -> dict[str, float]:
    """``{NAME: VALUE}`` of ``--locked-joint NAME=VALUE`` options (errors name ``--locked-joint``)."""
    from pfield._validation import finite  # numpy: only when the option is given

    locked: dict[str, float] = {}
    for value in values or []:
        name, sep, number = value.partition("=")
        if not sep or not name.strip() or not number.strip():
            raise InvalidInput("--locked-joint", value, "expected NAME=VALUE (a joint name, '=', its position in "
                                                        "rad or m), e.g. panda_finger_joint1=0.04")
        try:
            position = float(number)
        except ValueError:
            raise InvalidInput("--locked-joint", value, f"{number!r} is not a number") from None
        locked[name.strip()] = finite("--locked-joint", position)
    return locked


def robot_description(robot: str, srdf: Path | None = None, end_effector: str | None = None,
                      package_path: list[str] | None = None,
                      locked_joint: list[str] | None = None) -> RobotDescription:
    """The :class:`RobotDescription` of the robot flags; an error names the flag and the value."""
    from pfield.robot.description import RobotDescription

    locked = parse_locked_joints(locked_joint)
    try:  # the package roots as given: the description checks them after the robot's files
        return RobotDescription(robot, tuple(locked.items()), None if srdf is None else str(srdf), end_effector,
                                tuple(package_path or ()))  # type: ignore[arg-type]
    except InvalidInput as exc:
        reason = exc.reason
        if exc.field == "robot" and reason.startswith(("neither", "no such")):  # the advice in flags
            reason = reason.partition(": give")[0] + ": give a built-in name, or --robot FILE.urdf --end-effector LINK"
        raise InvalidInput(_flag(exc.field), exc.value, reason) from None


def build_robot(description: RobotDescription) -> RobotModel:
    """``description.build()`` (pinocchio reads the files, the meshes are found), an error naming the flag of the
    field it names (``srdf`` → ``--srdf``), as the description's own errors do."""
    try:
        return description.build()
    except InvalidInput as exc:
        raise InvalidInput(_flag(exc.field), exc.value, exc.reason) from None
