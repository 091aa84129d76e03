"""Static transforms: poses given in a named frame are re-expressed in the node's fixed frame.

The table maps a frame name to ``T_fixed_frame`` (the :class:`~pfield.spatial.Pose` of that frame in the
fixed frame); a pose ``T_frame_x`` given in ``frame`` becomes ``T_fixed_x = T_fixed_frame * T_frame_x``
(DESIGN.md §2). Its parameter form is JSON/YAML-friendly::

    static_transforms: {camera: {translation: [x, y, z], rotation: [qx, qy, qz, qw]}}

(m, within ±1e6 m as every position a node accepts; quaternion x, y, z, w of a norm in [1e-9, 1e6],
normalised on input; ``rotation`` may be left out for the identity). On the command line:
``--static-transform camera=x,y,z[,qx,qy,qz,qw]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pfield._validation import as_vector
from pfield.errors import InvalidInput, UnknownFrame
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces.convert import point_from_msg, quaternion_from_msg
from pfield.spatial import Pose, normalize_quaternion

__all__ = ["PARAMETER", "StaticTransforms", "parse_transform_option", "parse_transforms", "transforms_data"]

PARAMETER = "static_transforms"
_KEYS = ("translation", "rotation")
_IDENTITY = (0.0, 0.0, 0.0, 1.0)


def _parse_one(frame: Any, value: Any, fixed_frame: str) -> Pose:
    field = f"{PARAMETER}.{frame}"
    if not isinstance(frame, str) or not frame:
        raise InvalidInput(field, frame, "a frame name must be a non-empty string")
    if frame == fixed_frame:
        raise InvalidInput(field, frame, "is the fixed frame itself; it needs no transform")
    if isinstance(value, Pose):
        return value
    if not isinstance(value, Mapping) or "translation" not in value or set(value) - set(_KEYS):
        raise InvalidInput(field, value, "expected {translation: [x, y, z], rotation: [qx, qy, qz, qw]}")
    if not _is_list(value["translation"], 3):
        raise InvalidInput(f"{field}.translation", value["translation"], "expected a list of 3 numbers (m)")
    rotation = value.get("rotation", _IDENTITY)
    if not _is_list(rotation, 4):
        raise InvalidInput(f"{field}.rotation", rotation, "expected a list of 4 numbers (qx, qy, qz, qw)")
    # the ranges of every pose a node accepts (convert's checks), on values made finite doubles first
    x, y, z = as_vector(f"{field}.translation", value["translation"], 3).tolist()
    qx, qy, qz, qw = as_vector(f"{field}.rotation", rotation, 4).tolist()
    translation = point_from_msg(gm.Point(x=x, y=y, z=z), f"{field}.translation")
    quaternion = quaternion_from_msg(gm.Quaternion(x=qx, y=qy, z=qz, w=qw), f"{field}.rotation")
    return Pose(translation, normalize_quaternion(quaternion, f"{field}.rotation"))


def _is_list(value: Any, length: int) -> bool:
    return isinstance(value, list | tuple) and len(value) == length and all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value)


def parse_transforms(value: Any, fixed_frame: str) -> dict[str, Pose]:
    """``{frame: T_fixed_frame}`` of the parameter form (entries may also be :class:`Pose`).

    Raises :class:`InvalidInput` naming ``static_transforms.<frame>[.translation|.rotation]`` for a
    value of another shape, a non-finite number or a zero quaternion.
    """
    if not isinstance(value, Mapping):
        raise InvalidInput(PARAMETER, value, "expected a mapping {frame: {translation: [...], rotation: [...]}}")
    try:
        return {frame: _parse_one(frame, item, fixed_frame) for frame, item in value.items()}
    except InvalidInput as exc:
        if exc.field.startswith(PARAMETER):
            raise
        raise InvalidInput(f"{PARAMETER}.{exc.field}", exc.value, exc.reason) from None


def transforms_data(transforms: Mapping[str, Pose]) -> dict[str, dict[str, list[float]]]:
    """The parameter form of a table (what ``get_parameters`` reports)."""
    return {frame: {"translation": [float(v) for v in pose.position],
                    "rotation": [float(v) for v in pose.orientation]} for frame, pose in transforms.items()}


def parse_transform_option(text: str) -> tuple[str, dict[str, list[float]]]:
    """``(frame, parameter form)`` of one ``--static-transform FRAME=x,y,z[,qx,qy,qz,qw]`` value."""
    frame, sep, numbers = text.partition("=")
    try:
        values = [float(v) for v in numbers.split(",")] if sep and frame else []
    except ValueError:
        values = []
    if len(values) not in (3, 7):
        raise InvalidInput("--static-transform", text, "expected FRAME=x,y,z or FRAME=x,y,z,qx,qy,qz,qw")
    data = {"translation": values[:3], "rotation": values[3:] or list(_IDENTITY)}
    try:
        parse_transforms({frame: data}, "")
    except InvalidInput as exc:
        raise InvalidInput("--static-transform", text, f"{exc.field}: {exc.reason}") from None
    return frame, data


class StaticTransforms:
    """Re-expresses poses in the fixed frame through a table of static transforms (see the module doc)."""

    def __init__(self, fixed_frame: str, transforms: Mapping[str, Pose]) -> None:
        self.fixed_frame = fixed_frame
        self.transforms = dict(transforms)

    def lookup(self, field: str, frame_id: str, what: str = "poses", end_effector: str = "") -> Pose | None:
        """``T_fixed_frame`` of ``frame_id`` (a pose ``p`` in that frame is ``T_fixed_frame * p`` in the fixed
        frame); None for the fixed frame itself or ``""``. Raises :class:`UnknownFrame` naming ``field`` for a
        frame without a configured transform; its message speaks of ``what`` is refused and names the
        ``end_effector`` frame where the caller also takes that one (operator twists)."""
        if frame_id in ("", self.fixed_frame):
            return None
        if frame_id in self.transforms:
            return self.transforms[frame_id]
        known = ", ".join(sorted(self.transforms)) or "none"
        tool = f", the end-effector frame {end_effector!r}," if end_effector else ""
        raise UnknownFrame(field, frame_id, f"{what} must be given in the fixed frame {self.fixed_frame!r}{tool} or "
                           f"a frame with a static transform (configured: {known}); configure one with the "
                           f"{PARAMETER} parameter or --static-transform FRAME=x,y,z[,qx,qy,qz,qw]")
