"""Conversions between the message models and pfield's core types.

* ``geometry_msgs`` ↔ :class:`~pfield.spatial.Pose` / :class:`~pfield.spatial.Twist` (quaternions x, y, z, w,
  normalised on input; a zero or non-finite quaternion is rejected naming the field path);
* ``potential_fields_interfaces/Obstacle`` ↔ :class:`~pfield.geometry.Obstacle` (the seed's shape table:
  Sphere radius, Box length/width/height full extents, Cylinder radius/height, Ellipsoid semi-axes,
  Capsule radius/shaft height, Mesh resource + scale);
* :class:`~pfield.planning.result.PlannedPath` → ``PlanPath`` response: ``nav_msgs/Path`` and one
  ``TwistStamped`` per waypoint stamped ``i·dt`` s, a ``JointTrajectory`` with joint names.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from pfield.errors import InvalidInput
from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces.potential_fields_interfaces import Obstacle as ObstacleMsg
from pfield.interfaces.potential_fields_interfaces import PlanPath_Response
from pfield.interfaces.std_msgs import Duration, Header, Time
from pfield.interfaces.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from pfield.planning.result import PlannedPath
from pfield.spatial import Pose, Twist

__all__ = [
    "obstacle_from_msg",
    "obstacle_to_msg",
    "plan_response",
    "pose_from_msg",
    "pose_to_msg",
    "prefixed",
    "twist_stamped",
    "twist_to_msg",
]

def prefixed(error: InvalidInput, prefix: str) -> InvalidInput:
    """The same error with its field path under ``prefix`` (``radius`` → ``obstacles[2].radius``)."""
    return type(error)(f"{prefix}.{error.field}" if prefix else error.field, error.value, error.reason)


def pose_from_msg(message: gm.Pose, field: str = "pose") -> Pose:
    """:class:`Pose` of a ``geometry_msgs/Pose``; errors name ``<field>.position`` / ``<field>.orientation``."""
    p, q = message.position, message.orientation
    try:
        return Pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
    except InvalidInput as exc:
        raise prefixed(exc, field) from None


def pose_to_msg(pose: Pose) -> gm.Pose:
    x, y, z = (float(v) for v in pose.position)
    qx, qy, qz, qw = (float(v) for v in pose.orientation)
    return gm.Pose(position=gm.Point(x=x, y=y, z=z), orientation=gm.Quaternion(x=qx, y=qy, z=qz, w=qw))


def _vector3(values: Any) -> gm.Vector3:
    x, y, z = (float(v) for v in values)
    return gm.Vector3(x=x, y=y, z=z)


def twist_to_msg(twist: Twist) -> gm.Twist:
    return gm.Twist(linear=_vector3(twist.linear), angular=_vector3(twist.angular))


def twist_stamped(twist: Twist, frame_id: str, seconds: float = 0.0) -> gm.TwistStamped:
    return gm.TwistStamped(header=Header(stamp=Time.from_seconds(seconds), frame_id=frame_id),
                           twist=twist_to_msg(twist))


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
    return make_mesh(message.mesh_resource, message.scale_x, message.scale_y, message.scale_z)


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


def _joint_trajectory(path: PlannedPath, header: Header) -> JointTrajectory:
    """The time-parameterised trajectory when the plan has one (velocities and accelerations filled, as a
    JointTrajectoryController expects), else the planner's samples."""
    if path.trajectory is not None and path.joint_positions is not None:
        timed = path.trajectory
        timed_points = [JointTrajectoryPoint(positions=q.tolist(), velocities=v.tolist(), accelerations=a.tolist(),
                                             time_from_start=Duration.from_seconds(t))
                        for q, v, a, t in zip(timed.positions, timed.velocities, timed.accelerations,
                                              timed.times.tolist(), strict=True)]
        return JointTrajectory(header=header, joint_names=list(timed.joint_names), points=timed_points)
    if path.joint_positions is None:
        return JointTrajectory()
    velocities = path.joint_velocities if path.joint_velocities is not None else np.zeros_like(path.joint_positions)
    points = [JointTrajectoryPoint(positions=q.tolist(), velocities=v.tolist(),
                                   time_from_start=Duration.from_seconds(t))
              for q, v, t in zip(path.joint_positions, velocities, path.times.tolist(), strict=True)]
    return JointTrajectory(header=header, joint_names=list(path.joint_names), points=points)


def plan_response(path: PlannedPath, frame_id: str) -> PlanPath_Response:
    """``PlanPath`` response of a plan: poses and twists stamped ``times[i]`` (= i·dt, s) in ``frame_id``."""
    header = Header(frame_id=frame_id)
    poses, twists = [], []
    for t, p, q, v in zip(path.times.tolist(), path.positions.tolist(), path.orientations.tolist(),
                          path.twists.tolist(), strict=True):
        stamped_header = Header(stamp=Time.from_seconds(t), frame_id=frame_id)
        pose = gm.Pose(position=gm.Point(x=p[0], y=p[1], z=p[2]),
                       orientation=gm.Quaternion(x=q[0], y=q[1], z=q[2], w=q[3]))
        poses.append(gm.PoseStamped(header=stamped_header, pose=pose))
        twists.append(gm.TwistStamped(header=stamped_header,
                                      twist=gm.Twist(linear=_vector3(v[:3]), angular=_vector3(v[3:]))))
    from pfield.interfaces.nav_msgs import Path

    return PlanPath_Response(success=path.success, end_effector_path=Path(header=header, poses=poses),
                             joint_trajectory=_joint_trajectory(path, header),
                             end_effector_velocity_trajectory=twists, error_message=path.failure_reason)
