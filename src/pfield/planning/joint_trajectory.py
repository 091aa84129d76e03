"""Joint trajectories for task-space plans: inverse kinematics along the planned end-effector path.

:func:`attach_joint_trajectory` solves the IK of :mod:`pfield.robot.ik` at every waypoint of a
:class:`PlannedPath` — the start included, so waypoint i's joint angles belong to waypoint i's pose — each
seeded from the previous solution (the first from the caller's ``q_seed``, e.g. the robot's current
joints), which keeps the trajectory on one IK branch. Joint velocities are forward differences
(q_{i+1} − q_i)/dt, zero at the last waypoint.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from pfield.errors import InvalidInput
from pfield.planning.result import PlannedPath
from pfield.planning.retime import retime_joint_path
from pfield.planning.status import PlanStatus
from pfield.robot.ik import ik_settings, solve_ik_path
from pfield.robot.model import RobotModel

__all__ = ["attach_joint_trajectory"]

_LOG = logging.getLogger(__name__)


def attach_joint_trajectory(path: PlannedPath, robot: RobotModel, q_seed: ArrayLike, *,
                            position_tolerance: float = 1e-4, rotation_tolerance: float = 1e-3,
                            max_iterations: int = 200, acceleration_limits: ArrayLike | None = None) -> PlannedPath:
    """``path`` with ``joint_names``, ``joint_positions`` and ``joint_velocities`` for every waypoint.

    When the IK fails at waypoint k, the result keeps the task-space path, has ``success=False`` and a
    ``failure_reason`` naming k and the remaining error, and no joint arrays (the robot cannot follow it).
    Joint speeds above the URDF velocity limits are logged as a warning (the plan's ``dt`` is too short
    for the robot there), not changed; ``trajectory`` is the joint path time-parameterised within the
    velocity limits and ``acceleration_limits`` (per joint; default :attr:`RobotModel.acceleration_limits
    <pfield.robot.RobotModel.acceleration_limits>`), which a controller can execute.
    """
    if not isinstance(path, PlannedPath):
        raise InvalidInput("path", path, "expected a pfield PlannedPath")
    seed = robot.check_joint_angles(q_seed, "q_seed")
    settings = ik_settings(max_iterations, position_tolerance, rotation_tolerance, damping=1e-4, max_step=0.3)
    qs, outcome = solve_ik_path(robot, seed, path.positions, path.orientations, settings)
    failed, pos_err, rot_err = outcome.failed, outcome.position_error, outcome.rotation_error
    if failed >= 0:
        reason = (f"inverse kinematics failed at waypoint {failed} of {len(path)} (position error {pos_err:.4g} m, "
                  f"rotation error {rot_err:.4g} rad): the robot cannot follow the planned path")
        at_seed = robot.forward_kinematics(seed).position
        off = float(np.linalg.norm(np.asarray(path.positions[0]) - at_seed))
        if failed == 0 and off > position_tolerance:  # the path does not start where the seed's end effector is
            reason += (f"; its start is {off:.4g} m from the end effector at the starting joint angles (at "
                       f"{np.round(at_seed, 4).tolist()}): give the start pose of those joints (an unset pose is the "
                       "origin)")
        _LOG.info(reason)
        return replace(path, success=False, failure_reason=reason, status=PlanStatus.IK_FAILED,
                       joint_names=robot.joint_names,
                       joint_positions=None, joint_velocities=None)
    velocities = np.zeros_like(qs)
    if len(path) > 1:
        steps = np.diff(path.times)[:, None]
        velocities[:-1] = np.diff(qs, axis=0) / np.where(steps > 0, steps, 1.0)
        too_fast = np.abs(velocities) > robot.velocity_limits
        if too_fast.any():
            first = int(np.argwhere(too_fast)[0, 0])
            _LOG.warning("joint trajectory exceeds the velocity limits from waypoint %d on", first)
    limits = robot.acceleration_limits if acceleration_limits is None else acceleration_limits
    dt = float(path.times[1] - path.times[0]) if len(path) > 1 else 0.01
    trajectory = retime_joint_path(robot.joint_names, qs, robot.velocity_limits, limits, dt if dt > 0 else 0.01)
    return replace(path, joint_names=robot.joint_names, joint_positions=qs, joint_velocities=velocities,
                   trajectory=trajectory)
