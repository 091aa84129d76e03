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

The whole-body evaluation is one compiled call; the packed robot, scene and workspace are cached per
(field, robot) and thread.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._validation import as_vector, finite
from pfield.errors import InvalidInput
from pfield.field.field import _fast_twist
from pfield.planning import _whole_body_kernel as _wb
from pfield.planning._whole_body_flat import FlatStep, flat_step
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters, make_scene, pack_robot
from pfield.robot.model import RobotModel
from pfield.spatial import Pose, Twist

__all__ = ["WholeBodyAutonomy", "task_space_autonomy_vector", "whole_body_autonomy", "whole_body_autonomy_vector"]

_LOG = logging.getLogger(__name__)
_NOMINAL_DT = 0.01  # s, damper look-ahead when the caller gives no delta_time
_CACHE = threading.local()


@dataclass(frozen=True, eq=False)
class WholeBodyAutonomy:
    """The whole-body autonomy vector and what it was computed from.

    ``twist`` — end-effector twist J(q) q̇ (world frame); ``joint_velocities`` — q̇ (rad/s or m/s, tree
    order); ``pose`` — FK(q); ``pose_mismatch`` — a query pose was given and differs from ``pose`` beyond
    the tolerance; ``clearance`` — smallest link-capsule clearance to an obstacle (m, ``inf`` without).
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


class _Prepared:
    """Packed robot, scene, parameters and workspace of one (field, robot) pair."""

    def __init__(self, field: Any, robot: RobotModel, options: WholeBodyOptions) -> None:
        config = field.config
        self.field, self.robot, self.options = field, robot, options
        self.arrays = pack_robot(robot, config, options)
        self.scene = make_scene(field.arrays.packed, self.arrays)
        self.params = kernel_parameters(config, _NOMINAL_DT, 0.01, config.rotation_tolerance, options)
        self.goal_p = np.array(field.goal.position, dtype=np.float64)
        self.goal_q = np.array(field.goal.orientation, dtype=np.float64)
        self.buffers = FlatStep(self.arrays, self.scene).buffers()
        self.zeros = np.zeros(robot.n_joints)
        self.last_step, self.step_params = -1.0, self.params

    def evaluate(self, q: NDArray[np.float64], previous: ArrayLike | None, dt: float, n: int) -> NDArray[np.float64]:
        """The kernel's (20 + n,) output row at validated ``q`` (see :func:`flat_step`)."""
        step = dt if type(dt) is float else finite("delta_time", dt)
        if not 0.0 <= step < math.inf:
            raise InvalidInput("delta_time", dt, "must be a finite number >= 0 s")
        velocities, has_prev = self.zeros, False
        if previous is not None:
            velocities = np.asarray(previous, dtype=np.float64)
            if velocities.shape != (n,) or not np.isfinite(velocities).all():
                if velocities.size == 0:
                    velocities = self.zeros  # an empty list (the message default) means "no previous"
                else:
                    velocities = np.array(as_vector("prev_joint_velocities", previous, n))
            has_prev = step > 0.0 and velocities is not self.zeros
        return flat_step(q, velocities, has_prev, self.goal_p, self.goal_q, self._parameters(step),
                         *self.buffers)

    def _parameters(self, step: float) -> NDArray[np.float64]:
        """The parameter vector for ``delta_time`` = ``step`` (cached: callers usually keep dt constant)."""
        if step <= 0.0:
            return self.params
        if step != self.last_step:
            self.step_params = self.params.copy()
            self.step_params[_wb.DT] = step
            self.last_step = step
        return self.step_params


def _prepared(field: Any, robot: RobotModel, options: WholeBodyOptions | None) -> _Prepared:
    cached: _Prepared | None = getattr(_CACHE, "entry", None)
    if cached is not None and cached.field is field and cached.robot is robot and \
            (options is None or options == cached.options):
        return cached
    entry = _Prepared(field, robot, options or WholeBodyOptions())
    _CACHE.entry = entry
    return entry


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
    values = robot.check_joint_angles(q, "joint_angles")
    out = _prepared(field, robot, options).evaluate(values, prev_joint_velocities, dt, robot.n_joints)
    pose = Pose(out[6:9], out[9:13])
    mismatch = False
    if query_pose is not None:
        mismatch = (pose.translation_distance(query_pose) > pose_tolerance[0]
                    or pose.rotation_distance(query_pose) > pose_tolerance[1])
        if mismatch:
            _warn_mismatch(query_pose, pose)
    return WholeBodyAutonomy(_fast_twist(out[0:6]), out[20:], pose, mismatch, float(out[13]))


def whole_body_autonomy_vector(field: Any, robot: RobotModel, q: ArrayLike,
                               prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0,
                               query_pose: Pose | None = None) -> Twist:
    """End-effector twist of :func:`whole_body_autonomy` (world frame): the ComputeAutonomyVector answer."""
    if query_pose is None:
        return _fast_twist(_fast_path(field, robot, q, prev_joint_velocities, dt))
    return whole_body_autonomy(field, robot, q, prev_joint_velocities, dt, query_pose).twist


def _fast_path(field: Any, robot: RobotModel, q: ArrayLike, prev_joint_velocities: ArrayLike | None,
               dt: float) -> NDArray[np.float64]:
    """The twist alone, skipping the FK pose object (the service's hot path)."""
    values = robot.check_joint_angles(q, "joint_angles")
    return _prepared(field, robot, None).evaluate(values, prev_joint_velocities, dt, robot.n_joints)[0:6]
