"""Joint velocity and acceleration limits: MoveIt's ``joint_limits.yaml``, else the URDF and documented defaults.

A URDF gives each joint's velocity limit but no acceleration limit. MoveIt keeps both in a robot's
``config/joint_limits.yaml``::

    joint_limits:
      shoulder_pan_joint:
        has_velocity_limits: true
        max_velocity: 3.15
        has_acceleration_limits: true
        max_acceleration: 5.0

:func:`read_joint_limits` reads that file: a ``max_velocity`` with ``has_velocity_limits: true`` replaces the
URDF's (MoveIt's rule), a ``max_acceleration`` with ``has_acceleration_limits: true`` sets the joint's
acceleration limit. Joints the file does not limit get :data:`DEFAULT_JOINT_ACCELERATION` (revolute) or
:data:`DEFAULT_PRISMATIC_ACCELERATION` (prismatic): limits every industrial arm follows, chosen so that retimed
trajectories (:mod:`pfield.planning.retime`) last what a robot's own controller would take, not several times
longer.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from pfield._validation import positive
from pfield.errors import InvalidInput, ResourceNotFound

__all__ = ["DEFAULT_JOINT_ACCELERATION", "DEFAULT_PRISMATIC_ACCELERATION", "JointLimits", "default_accelerations",
           "missing_velocity_limit", "read_joint_limits"]

DEFAULT_JOINT_ACCELERATION = 1.4
"""rad/s²: revolute joints without a configured limit — the default joint acceleration of Universal Robots'
``movej`` (URScript manual: ``movej(q, a=1.4, v=1.05)``), a pace every current 6- and 7-axis arm follows (the
Panda's joints allow 7.5–20 rad/s², its datasheet)."""
DEFAULT_PRISMATIC_ACCELERATION = 1.0
"""m/s²: prismatic joints without a configured limit (FieldConfig's ``max_linear_acceleration`` default)."""
_MAX_FILE_BYTES = 1_000_000


class JointLimits(NamedTuple):
    """Per joint (tree order): ``velocity`` (rad/s or m/s) and ``acceleration`` (rad/s² or m/s²) limits."""

    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]


def missing_velocity_limit(joint_names: Sequence[str], velocity: NDArray[np.float64], urdf: str) -> str:
    """Empty when every joint has a finite velocity limit > 0; else what is wrong and how to give one.

    URDF exporters write ``<limit velocity="0"/>`` as a placeholder, and a continuous joint may have no
    ``<limit>`` (pinocchio reads infinity). Whole-body plans, steps and assistance scale joint velocities into the
    limits and retime within them, so they need one (MoveIt's time parameterisation refuses such a joint too);
    forward kinematics, Jacobians and IK do not."""
    for name, limit in zip(joint_names, velocity.tolist(), strict=True):
        if not (np.isfinite(limit) and limit > 0.0):
            return (f"joint {name!r} of {urdf} has velocity limit {limit:g}; moving it needs a finite limit > 0: set "
                    f"<limit velocity=...> in the URDF, give max_velocity in a MoveIt joint_limits.yaml "
                    f"(RobotModel.from_urdf(..., joint_limits=...)), or lock the joint (locked_joints={{{name!r}: "
                    f"value}}, on the command line --locked-joint {name}=VALUE)")
    return ""


def default_accelerations(kinds: Sequence[int] | NDArray[np.int64]) -> NDArray[np.float64]:
    """The default acceleration limit of each joint from its kind (0 revolute, else prismatic)."""
    return np.where(np.asarray(kinds) == 0, DEFAULT_JOINT_ACCELERATION, DEFAULT_PRISMATIC_ACCELERATION).astype(
        np.float64)


def read_joint_limits(path: str | Path, joint_names: Sequence[str], urdf_velocity: NDArray[np.float64],
                      kinds: Sequence[int] | NDArray[np.int64]) -> JointLimits:
    """The limits of ``joint_names`` from a MoveIt ``joint_limits.yaml`` over the URDF's velocities and the
    defaults (module docstring). Joints of the file that the robot does not have (a gripper's) are ignored."""
    import yaml

    source = Path(path)
    try:
        if not source.is_file():
            raise ResourceNotFound(f"joint limits {source}: no such file")
        if source.stat().st_size > _MAX_FILE_BYTES:
            raise InvalidInput("joint_limits", str(source), f"larger than {_MAX_FILE_BYTES} bytes")
        document: Any = yaml.safe_load(source.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise InvalidInput("joint_limits", str(source), f"cannot be read as YAML ({type(exc).__name__})") from None
    table = document.get("joint_limits") if isinstance(document, dict) else None
    if not isinstance(table, dict):
        raise InvalidInput("joint_limits", str(source), "expected a 'joint_limits:' mapping of joint names")
    velocity = np.array(urdf_velocity, dtype=np.float64)
    acceleration = default_accelerations(kinds)
    for j, name in enumerate(joint_names):
        entry = table.get(name)
        if not isinstance(entry, dict):
            continue
        if entry.get("has_velocity_limits") is True and "max_velocity" in entry:
            velocity[j] = positive(f"joint_limits.{name}.max_velocity", entry["max_velocity"])
        if entry.get("has_acceleration_limits") is True and "max_acceleration" in entry:
            acceleration[j] = positive(f"joint_limits.{name}.max_acceleration", entry["max_acceleration"])
    return JointLimits(velocity, acceleration)
