"""``trajectory_msgs`` messages (joint trajectories of whole-body plans)."""

from __future__ import annotations

from pydantic import Field

from pfield.interfaces._base import Float64, RosMessage, String
from pfield.interfaces.std_msgs import Duration, Header


class JointTrajectoryPoint(RosMessage):
    """Joint positions (rad or m), velocities, accelerations and efforts at ``time_from_start``."""

    ros_type = "trajectory_msgs/msg/JointTrajectoryPoint"
    positions: list[Float64] = Field(default_factory=list)
    velocities: list[Float64] = Field(default_factory=list)
    accelerations: list[Float64] = Field(default_factory=list)
    effort: list[Float64] = Field(default_factory=list)
    time_from_start: Duration = Field(default_factory=Duration)


class JointTrajectory(RosMessage):
    ros_type = "trajectory_msgs/msg/JointTrajectory"
    header: Header = Field(default_factory=Header)
    joint_names: list[String] = Field(default_factory=list)
    points: list[JointTrajectoryPoint] = Field(default_factory=list)
