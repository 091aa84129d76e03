"""The ``PlanPath`` response built as one validated pydantic object per waypoint (how pfield built it before
its JSON was written from the arrays): the reference the fast encoding is compared with."""

from __future__ import annotations

import numpy as np

from pfield.interfaces import geometry_msgs as gm
from pfield.interfaces.nav_msgs import Path
from pfield.interfaces.potential_fields_interfaces import PlanPath_Response
from pfield.interfaces.std_msgs import Duration, Header, Time
from pfield.interfaces.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from pfield.planning.result import PlannedPath


def _vector3(values: list[float]) -> gm.Vector3:
    return gm.Vector3(x=values[0], y=values[1], z=values[2])


def reference_response(path: PlannedPath, frame_id: str) -> PlanPath_Response:
    header = Header(frame_id=frame_id)
    poses, twists = [], []
    for t, p, q, v in zip(path.times.tolist(), path.positions.tolist(), path.orientations.tolist(),
                          path.twists.tolist(), strict=True):
        stamped = Header(stamp=Time.from_seconds(t), frame_id=frame_id)
        pose = gm.Pose(position=gm.Point(x=p[0], y=p[1], z=p[2]),
                       orientation=gm.Quaternion(x=q[0], y=q[1], z=q[2], w=q[3]))
        poses.append(gm.PoseStamped(header=stamped, pose=pose))
        twists.append(gm.TwistStamped(header=stamped, twist=gm.Twist(linear=_vector3(v[:3]),
                                                                     angular=_vector3(v[3:]))))
    trajectory = JointTrajectory()
    if path.joint_positions is not None and path.trajectory is not None:  # the retimed trajectory
        timed = path.trajectory
        points = [JointTrajectoryPoint(positions=q.tolist(), velocities=v.tolist(), accelerations=a.tolist(),
                                       time_from_start=Duration.from_seconds(t))
                  for q, v, a, t in zip(timed.positions, timed.velocities, timed.accelerations, timed.times.tolist(),
                                        strict=True)]
        trajectory = JointTrajectory(header=header, joint_names=list(timed.joint_names), points=points)
    elif path.joint_positions is not None:
        velocities = path.joint_velocities if path.joint_velocities is not None else \
            np.zeros_like(path.joint_positions)
        points = [JointTrajectoryPoint(positions=q.tolist(), velocities=v.tolist(),
                                       time_from_start=Duration.from_seconds(t))
                  for q, v, t in zip(path.joint_positions, velocities, path.times.tolist(), strict=True)]
        trajectory = JointTrajectory(header=header, joint_names=list(path.joint_names), points=points)
    return PlanPath_Response(success=path.success, end_effector_path=Path(header=header, poses=poses),
                             joint_trajectory=trajectory, end_effector_velocity_trajectory=twists,
                             error_message=path.failure_reason)
