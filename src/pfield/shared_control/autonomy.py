"""Autonomy vectors for shared control: the motion the potential field recommends right now.

* Task space — :func:`task_space_autonomy_vector`: the field's limited twist at an end-effector pose
  (:meth:`PotentialField.twist`).
* Whole body — :func:`whole_body_autonomy`: at joint angles q, one step of the whole-body field of
  :mod:`pfield.planning.whole_body` (end-effector attraction, every link damped and repelled by obstacles
  and by the robot itself, joint position and velocity limits) gives joint velocities q̇; the autonomy
  vector is the end-effector twist J(q) q̇ they produce (world frame, linear m/s then angular rad/s).
  The pose is FK(q); a ``query_pose`` that disagrees with it by more than ``pose_tolerance`` (m, rad) is
  reported (``pose_mismatch`` and a logged warning) and otherwise ignored: the joints are the truth.
  ``prev_joint_velocities`` with ``dt > 0`` apply the joint acceleration limits:
  |q̇_j − q̇_prev,j| ≤ a_j·dt, with a_j = ``max_angular_acceleration`` (revolute) or
  ``max_linear_acceleration`` (prismatic), unless that would break an obstacle damper (safety first).
  Link–obstacle and self pairs already closer than ``safety_distance`` at q may not approach further.
  The answer keeps the output contract (:mod:`pfield.safety`): q̇ within the URDF velocity limits and J q̇
  within ``max_linear_velocity`` / ``max_angular_velocity``, by one factor (the planner's own steps are not
  scaled: where the null-space motion makes the end effector faster than those limits, the autonomy vector is
  a scaled copy of the planner's first step).

The whole-body evaluation is one compiled call of :class:`pfield.planning.WholeBodyStepper` (planning's
public whole-body step), cached per (field, robot) and thread.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield.planning import WholeBodyOptions, WholeBodyStepper
from pfield.robot.model import RobotModel
from pfield.shared_control._recent import Recent
from pfield.spatial import Pose, Twist, readonly_parts, twist_from_checked

__all__ = ["WholeBodyAutonomy", "task_space_autonomy_vector", "whole_body_autonomy", "whole_body_autonomy_vector",
           "whole_body_row", "whole_body_stepper"]

_LOG = logging.getLogger(__name__)
_DEFAULT_OPTIONS = WholeBodyOptions()  # frozen: one value for every call without options
_STEPPERS: Recent[WholeBodyStepper] = Recent()
"""The steppers of (field, robot) on each thread (several fields in turn: one per candidate goal)."""


@dataclass(frozen=True, eq=False)
class WholeBodyAutonomy:
    """The whole-body autonomy vector and what it was computed from.

    ``twist`` — end-effector twist J(q) q̇ (world frame); ``joint_velocities`` — q̇ (rad/s or m/s, tree
    order); ``pose`` — FK(q); ``pose_mismatch`` — a query pose was given and differs from ``pose`` beyond
    the tolerance; ``clearance`` — smallest clearance of the fitted link model to an obstacle (m, ``inf``
    without; exact within the influence distance, a lower bound beyond).
    """

    twist: Twist
    joint_velocities: NDArray[np.float64]
    pose: Pose
    pose_mismatch: bool
    clearance: float


def task_space_autonomy_vector(field: Any, pose: Pose, previous: Twist | None = None, dt: float = 0.0) -> Twist:
    """The field's limited twist at ``pose`` (see :meth:`pfield.field.PotentialField.twist`)."""
    twist: Twist = field.twist(pose, previous, dt)
    return twist


def _stepper(field: Any, robot: RobotModel, options: WholeBodyOptions | None) -> WholeBodyStepper:
    """The cached :class:`WholeBodyStepper` of (field, robot, options) for this thread (None: the default
    options, never a stepper built with others)."""
    wanted = options or _DEFAULT_OPTIONS
    return _STEPPERS.get(field, robot, lambda: WholeBodyStepper(field, robot, wanted),
                         lambda cached: cached.options is wanted or cached.options == wanted)


_MISMATCH_WARNING_PERIOD = 5.0  # s; autonomy vectors are asked for at control rate, the log must not flood
_last_mismatch_warning = [-math.inf, 0]  # [monotonic time of the last warning, calls suppressed since]


def _warn_mismatch(query_pose: Pose, pose: Pose) -> None:
    """Log a query-pose/FK disagreement at most once per ``_MISMATCH_WARNING_PERIOD`` seconds."""
    now = time.monotonic()
    if now - _last_mismatch_warning[0] < _MISMATCH_WARNING_PERIOD:
        _last_mismatch_warning[1] += 1
        return
    _LOG.warning("query pose %r disagrees with FK(joint_angles) %r; using the joint angles (%d similar "
                 "warnings suppressed)", query_pose, pose, _last_mismatch_warning[1])
    _last_mismatch_warning[:] = [now, 0]


def whole_body_autonomy(field: Any, robot: RobotModel, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None,
                        dt: float = 0.0, query_pose: Pose | None = None,
                        pose_tolerance: tuple[float, float] = (0.01, 0.05),
                        options: WholeBodyOptions | None = None) -> WholeBodyAutonomy:
    """The whole-body field's recommendation at joint angles ``q`` (see the module docstring).

    Args:
        field: a :class:`~pfield.field.PotentialField` (goal, obstacles, parameters).
        robot: the robot; ``q`` must fit its joints and limits (``InvalidInput`` otherwise).
        prev_joint_velocities: q̇ of the previous command (rad/s); with ``dt`` > 0 (s) it rate-limits q̇.
        query_pose: the caller's idea of the end-effector pose, compared with FK(q).
        pose_tolerance: (m, rad) beyond which ``query_pose`` counts as a mismatch.
    """
    step = _stepper(field, robot, options).step(q, prev_joint_velocities, dt)
    pose = Pose(step.position, step.orientation)
    mismatch = False
    if query_pose is not None:
        mismatch = (pose.translation_distance(query_pose) > pose_tolerance[0]
                    or pose.rotation_distance(query_pose) > pose_tolerance[1])
        if mismatch:
            _warn_mismatch(query_pose, pose)
    return WholeBodyAutonomy(twist_from_checked(*readonly_parts(step.twist)), step.joint_velocities, pose, mismatch,
                             step.clearance)


def whole_body_autonomy_vector(field: Any, robot: RobotModel, q: ArrayLike,
                               prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0,
                               query_pose: Pose | None = None) -> Twist:
    """End-effector twist of :func:`whole_body_autonomy` (world frame): the ComputeAutonomyVector answer."""
    if query_pose is None:  # the service's hot path: the cached stepper's twist alone, no FK pose object
        last = _STEPPERS.last()  # the stepper used last, when it is this field's and robot's with the defaults
        stepper = last[2] if last is not None and last[0] is field and last[1] is robot and \
            last[2].options is _DEFAULT_OPTIONS else _stepper(field, robot, None)
        return stepper.autonomy_vector(q, prev_joint_velocities, dt)
    return whole_body_autonomy(field, robot, q, prev_joint_velocities, dt, query_pose).twist


def whole_body_stepper(field: Any, robot: RobotModel) -> WholeBodyStepper:
    """The cached :class:`~pfield.planning.WholeBodyStepper` of (field, robot) with the default options, for
    this thread: the one every autonomy and assistance call at control rate steps with."""
    return _stepper(field, robot, None)


def whole_body_row(field: Any, robot: RobotModel, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None,
                   dt: float = 0.0) -> NDArray[np.float64]:
    """The whole-body step's raw row at ``q`` (:meth:`pfield.planning.WholeBodyStepper.row`), from the cached
    stepper: what :func:`whole_body_autonomy` reads, without building its value objects."""
    return _stepper(field, robot, None).row(q, prev_joint_velocities, dt)
