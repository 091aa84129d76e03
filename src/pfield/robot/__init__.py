"""Robots: URDF models (pinocchio), compiled kinematics, link capsules, collision checks and IK."""

from pfield.robot.description import RobotDescription
from pfield.robot.model import RobotModel

__all__ = ["RobotDescription", "RobotModel"]
