"""MoveIt ``PlanningScene`` and ``MotionPlanRequest`` YAML into pfield obstacles, start and goal.

The layout is moveit_msgs' (MoveIt 2, ``moveit_msgs/msg/PlanningScene`` and ``MotionPlanRequest``), as
``ros2 topic echo`` and MoveIt's scene/request dumps write it, and as MotionBenchMaker (Chamzas et al.,
RA-L 2022) stores its problems. Poses may be written as ROS mappings (``{x: …, y: …, z: …}``,
orientation ``{x, y, z, w}``) or as lists (``[x, y, z]``, ``[x, y, z, w]``, the MBM files' form).

What maps (shape_msgs/SolidPrimitive; ``dimensions`` indices are the message's constants):

* ``box`` [x, y, z] full extents → :class:`~pfield.geometry.Box` (length=x, width=y, height=z);
* ``sphere`` [radius] → :class:`~pfield.geometry.Sphere`;
* ``cylinder`` [height, radius] → :class:`~pfield.geometry.Cylinder` (axis along local z);
* ``meshes`` (shape_msgs/Mesh: ``vertices``, ``triangles[].vertex_indices``) → :class:`~pfield.geometry.Mesh`.

A collision object's ``pose`` (MoveIt ≥ 2: the object's frame) is composed with each shape's
``primitive_poses`` / ``mesh_poses`` entry; ``subframe_names`` / ``subframe_poses`` are named frames of the
object, not geometry, and are checked but add no obstacle. Refused, naming the part: cones (pfield has no
cone shape), planes, octomaps, attached collision objects, operations other than ADD, frames other than
the world frame, path or trajectory constraints, and more than one goal constraint set.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pfield._validation import finite, number, text
from pfield.errors import InvalidInput
from pfield.geometry import Box, Cylinder, Mesh, Obstacle, Shape, Sphere
from pfield.spatial import Pose

__all__ = ["WORLD_FRAMES", "MotionRequest", "pose_from_moveit", "request_from_moveit", "scene_obstacles"]

WORLD_FRAMES = ("", "world")
"""Frame ids taken as the world frame (an empty ``frame_id`` means the scene's planning frame)."""
_PRIMITIVES = {1: "box", 2: "sphere", 3: "cylinder", 4: "cone"}
_ADD = (0, "ADD", "add")


def _mapping(where: str, value: Any) -> Mapping[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise InvalidInput(where, value, "expected a mapping")
    return value


def _number(where: str, value: Any) -> float:
    """A finite number as ROS types it: an int or a float, never a string or a boolean (``"0.5"``, ``true``)."""
    return finite(where, number(where, value))


def _list(where: str, value: Any) -> list[Any]:
    if value is None:
        return []
    if not isinstance(value, list):
        raise InvalidInput(where, value, "expected a list")
    return value


def _vector(where: str, value: Any, names: str) -> list[float]:
    if isinstance(value, Mapping):
        unknown = set(value) - set(names)
        if unknown:
            raise InvalidInput(where, value, f"unknown keys {sorted(unknown)}; expected {list(names)}")
        default = {"w": 1.0} if names == "xyzw" else {}
        values = [value.get(name, default.get(name, 0.0)) for name in names]
    elif isinstance(value, list | tuple):
        if len(value) != len(names):
            raise InvalidInput(where, value, f"expected {len(names)} numbers ({', '.join(names)})")
        values = list(value)
    else:
        raise InvalidInput(where, value, f"expected a mapping of {list(names)} or a list")
    return [_number(f"{where}.{name}", v) for name, v in zip(names, values, strict=True)]


def pose_from_moveit(where: str, value: Any) -> Pose:
    """A geometry_msgs/Pose written as a mapping or with list-valued position/orientation (missing: identity)."""
    data = _mapping(where, value)
    unknown = set(data) - {"position", "orientation"}
    if unknown:
        raise InvalidInput(where, dict(data), f"unknown pose keys {sorted(unknown)}; expected position, orientation")
    position = _vector(f"{where}.position", data.get("position", [0.0, 0.0, 0.0]), "xyz")
    orientation = _vector(f"{where}.orientation", data.get("orientation", [0.0, 0.0, 0.0, 1.0]), "xyzw")
    if np.linalg.norm(orientation) < 1e-9:
        raise InvalidInput(f"{where}.orientation", orientation, "a zero quaternion has no rotation")
    return Pose(position, orientation)


def _check_frame(where: str, header: Any, frames: Sequence[str]) -> None:
    frame = _mapping(f"{where}.header", header).get("frame_id", "")
    frame = text(f"{where}.header.frame_id", frame) if frame else ""
    if frame not in frames:
        raise InvalidInput(f"{where}.header.frame_id", frame,
                           f"only the world frame is supported (one of {list(frames)})")


def _primitive(where: str, primitive: Any) -> Shape:
    data = _mapping(where, primitive)
    kind = data.get("type")
    name = _PRIMITIVES.get(kind, kind) if isinstance(kind, int) and not isinstance(kind, bool) else kind
    dims = [_number(f"{where}.dimensions[{i}]", d) for i, d in enumerate(_list(f"{where}.dimensions",
                                                                              data.get("dimensions")))]
    expected = {"box": 3, "sphere": 1, "cylinder": 2}
    if name == "cone":
        raise InvalidInput(f"{where}.type", kind, "cone primitives are not supported (pfield has no cone shape)")
    if name not in expected:
        raise InvalidInput(f"{where}.type", kind, "unknown primitive; expected box, sphere, cylinder (or 1, 2, 3)")
    if len(dims) != expected[name]:
        raise InvalidInput(f"{where}.dimensions", dims, f"a {name} takes {expected[name]} dimensions")
    try:
        if name == "box":
            return Box(length=dims[0], width=dims[1], height=dims[2])
        if name == "sphere":
            return Sphere(radius=dims[0])
        return Cylinder(radius=dims[1], height=dims[0])
    except InvalidInput as exc:
        raise InvalidInput(f"{where}.{exc.field}", exc.value, exc.reason) from None


def _mesh(where: str, mesh: Any, name: str) -> Mesh:
    data = _mapping(where, mesh)
    vertices = [_vector(f"{where}.vertices[{i}]", v, "xyz") for i, v in enumerate(_list(f"{where}.vertices",
                                                                                           data.get("vertices")))]
    faces = []
    for i, triangle in enumerate(_list(f"{where}.triangles", data.get("triangles"))):
        indices = _mapping(f"{where}.triangles[{i}]", triangle).get("vertex_indices")
        if (not isinstance(indices, list) or len(indices) != 3
                or not all(isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(vertices) for k in indices)):
            raise InvalidInput(f"{where}.triangles[{i}].vertex_indices", indices,
                               f"expected 3 vertex indices in [0, {len(vertices)})")
        faces.append(indices)
    if not faces:
        raise InvalidInput(f"{where}.triangles", [], "a mesh needs at least one triangle")
    try:
        return Mesh.from_arrays(np.array(vertices), np.array(faces), name=name)
    except InvalidInput as exc:
        raise InvalidInput(f"{where}.{exc.field}", exc.value, exc.reason) from None


def _shapes(where: str, item: Mapping[str, Any], kind: str, poses_key: str) -> list[tuple[str, Any, Pose]]:
    shapes = _list(f"{where}.{kind}", item.get(kind))
    poses = _list(f"{where}.{poses_key}", item.get(poses_key))
    if len(poses) != len(shapes):
        raise InvalidInput(f"{where}.{poses_key}", len(poses), f"expected one pose per entry of {kind} ({len(shapes)})")
    return [(f"{where}.{kind}[{i}]", shape, pose_from_moveit(f"{where}.{poses_key}[{i}]", pose))
            for i, (shape, pose) in enumerate(zip(shapes, poses, strict=True))]


def _collision_object(where: str, value: Any, frames: Sequence[str]) -> list[Obstacle]:
    item = _mapping(where, value)
    identifier = text(f"{where}.id", item.get("id", ""))
    _check_frame(where, item.get("header"), frames)
    operation = item.get("operation", 0)
    if operation not in _ADD:
        raise InvalidInput(f"{where}.operation", operation, "only ADD (0) collision objects are supported")
    if _list(f"{where}.planes", item.get("planes")):
        raise InvalidInput(f"{where}.planes", item["planes"], "plane shapes are not supported")
    names = _list(f"{where}.subframe_names", item.get("subframe_names"))
    for i, _ in enumerate(_shapes(where, {"s": names, "p": item.get("subframe_poses")}, "s", "p")):
        text(f"{where}.subframe_names[{i}]", names[i])
    origin = pose_from_moveit(f"{where}.pose", item.get("pose"))
    parts = _shapes(where, item, "primitives", "primitive_poses") + _shapes(where, item, "meshes", "mesh_poses")
    obstacles = []
    for k, (part, shape, pose) in enumerate(parts):
        name = f"{identifier}_{k}" if len(parts) > 1 else identifier
        made = _mesh(part, shape, name) if ".meshes[" in part else _primitive(part, shape)
        obstacles.append(Obstacle(name, made, origin * pose))
    return obstacles


def scene_obstacles(scene: Any, frames: Sequence[str] = WORLD_FRAMES) -> list[Obstacle]:
    """The obstacles of a MoveIt PlanningScene (a parsed YAML mapping): ``world.collision_objects``.

    ``frames`` are the frame ids taken as the world frame (add the robot's base link when it sits at the
    world origin). Obstacle ids are the objects' ids, with ``_k`` appended per shape when an object has
    several. Raises :class:`~pfield.errors.InvalidInput` naming the part that is malformed or unsupported.
    """
    data = _mapping("scene", scene)
    state = _mapping("scene.robot_state", data.get("robot_state"))
    if _list("scene.robot_state.attached_collision_objects", state.get("attached_collision_objects")):
        raise InvalidInput("scene.robot_state.attached_collision_objects", "…",
                           "attached collision objects are not supported")
    world = _mapping("scene.world", data.get("world"))
    octomap = _mapping("scene.world.octomap", world.get("octomap"))
    if _list("scene.world.octomap.octomap.data", _mapping("octomap", octomap.get("octomap")).get("data")):
        raise InvalidInput("scene.world.octomap", "…", "octomaps are not supported")
    obstacles = []
    for i, item in enumerate(_list("scene.world.collision_objects", world.get("collision_objects"))):
        obstacles.extend(_collision_object(f"scene.world.collision_objects[{i}]", item, frames))
    ids = [o.id for o in obstacles]
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        raise InvalidInput("scene.world.collision_objects", duplicates, "collision object ids must be unique")
    return obstacles


@dataclass(frozen=True)
class MotionRequest:
    """The parts of a MotionPlanRequest pfield plans with.

    ``start`` maps joint names to positions (rad or m); the goal is either ``goal_joints`` (joint name →
    position) or ``goal_pose`` of ``goal_link`` (world frame; the position constraint's region centre plus
    its target offset, the orientation constraint's orientation).
    """

    start: dict[str, float]
    goal_joints: dict[str, float] | None = None
    goal_pose: Pose | None = None
    goal_link: str = ""
    group_name: str = ""


def _goal_pose(where: str, goal: Mapping[str, Any], frames: Sequence[str]) -> tuple[Pose, str]:
    positions = _list(f"{where}.position_constraints", goal.get("position_constraints"))
    orientations = _list(f"{where}.orientation_constraints", goal.get("orientation_constraints"))
    if len(positions) != 1 or len(orientations) > 1:
        raise InvalidInput(f"{where}.position_constraints", len(positions),
                           "a pose goal needs one position constraint and at most one orientation constraint")
    constraint = _mapping(f"{where}.position_constraints[0]", positions[0])
    _check_frame(f"{where}.position_constraints[0]", constraint.get("header"), frames)
    link = text(f"{where}.position_constraints[0].link_name", constraint.get("link_name", ""))
    region = _mapping(f"{where}.position_constraints[0].constraint_region", constraint.get("constraint_region"))
    centres = _list(f"{where}.position_constraints[0].constraint_region.primitive_poses", region.get("primitive_poses"))
    if not centres:
        raise InvalidInput(f"{where}.position_constraints[0].constraint_region.primitive_poses", [],
                           "the constraint region needs a pose")
    centre = pose_from_moveit(f"{where}.position_constraints[0].constraint_region.primitive_poses[0]", centres[0])
    offset = _vector(f"{where}.position_constraints[0].target_point_offset",
                     constraint.get("target_point_offset", [0.0, 0.0, 0.0]), "xyz")
    orientation = np.array([0.0, 0.0, 0.0, 1.0])
    if orientations:
        item = _mapping(f"{where}.orientation_constraints[0]", orientations[0])
        _check_frame(f"{where}.orientation_constraints[0]", item.get("header"), frames)
        other = item.get("link_name", link)
        if other != link:
            raise InvalidInput(f"{where}.orientation_constraints[0].link_name", other,
                               f"must name the position constraint's link {link!r}")
        orientation = np.array(_vector(f"{where}.orientation_constraints[0].orientation", item.get("orientation"),
                                       "xyzw"))
    goal_pose = Pose(centre.position, orientation)
    # the target point is offset in the link frame: the link's origin sits at centre − R·offset
    return Pose(centre.position - goal_pose.rotation @ np.array(offset), orientation), link


def request_from_moveit(request: Any, frames: Sequence[str] = WORLD_FRAMES) -> MotionRequest:
    """The start state and goal of a MoveIt MotionPlanRequest (a parsed YAML mapping).

    The start is ``start_state.joint_state`` (``name`` and ``position`` of equal length); the goal is
    ``goal_constraints[0]``: its ``joint_constraints`` (a joint goal) or one position constraint plus at
    most one orientation constraint (a pose goal). Raises :class:`~pfield.errors.InvalidInput` naming the part.
    """
    data = _mapping("request", request)
    state = _mapping("request.start_state.joint_state",
                     _mapping("request.start_state", data.get("start_state")).get("joint_state"))
    names = _list("request.start_state.joint_state.name", state.get("name"))
    values = _list("request.start_state.joint_state.position", state.get("position"))
    if len(names) != len(values):
        raise InvalidInput("request.start_state.joint_state.position", len(values),
                           f"expected one position per joint name ({len(names)})")
    start = {text(f"request.start_state.joint_state.name[{i}]", n):
             _number(f"request.start_state.joint_state.position[{i}]", v)
             for i, (n, v) in enumerate(zip(names, values, strict=True))}
    for key in ("path_constraints", "trajectory_constraints"):
        value = data.get(key)
        constraints = _mapping(f"request.{key}", value)
        if any(_list(f"request.{key}.{k}", v) for k, v in constraints.items() if k != "name"):
            raise InvalidInput(f"request.{key}", dict(constraints), f"{key.replace('_', ' ')} are not supported")
    goals = _list("request.goal_constraints", data.get("goal_constraints"))
    if len(goals) != 1:
        raise InvalidInput("request.goal_constraints", len(goals), "expected exactly one goal constraint set")
    goal = _mapping("request.goal_constraints[0]", goals[0])
    joints = _list("request.goal_constraints[0].joint_constraints", goal.get("joint_constraints"))
    group = data.get("group_name", "")
    group = text("request.group_name", group) if group else ""
    if joints:
        if goal.get("position_constraints") or goal.get("orientation_constraints"):
            raise InvalidInput("request.goal_constraints[0]", "…",
                               "a goal with both joint and pose constraints is not supported")
        goal_joints = {}
        for i, item in enumerate(joints):
            where = f"request.goal_constraints[0].joint_constraints[{i}]"
            entry = _mapping(where, item)
            goal_joints[text(f"{where}.joint_name", entry.get("joint_name"))] = _number(f"{where}.position",
                                                                                       entry.get("position"))
        return MotionRequest(start, goal_joints=goal_joints, group_name=group)
    pose, link = _goal_pose("request.goal_constraints[0]", goal, frames)
    return MotionRequest(start, goal_pose=pose, goal_link=link, group_name=group)
