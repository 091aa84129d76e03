"""Built-in robots, loaded from the files of the installed ``example-robot-data`` package (no network).

| name | URDF | end effector | notes |
|---|---|---|---|
| ``xarm7`` | UFACTORY xArm7 | ``link_eef`` (= ``link7`` origin) | joints ``joint1..7`` |
| ``panda`` | Franka Emika Panda | ``panda_hand_tcp`` (between the fingertips) | fingers locked open |

The Panda's tool frame ``panda_hand_tcp`` sits 10.34 cm beyond the hand flange along its z axis; both
finger joints are locked at 0.04 m (fully open) so the planning model has the 7 arm joints.
"""

from __future__ import annotations

import difflib
import importlib.metadata
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

from pfield.errors import InvalidInput, ResourceNotFound

__all__ = ["BUILTIN_ROBOTS", "BuiltinRobot", "builtin_spec", "did_you_mean", "example_robot_data_root"]


@dataclass(frozen=True)
class BuiltinRobot:
    """Where a built-in robot's files are inside ``example-robot-data`` and how to configure it."""

    urdf: str
    srdf: str
    end_effector: str
    locked_joints: dict[str, float] = field(default_factory=dict)


BUILTIN_ROBOTS: dict[str, BuiltinRobot] = {
    "xarm7": BuiltinRobot("robots/xarm_description/urdf/xarm7.urdf", "robots/xarm_description/srdf/xarm7.srdf",
                          "link_eef"),
    "panda": BuiltinRobot("robots/panda_description/urdf/panda.urdf", "robots/panda_description/srdf/panda.srdf",
                          "panda_hand_tcp", {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}),
}


@cache
def example_robot_data_root() -> Path:
    """``share/example-robot-data`` of the installed package (the root of its ``package://`` URIs)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError as exc:
        raise ResourceNotFound("the example-robot-data package is not installed (pip install example-robot-data)") \
            from exc
    for entry in dist.files or []:
        text = str(entry)
        if text.endswith("share/example-robot-data/robots/xarm_description/urdf/xarm7.urdf"):
            return Path(str(dist.locate_file(entry))).parents[3]
    raise ResourceNotFound("example-robot-data is installed but ships no robots/xarm_description")


def builtin_spec(name: str) -> BuiltinRobot:
    """The catalog entry of ``name`` (case-insensitive); lists the known names when it is unknown."""
    key = str(name).strip().lower()
    if key not in BUILTIN_ROBOTS:
        raise InvalidInput("robot", name, f"unknown built-in robot{did_you_mean(name)}; known: "
                                          f"{', '.join(sorted(BUILTIN_ROBOTS))}")
    return BUILTIN_ROBOTS[key]


def did_you_mean(name: str) -> str:
    """`` (did you mean 'panda'?)`` when ``name`` is a near miss of one built-in robot's name, else ``""``."""
    close = difflib.get_close_matches(str(name).strip().lower(), list(BUILTIN_ROBOTS), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""
