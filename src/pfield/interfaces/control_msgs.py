"""``control_msgs`` messages pfield takes in: ``JointJog`` (the servo loop's joint jog, MoveIt Servo's
``~/delta_joint_cmds``).

Fields exactly as ``control_msgs/msg/JointJog`` (Jazzy, 5.8.0), built with the FollowJointTrajectory subset by
``make ros2-interfaces`` from ``ros/control_msgs`` (NOTICE.md there).
"""

from __future__ import annotations

from pydantic import Field

from pfield.interfaces._base import Float64, RosMessage, String
from pfield.interfaces.std_msgs import Header

__all__ = ["JointJog"]


class JointJog(RosMessage):
    """Joint velocities (rad/s or m/s) or displacements (rad or m) by joint name, in ``joint_names``' order (not all
    of the robot's joints need be named), and a ``duration`` (s). pfield's servo reads the names and velocities
    only."""

    ros_type = "control_msgs/msg/JointJog"
    header: Header = Field(default_factory=Header)
    joint_names: list[String] = Field(default_factory=list)
    displacements: list[Float64] = Field(default_factory=list)
    velocities: list[Float64] = Field(default_factory=list)
    duration: Float64 = 0.0
