"""One step of the whole-body field, as a public API: :class:`WholeBodyStepper`.

The whole-body planner integrates this step; shared control (:mod:`pfield.shared_control`) evaluates it once per
control cycle at the robot's measured joints. The stepper packs the robot, the field's obstacles and a
workspace once, and each :meth:`~WholeBodyStepper.step` is one compiled call: the joint velocities of the
velocity QP (:mod:`pfield.planning._whole_body_kernel`), with link–obstacle and self pairs already closer
than ``safety_distance`` at q not allowed to approach further.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield import safety
from pfield._validation import finite, kernel_vector, optional_vector
from pfield.errors import InvalidInput
from pfield.planning import _whole_body_layout as _wb
from pfield.planning._whole_body_flat import FlatStep, bound_step, flat_step
from pfield.planning.options import PlanOptions
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters, make_scene, pack_robot
from pfield.robot.model import RobotModel

__all__ = ["WholeBodyStep", "WholeBodyStepper"]

_LOG = logging.getLogger(__name__)
NOMINAL_DT = 0.01
"""(s) the dampers' look-ahead when a step is asked for without a ``dt``."""
_TWIST, _POSITION, _ORIENTATION = slice(*_wb.OUT_TWIST), slice(*_wb.OUT_POSITION), slice(*_wb.OUT_ORIENTATION)


class WholeBodyStep:
    """One evaluation of the whole-body field at joint angles q, read from the compiled step's row.

    ``joint_velocities`` q̇ (rad/s or m/s, tree order); ``twist`` the end-effector twist J(q) q̇ (world
    frame, linear then angular); ``position``/``orientation`` FK(q) (m; x, y, z, w); ``clearance`` the
    smallest link-capsule clearance to an obstacle (m, ``inf`` without obstacles); ``result`` every named
    value of the step (:class:`~pfield.planning._whole_body_layout.StepResult`). Arrays are views of the row.
    """

    __slots__ = ("_row",)

    def __init__(self, row: NDArray[np.float64]) -> None:
        self._row = row

    @property
    def joint_velocities(self) -> NDArray[np.float64]:
        return self._row[_wb.OUT_SIZE:]

    @property
    def twist(self) -> NDArray[np.float64]:
        return self._row[_TWIST]

    @property
    def position(self) -> NDArray[np.float64]:
        return self._row[_POSITION]

    @property
    def orientation(self) -> NDArray[np.float64]:
        return self._row[_ORIENTATION]

    @property
    def clearance(self) -> float:
        return float(self._row[_wb.OUT_CLEARANCE])

    @property
    def result(self) -> _wb.StepResult:
        return _wb.StepResult.of(self._row)


class WholeBodyStepper:
    """The whole-body field of ``field`` (goal, obstacles, parameters) for ``robot``, one step at a time."""

    def __init__(self, field: Any, robot: RobotModel, options: WholeBodyOptions | None = None) -> None:
        if field.goal is None:
            raise InvalidInput("goal", None, "the field has no goal pose")
        config = field.config
        self.field, self.robot, self.options = field, robot, options or WholeBodyOptions()
        arrays = pack_robot(robot, config, self.options)
        scene = make_scene(field.arrays.packed, arrays)
        self._params = kernel_parameters(config, PlanOptions(dt=NOMINAL_DT).resolved(config), self.options)
        self._goal_p = np.array(field.goal.position, dtype=np.float64)
        self._goal_q = np.array(field.goal.orientation, dtype=np.float64)
        flat = FlatStep(arrays, scene)
        self._buffers = flat.buffers()
        self._zeros = np.zeros(robot.n_joints)
        self._last_dt, self._dt_params = -1.0, self._params
        # the hot path's bound arrays: the parameter vector of the current dt is rewritten in place
        self._bound_params, self._bound_dt = self._params.copy(), 0.0
        self._bound = flat.bind(self._goal_p, self._goal_q, self._bound_params, robot.lower_limits,
                                robot.upper_limits)
        self._table = self._bound.table

    def row(self, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0) -> NDArray[np.float64]:
        """The compiled step's raw row (``STEP_OUT`` then q̇) at ``q``, validated as :meth:`step` does.

        Writable C-contiguous float64 arrays of rank 1 (:func:`~pfield._validation.kernel_vector`) take one
        compiled call that checks them itself (bound arrays,
        :func:`~pfield.planning._whole_body_flat.bound_step`); anything else, or a bad value, goes through
        :meth:`~pfield.robot.RobotModel.check_joint_angles` and :meth:`evaluate` (same results, the errors).
        """
        previous = prev_joint_velocities
        if dt.__class__ is float and 0.0 <= dt < math.inf and kernel_vector(q) and \
                (previous is None or kernel_vector(previous)):
            given = previous is not None
            if given:
                previous = self._previous_within_limits(previous)  # type: ignore[arg-type]
            row = bound_step(q, previous if given else self._zeros, given, given and dt > 0.0,  # type: ignore[arg-type]
                             self.bound_table(dt))
            if row.shape[0]:
                return self.limited(row)
        return self.evaluate(self.robot.check_joint_angles(q, "joint_angles"), previous, dt)

    def _previous_within_limits(self, previous: NDArray[np.float64]) -> NDArray[np.float64]:
        """Rule 3 of :mod:`pfield.safety`: previous joint velocities clipped to the URDF limits (a NaN or a wrong
        length stays, for the compiled check to refuse)."""
        if previous.shape[0] != self.robot.n_joints:
            return previous
        clipped: NDArray[np.float64] = safety.clip_joint_velocities(previous, self.robot.velocity_limits)
        return clipped

    def limited(self, row: NDArray[np.float64]) -> NDArray[np.float64]:
        """The output contract (:func:`pfield.safety.limit_joint_command`) on a fresh step row, in place: its
        q̇ within the URDF velocity limits and its twist J q̇ within the field's speed limits, by one factor
        (zero when not finite); returns ``row``."""
        config = self.field.config
        outcome = safety.limit_joint_command(row[_wb.OUT_SIZE:], row[_TWIST], self.robot.velocity_limits,
                                             config.max_linear_velocity, config.max_angular_velocity)
        if outcome == safety.HALTED:
            _LOG.warning("whole-body step: %s", safety.describe(outcome))
        return row

    def bound_table(self, dt: float) -> NDArray[np.int64]:
        """The table of :func:`~pfield.planning._whole_body_flat.bound_step` with the parameters of ``dt``
        (s, finite and ≥ 0, checked by the caller; 0: the nominal step), for callers that fuse the step
        into their own compiled call (the whole-body assistance)."""
        if dt != self._bound_dt:
            self._bind_dt(dt)
        table: NDArray[np.int64] = self._table
        return table

    def _bind_dt(self, dt: float) -> None:
        self._bound_params[:] = self._params
        if dt > 0.0:
            self._bound_params[_wb.DT] = dt
        self._bound_dt = dt

    def step(self, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0) -> WholeBodyStep:
        """The field's joint velocities at ``q`` (validated against the robot's joints and limits).

        ``prev_joint_velocities`` with ``dt`` > 0 (s) apply the joint acceleration limits
        |q̇_j − q̇_prev,j| ≤ a_j·dt unless that would break an obstacle damper; ``dt`` also sets the
        dampers' look-ahead (:data:`NOMINAL_DT` when 0).
        """
        return WholeBodyStep(self.row(q, prev_joint_velocities, dt))

    def twist(self, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None,
              dt: float = 0.0) -> NDArray[np.float64]:
        """The end-effector twist (6,) of :meth:`step` alone (the shared-control service's hot path)."""
        return self.row(q, prev_joint_velocities, dt)[_TWIST]

    def evaluate(self, q: NDArray[np.float64], previous: ArrayLike | None, dt: float) -> NDArray[np.float64]:
        """The compiled step's row at already validated ``q``: ``STEP_OUT`` then q̇ (within the limits,
        :meth:`limited`)."""
        step = dt if type(dt) is float else finite("delta_time", dt)
        if not 0.0 <= step < math.inf:
            raise InvalidInput("delta_time", dt, "must be a finite number >= 0 s")
        n = self.robot.n_joints
        given = optional_vector("prev_joint_velocities", previous, n)
        if given is not None:
            given = self._previous_within_limits(given)
        velocities, has_prev = (self._zeros, False) if given is None else (given, step > 0.0)
        return self.limited(flat_step(q, velocities, has_prev, self._goal_p, self._goal_q, self._parameters(step),
                                      *self._buffers))

    def _parameters(self, step: float) -> NDArray[np.float64]:
        """The parameter vector for ``delta_time`` = ``step`` (cached: callers usually keep dt constant)."""
        if step <= 0.0:
            return self._params
        if step != self._last_dt:
            self._dt_params = self._params.copy()
            self._dt_params[_wb.DT] = step
            self._last_dt = step
        return self._dt_params
