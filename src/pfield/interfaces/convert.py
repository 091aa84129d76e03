"""Conversions between the message models and pfield's core types.

* ``geometry_msgs`` ↔ :class:`~pfield.spatial.Pose` / :class:`~pfield.spatial.Twist` (quaternions x, y, z, w,
  normalised on input; a zero or non-finite quaternion is rejected naming the field path);
* ``potential_fields_interfaces/Obstacle`` ↔ :class:`~pfield.geometry.Obstacle` (the seed's shape table:
  Sphere radius, Box length/width/height full extents, Cylinder radius/height, Ellipsoid semi-axes,
  Capsule radius/shaft height, Mesh resource + scale);
* :class:`~pfield.planning.result.PlannedPath` → ``PlanPath`` response: ``nav_msgs/Path`` and one
  ``TwistStamped`` per waypoint stamped ``i·dt`` s, a ``JointTrajectory`` with joint names (its JSON
  written from the plan's arrays, its per-waypoint models built only when read).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray
from pydantic import PrivateAttr
from pydantic_core import to_json

from pfield._validation import as_vector, scaled_norm
from pfield.errors import InvalidInput
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces._base import RosMessage
from pfield.interfaces.nav_msgs import Path
from pfield.interfaces.potential_fields_interfaces import Obstacle as ObstacleMsg
from pfield.interfaces.potential_fields_interfaces import PlanPath_Response
from pfield.interfaces.std_msgs import Header, Time
from pfield.interfaces.trajectory_msgs import JointTrajectory
from pfield.planning.result import PlannedPath
from pfield.spatial import MIN_QUATERNION_NORM, Pose, Twist, pose_from_checked

__all__ = [
    "MAX_COORDINATE",
    "MAX_QUATERNION_NORM",
    "MIN_QUATERNION_NORM",
    "obstacle_from_msg",
    "obstacle_to_msg",
    "plan_response",
    "point_from_msg",
    "pose_from_msg",
    "pose_to_msg",
    "prefixed",
    "quaternion_from_msg",
    "twist_stamped",
    "twist_stamped_fields",
    "twist_to_msg",
]

def prefixed(error: InvalidInput, prefix: str) -> InvalidInput:
    """The same error with its field path under ``prefix`` (``radius`` → ``obstacles[2].radius``)."""
    return type(error)(f"{prefix}.{error.field}" if prefix else error.field, error.value, error.reason)


MAX_COORDINATE = 1.0e6
"""m: the largest |x|, |y|, |z| of a position a node accepts. 1000 km is beyond any map a robot works in,
and it keeps sums, squares and products of coordinates (transforms, distances) finite."""
MAX_QUATERNION_NORM = 1e6
"""A message's quaternion (x, y, z, w) is normalised on input (DESIGN §2) when its norm lies in
[:data:`MIN_QUATERNION_NORM`, :data:`MAX_QUATERNION_NORM`]; outside it (a zero quaternion, ``w = 1e308``)
it is refused: no sensor or planner produces such a rotation, and the norm is computed scaled, so the
check itself never overflows."""


def _checked(values: tuple[Any, ...]) -> NDArray[np.float64] | None:
    """``values`` as a read-only array when all are finite floats within :data:`MAX_COORDINATE` (the common
    case, checked without numpy's per-call overhead), else None: then the full checks name what is wrong."""
    if all(type(v) is float and math.isfinite(v) and -MAX_COORDINATE <= v <= MAX_COORDINATE for v in values):
        array = np.array(values)
        array.setflags(write=False)
        return array
    return None


def point_from_msg(message: gm.Point | gm.Vector3, field: str = "position") -> NDArray[np.float64]:
    """``(x, y, z)`` of a point message: finite and within :data:`MAX_COORDINATE` m (errors name ``field``)."""
    fast = _checked((message.x, message.y, message.z))
    if fast is not None:
        return fast
    values = as_vector(field, (message.x, message.y, message.z), 3)
    if float(np.max(np.abs(values))) > MAX_COORDINATE:
        raise InvalidInput(field, values.tolist(), f"coordinates must be within ±{MAX_COORDINATE:g} m")
    return values


def quaternion_from_msg(message: gm.Quaternion, field: str = "orientation") -> NDArray[np.float64]:
    """``(x, y, z, w)`` of a quaternion message, finite with a norm in the accepted range (not yet unit)."""
    fast = _checked((message.x, message.y, message.z, message.w))
    if fast is not None and MIN_QUATERNION_NORM <= math.hypot(*fast.tolist()) <= MAX_QUATERNION_NORM:
        return fast
    values = as_vector(field, (message.x, message.y, message.z, message.w), 4)
    norm = scaled_norm(values)
    if norm < MIN_QUATERNION_NORM:
        raise InvalidInput(field, values.tolist(), "zero quaternion: give a unit quaternion, e.g. {w: 1.0}")
    if norm > MAX_QUATERNION_NORM:
        raise InvalidInput(field, values.tolist(), f"quaternion norm {norm:.3g} is above {MAX_QUATERNION_NORM:g}: "
                           "give a unit quaternion (x, y, z, w)")
    return values


def pose_from_msg(message: gm.Pose, field: str = "pose") -> Pose:
    """:class:`Pose` of a ``geometry_msgs/Pose``; errors name ``<field>.position`` / ``<field>.orientation``.

    Positions within :data:`MAX_COORDINATE`, quaternions of a norm in [:data:`MIN_QUATERNION_NORM`,
    :data:`MAX_QUATERNION_NORM`] (normalised here)."""
    position = point_from_msg(message.position, f"{field}.position")
    orientation = quaternion_from_msg(message.orientation, f"{field}.orientation")
    unit = orientation / float(np.linalg.norm(orientation))  # normalised as normalize_quaternion does
    unit.setflags(write=False)
    return pose_from_checked(position, unit)  # both checked just now (point_from_msg's arrays are read-only)


def pose_to_msg(pose: Pose) -> gm.Pose:
    x, y, z = (float(v) for v in pose.position)
    qx, qy, qz, qw = (float(v) for v in pose.orientation)
    return gm.Pose(position=gm.Point(x=x, y=y, z=z), orientation=gm.Quaternion(x=qx, y=qy, z=qz, w=qw))


def _vector3(values: Any) -> gm.Vector3:
    x, y, z = (float(v) for v in values)
    return gm.Vector3(x=x, y=y, z=z)


def twist_to_msg(twist: Twist) -> gm.Twist:
    return gm.Twist(linear=_vector3(twist.linear), angular=_vector3(twist.angular))


def _xyz(values: Any) -> dict[str, float]:
    x, y, z = values.tolist()
    return {"x": x, "y": y, "z": z}


def twist_stamped(twist: Twist, frame_id: str, seconds: float = 0.0) -> gm.TwistStamped:
    """The stamped message of ``twist`` (validated in one pass: the answer of every control-loop call)."""
    return gm.TwistStamped.model_validate(twist_stamped_fields(twist, frame_id, seconds))


def twist_stamped_fields(twist: Twist, frame_id: str, seconds: float = 0.0) -> dict[str, Any]:
    """The fields of :func:`twist_stamped` as plain data, for a caller that validates a whole answer once."""
    return {"header": {"stamp": Time.from_seconds(seconds), "frame_id": frame_id},
            "twist": {"linear": _xyz(twist.linear), "angular": _xyz(twist.angular)}}


def _shape(message: ObstacleMsg, make_mesh: Callable[[str, float, float, float], Any]) -> Any:
    from pfield import geometry

    kind = message.type
    if kind == "Sphere":
        return geometry.Sphere(radius=message.radius)
    if kind == "Box":
        return geometry.Box(length=message.length, width=message.width, height=message.height)
    if kind == "Cylinder":
        return geometry.Cylinder(radius=message.radius, height=message.height)
    if kind == "Ellipsoid":
        return geometry.Ellipsoid(semi_x=message.semi_x, semi_y=message.semi_y, semi_z=message.semi_z)
    if kind == "Capsule":
        return geometry.Capsule(radius=message.radius, height=message.height)
    if kind == "Mesh":
        return make_mesh(message.mesh_resource, message.scale_x, message.scale_y, message.scale_z)
    raise TypeError(f"no conversion from the message of obstacle shape {kind}")  # obstacle_from_msg checked the type


def obstacle_from_msg(message: ObstacleMsg, make_mesh: Callable[[str, float, float, float], Any],
                      field: str = "obstacle") -> Any:
    """A :class:`~pfield.geometry.Obstacle` from its message; ``make_mesh(resource, sx, sy, sz)`` builds Mesh
    shapes (it resolves the URI within the node's allowed roots). Errors name ``<field>.<member>``."""
    from pfield import geometry

    if not message.frame_id:
        raise InvalidInput(f"{field}.frame_id", message.frame_id, "every obstacle needs a unique id")
    if message.type not in geometry.SHAPE_TYPES:
        raise InvalidInput(f"{field}.type", message.type,
                           f"unknown shape; expected one of {', '.join(geometry.SHAPE_TYPES)}")
    if message.group not in geometry.GROUPS:
        raise InvalidInput(f"{field}.group", message.group,
                           f"unknown group; expected one of {', '.join(geometry.GROUPS)}")
    pose = pose_from_msg(message.pose, f"{field}.pose")
    try:
        shape = _shape(message, make_mesh)
    except InvalidInput as exc:
        raise prefixed(exc, field) from None
    return geometry.Obstacle(message.frame_id, shape, pose, group=message.group)


def obstacle_to_msg(obstacle: Any) -> ObstacleMsg:
    """The message of a :class:`~pfield.geometry.Obstacle` (fields of other shapes stay 0)."""
    shape = obstacle.shape
    data: dict[str, Any] = {"frame_id": obstacle.id, "type": type(shape).__name__, "group": obstacle.group,
                            "pose": pose_to_msg(obstacle.pose)}
    for name in ("radius", "height", "length", "width", "semi_x", "semi_y", "semi_z", "scale_x", "scale_y",
                 "scale_z"):
        if hasattr(shape, name):
            data[name] = float(getattr(shape, name))
    if hasattr(shape, "mesh_resource"):
        data["mesh_resource"] = str(shape.mesh_resource)
    return ObstacleMsg.model_validate(data)


def _stamps(times: NDArray[np.float64], field: str = "times") -> NDArray[np.int64]:
    """``(N, 2)`` ``sec``, ``nanosec`` of ``times`` (s) as :meth:`Time.from_seconds` rounds them (half to even).

    Raises :class:`InvalidInput` when a time does not fit ``builtin_interfaces/Time`` (``sec`` is an int32).
    """
    if times.size and not (np.all(np.isfinite(times)) and times.min() >= 0 and times.max() < _MAX_STAMP_S):
        raise InvalidInput(field, float(np.max(times)), f"a plan's times must lie in [0, {_MAX_STAMP_S:.0f}) s "
                           "(builtin_interfaces/Time holds int32 seconds)")
    total_ns = np.rint(times * 1e9).astype(np.int64)
    return np.column_stack([total_ns // 1_000_000_000, total_ns % 1_000_000_000])


_MAX_STAMP_S = 2.0**31 - 1.0
CHUNK_ROWS = 64
"""Waypoints written per step: each step holds the GIL for about a quarter of a millisecond, so control-loop
requests keep answering while a long plan's answer is written (and the answer can be streamed). 256 rows
wrote a 200 000-waypoint answer 10 % faster but doubled the autonomy calls' p99 while it was written."""


def _text(value: str) -> str:
    """JSON string of ``value`` as pydantic writes it."""
    return to_json(value).decode()


def _texts(block: NDArray[Any]) -> list[str]:
    """The JSON text of every value of ``block`` in row-major order, written by pydantic's own number
    formatter (so each number is spelled as ``model_dump_json`` spells it)."""
    if block.size == 0:
        return []
    return to_json(block.ravel().tolist()).decode()[1:-1].split(",")


def _rows(template: str, frame: str, blocks: Callable[[slice], tuple[NDArray[Any], ...]],
          count: int) -> Iterator[str]:
    """``template`` filled for each of ``count`` rows, comma-separated, :data:`CHUNK_ROWS` rows at a time.

    In ``template`` ``{}`` marks a value (taken in order from the row of ``blocks(rows)``, each ``(rows, k)``)
    and ``{frame}`` the JSON text ``frame``. The pieces are interleaved by slice assignment: no per-row Python.
    """
    fragments = [piece.replace("{frame}", frame) for piece in template.split("{}")]
    slots = len(fragments) - 1
    width = 2 * slots + 1
    for start in range(0, count, CHUNK_ROWS):
        parts = blocks(slice(start, start + CHUNK_ROWS))
        rows = parts[0].shape[0]
        out: list[str] = [""] * (rows * width)
        for i, fragment in enumerate(fragments):
            out[2 * i::width] = [fragment + ","] * rows if i == slots else [fragment] * rows
        slot = 0
        for part in parts:
            texts = _texts(part)
            for i in range(part.shape[1]):
                out[2 * slot + 1::width] = texts[i::part.shape[1]]
                slot += 1
        out[0] = fragments[0] if start == 0 else "," + fragments[0]
        out[-1] = fragments[-1]
        yield "".join(out)


@dataclass(frozen=True, eq=False)
class _PlanJson:
    """A plan's arrays and the JSON of its ``PlanPath`` response parts, written from the arrays directly.

    The text equals what pydantic writes for the same models, byte for byte (numbers go through pydantic's
    formatter), but no per-waypoint object is built, and it comes in chunks of :data:`CHUNK_ROWS` waypoints.
    """

    path: PlannedPath
    frame_id: str

    def header(self, frame_id: str | None = None) -> str:
        name = to_json(self.frame_id if frame_id is None else frame_id).decode()
        return '{"stamp":{"sec":0,"nanosec":0},"frame_id":' + name + "}"

    _STAMPED = '{"header":{"stamp":{"sec":{},"nanosec":{}},"frame_id":{frame}},'

    def poses(self) -> Iterator[str]:
        path, stamps = self.path, _stamps(self.path.times)
        template = (self._STAMPED + '"pose":{"position":{"x":{},"y":{},"z":{}},'
                    '"orientation":{"x":{},"y":{},"z":{},"w":{}}}}')
        yield "["
        yield from _rows(template, _text(self.frame_id),
                         lambda rows: (stamps[rows], path.positions[rows], path.orientations[rows]), len(path.times))
        yield "]"

    def twists(self) -> Iterator[str]:
        path, stamps = self.path, _stamps(self.path.times)
        template = self._STAMPED + '"twist":{"linear":{"x":{},"y":{},"z":{}},"angular":{"x":{},"y":{},"z":{}}}}'
        yield "["
        yield from _rows(template, _text(self.frame_id), lambda rows: (stamps[rows], path.twists[rows]),
                         len(path.times))
        yield "]"

    def joint_trajectory(self) -> Iterator[str]:
        """The time-parameterised trajectory when the plan has one (positions, velocities, accelerations and
        ``time_from_start`` of :attr:`PlannedPath.trajectory`, as a JointTrajectoryController expects), else
        the planner's samples (positions and velocities at ``times``)."""
        path = self.path
        if path.joint_positions is None:
            yield '{"header":' + self.header("") + ',"joint_names":[],"points":[]}'
            return
        timed = path.trajectory
        if timed is not None:
            blocks: tuple[NDArray[Any], ...] = (timed.positions, timed.velocities, timed.accelerations)
            stamps, names = _stamps(timed.times, "trajectory.times"), timed.joint_names
        else:
            positions = path.joint_positions
            velocities = path.joint_velocities if path.joint_velocities is not None else np.zeros_like(positions)
            blocks, stamps, names = (positions, velocities), _stamps(path.times), path.joint_names
        values = ",".join(["{}"] * blocks[0].shape[1])
        accelerations = values if timed is not None else ""
        template = ('{"positions":[' + values + '],"velocities":[' + values + '],"accelerations":[' + accelerations
                    + '],"effort":[],"time_from_start":{"sec":{},"nanosec":{}}}')
        yield '{"header":' + self.header() + ',"joint_names":' + to_json(list(names)).decode() + ',"points":['
        yield from _rows(template, "", lambda rows: (*(block[rows] for block in blocks), stamps[rows]),
                         len(stamps))
        yield "]}"

    def end_effector_path(self) -> Iterator[str]:
        yield '{"header":' + self.header() + ',"poses":'
        yield from self.poses()
        yield "}"

    def response(self) -> Iterator[str]:
        yield '{"success":' + ("true" if self.path.success else "false") + ',"end_effector_path":'
        yield from self.end_effector_path()
        yield ',"joint_trajectory":'
        yield from self.joint_trajectory()
        yield ',"end_effector_velocity_trajectory":'
        yield from self.twists()
        yield ',"error_message":' + to_json(self.path.failure_reason).decode() + "}"


_MATERIALISING = threading.RLock()
"""Held while a lazy plan model builds its pydantic objects (re-entrant: nested models build inside)."""


class _Lazy:
    """Mixin of the plan-response models whose large lists (``_lazy_fields``) are held as arrays: their JSON
    is written from the arrays (:class:`_PlanJson`), and the pydantic objects are built only when a field is
    read (then exactly what validating the JSON gives)."""

    _lazy_fields: ClassVar[tuple[str, ...]] = ()

    def _materialise(self: Any) -> None:
        with _MATERIALISING:
            missing = [name for name in self._lazy_fields if name not in self.__dict__]
            if missing:
                base: Any = type(self).__mro__[2]  # the message model (this class, _Lazy, model)
                full = base.model_validate_json(self.model_dump_json())
                values = self.__dict__ | {name: getattr(full, name) for name in missing}
                self.__dict__.clear()  # in field order, as pydantic writes them
                self.__dict__.update({name: values[name] for name in type(self).model_fields})
            for value in list(self.__dict__.values()):
                if isinstance(value, _Lazy):
                    value._materialise()

    def __getattr__(self, name: str) -> Any:
        if name in type(self)._lazy_fields or name in type(self).model_fields:  # type: ignore[attr-defined]
            # a field not in __dict__: lazy, or being rebuilt by another thread (the ROS 2 publisher and a
            # service answer may read one plan's path at once): wait for that, then read it
            with _MATERIALISING:
                if name in type(self)._lazy_fields:
                    self._materialise()
                if name in self.__dict__:
                    return self.__dict__[name]
        return super().__getattr__(name)  # type: ignore[misc]

    def json_chunks(self) -> Iterator[str]:
        """The JSON of :meth:`model_dump_json` in pieces (a transport may stream them)."""
        return self._plan_chunks()  # type: ignore[attr-defined, no-any-return]

    def model_dump_json(self, **kwargs: Any) -> str:
        if not kwargs:
            return "".join(self.json_chunks())
        self._materialise()
        return super().model_dump_json(**kwargs)  # type: ignore[misc, no-any-return]

    def model_dump(self, **kwargs: Any) -> dict[str, Any]:
        self._materialise()
        return super().model_dump(**kwargs)  # type: ignore[misc, no-any-return]

    def __iter__(self) -> Any:
        self._materialise()
        return super().__iter__()  # type: ignore[misc]

    def __repr_args__(self) -> Any:
        self._materialise()
        return super().__repr_args__()  # type: ignore[misc]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RosMessage) or other.ros_type != type(self).ros_type:  # type: ignore[attr-defined]
            return NotImplemented
        return self.model_dump() == other.model_dump()

    __hash__ = None  # type: ignore[assignment]


class _ArrayPath(_Lazy, Path):
    _lazy_fields: ClassVar[tuple[str, ...]] = ("poses",)
    _plan: _PlanJson = PrivateAttr()

    def _plan_chunks(self) -> Iterator[str]:
        return self._plan.end_effector_path()


class _ArrayJointTrajectory(_Lazy, JointTrajectory):
    _lazy_fields: ClassVar[tuple[str, ...]] = ("points",)
    _plan: _PlanJson = PrivateAttr()

    def _plan_chunks(self) -> Iterator[str]:
        return self._plan.joint_trajectory()


class _ArrayPlanResponse(_Lazy, PlanPath_Response):
    _lazy_fields: ClassVar[tuple[str, ...]] = ("end_effector_velocity_trajectory",)
    _plan: _PlanJson = PrivateAttr()

    def _plan_chunks(self) -> Iterator[str]:
        return self._plan.response()


def _lazy(model: type[Any], plan: _PlanJson, **values: Any) -> Any:
    message = model.model_construct(**values)
    for name in model._lazy_fields:
        message.__dict__.pop(name, None)
    message._plan = plan
    return message


def plan_response(path: PlannedPath, frame_id: str) -> PlanPath_Response:
    """``PlanPath`` response of a plan: poses and twists stamped ``times[i]`` (= i·dt, s) in ``frame_id``; the
    joint trajectory is the retimed :attr:`PlannedPath.trajectory` when the plan has one.

    Built without one pydantic object per waypoint: the response (and its ``end_effector_path``, which the
    node publishes) write their JSON straight from the plan's arrays, and build the per-waypoint models only
    if a field is read (the ROS 2 transport does). A plan time beyond ``builtin_interfaces/Time`` (2^31 s)
    raises :class:`InvalidInput` naming ``times``.
    """
    _stamps(path.times)  # refuse unrepresentable times before anything is built
    if path.trajectory is not None:
        _stamps(path.trajectory.times, "trajectory.times")
    plan = _PlanJson(path, frame_id)
    header = Header(frame_id=frame_id)
    trajectory = (JointTrajectory() if path.joint_positions is None else
                  _lazy(_ArrayJointTrajectory, plan, header=header, joint_names=list(path.joint_names)))
    return _lazy(_ArrayPlanResponse, plan, success=path.success,  # type: ignore[no-any-return]
                 end_effector_path=_lazy(_ArrayPath, plan, header=header), joint_trajectory=trajectory,
                 error_message=path.failure_reason)
