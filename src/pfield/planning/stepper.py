"""One step of the whole-body field, as a public API: :class:`WholeBodyStepper`.

The whole-body planner integrates this step; shared control (:mod:`pfield.shared_control`) evaluates it once per
control cycle at the robot's measured joints. The stepper packs the robot, the field's obstacles and a
workspace once (the compiled core's ``Stepper``, ``src/core/planning/whole_body``), and each
:meth:`~WholeBodyStepper.step` is one compiled call: the joint velocities of the velocity QP, with link–obstacle
and self pairs already closer than ``safety_distance`` at q not allowed to approach further.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield import safety
from pfield._core import whole_body as _core
from pfield._validation import finite, optional_vector
from pfield.errors import InvalidInput
from pfield.planning import _whole_body_layout as _wb
from pfield.planning._whole_body_core import core_robot, planner
from pfield.planning.options import PlanOptions
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters, make_scene, pack_robot
from pfield.robot.model import LIMIT_TOLERANCE, RobotModel
from pfield.spatial import Twist, readonly_parts, twist_from_checked

__all__ = ["WholeBodyStep", "WholeBodyStepper"]

_LOG = logging.getLogger(__name__)
NOMINAL_DT = 0.01
"""(s) the dampers' look-ahead when a step is asked for without a ``dt``."""
_TWIST, _POSITION, _ORIENTATION = slice(*_wb.OUT_TWIST), slice(*_wb.OUT_POSITION), slice(*_wb.OUT_ORIENTATION)
_HALTED = safety.HALTED


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
    """The whole-body field of ``field`` (goal, obstacles, parameters) for ``robot``, one step at a time.

    A thin shell over the compiled core's ``Stepper`` (``src/core/planning/whole_body``): the robot, the field's
    obstacles and the goal are bound once, the core owns the workspace, and each step is one call that checks
    its inputs, steps and applies the output contract."""

    def __init__(self, field: Any, robot: RobotModel, options: WholeBodyOptions | None = None) -> None:
        if field.goal is None:
            raise InvalidInput("goal", None, "the field has no goal pose")
        config = field.config
        self.field, self.robot, self.options = field, robot, options or WholeBodyOptions()
        self._arrays = pack_robot(robot, config, self.options)
        self._scene = make_scene(field.arrays.packed, self._arrays)
        self._params = kernel_parameters(config, PlanOptions(dt=NOMINAL_DT).resolved(config), self.options)
        self._goal_p = np.array(field.goal.position, dtype=np.float64)
        self._goal_q = np.array(field.goal.orientation, dtype=np.float64)
        self._core = _core.Stepper(planner(self._arrays, self._scene, self._goal_p, self._goal_q, self._params),
                                   np.ascontiguousarray(robot.velocity_limits, dtype=np.float64),
                                   config.max_linear_velocity, config.max_angular_velocity, LIMIT_TOLERANCE)
        self._row, self._twist = self._core.row, self._core.twist
        self._size = _wb.OUT_SIZE + robot.n_joints

    def bound(self) -> tuple[Any, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """What this stepper bound, for a compiled consumer that fuses its step (the whole-body assistance): the
        core's robot, the goal's position (3,) and orientation (4,), and the step's parameters — read in place,
        the same objects every step uses."""
        return core_robot(self._arrays), self._goal_p, self._goal_q, self._params

    def row(self, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0) -> NDArray[np.float64]:
        """The compiled step's raw row (``STEP_OUT`` then q̇) at ``q``, validated as :meth:`step` does.

        C-contiguous float64 arrays of rank 1 (and ``dt`` a number) take one compiled call that checks them itself
        (n values within the joint limits, finite previous velocities, dt finite and ≥ 0); anything else, or a bad
        value, goes through :meth:`~pfield.robot.RobotModel.check_joint_angles` and :meth:`evaluate` (same results,
        the errors)."""
        out = np.empty(self._size)
        try:
            outcome = self._row(q, prev_joint_velocities, dt, out)
        except TypeError:  # another type (a list, a strided view, float32): the validating path converts it
            outcome = -1
        if outcome < 0:
            return self.evaluate(self.robot.check_joint_angles(q, "joint_angles"), prev_joint_velocities, dt)
        if outcome == _HALTED:
            _LOG.warning("whole-body step: %s", safety.describe(_HALTED))
        return out

    def limited(self, row: NDArray[np.float64]) -> NDArray[np.float64]:
        """The output contract (:func:`pfield.safety.limit_joint_command`) on a fresh step row, in place: its
        q̇ within the URDF velocity limits and its twist J q̇ within the field's speed limits, by one factor
        (zero when not finite); returns ``row``. (:meth:`row` applies it already.)"""
        config = self.field.config
        outcome = safety.limit_joint_command(row[_wb.OUT_SIZE:], row[_TWIST], self.robot.velocity_limits,
                                             config.max_linear_velocity, config.max_angular_velocity)
        if outcome == safety.HALTED:
            _LOG.warning("whole-body step: %s", safety.describe(outcome))
        return row

    def step(self, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0) -> WholeBodyStep:
        """The field's joint velocities at ``q`` (validated against the robot's joints and limits).

        ``prev_joint_velocities`` with ``dt`` > 0 (s) apply the joint acceleration limits
        |q̇_j − q̇_prev,j| ≤ a_j·dt unless that would break an obstacle damper; ``dt`` also sets the
        dampers' look-ahead (:data:`NOMINAL_DT` when 0).
        """
        return WholeBodyStep(self.row(q, prev_joint_velocities, dt))

    def twist(self, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None,
              dt: float = 0.0) -> NDArray[np.float64]:
        """The end-effector twist (6,) of :meth:`step` alone, under the output contract (:meth:`autonomy_vector`)."""
        return self.autonomy_vector(q, prev_joint_velocities, dt).as_array()

    def autonomy_vector(self, q: ArrayLike, prev_joint_velocities: ArrayLike | None = None, dt: float = 0.0) -> Twist:
        """The end-effector twist of :meth:`step` alone, as a :class:`~pfield.spatial.Twist` (the shared-control
        service's hot path: one compiled call answers it, under the output contract), validated as :meth:`row`."""
        try:
            linear, angular, outcome = self._twist(q, prev_joint_velocities, dt)
        except TypeError:  # another type: the validating path converts it
            outcome = -1
        if outcome < 0:
            row = self.evaluate(self.robot.check_joint_angles(q, "joint_angles"), prev_joint_velocities, dt)
            return twist_from_checked(*readonly_parts(row[_TWIST]))
        if outcome == _HALTED:
            _LOG.warning("whole-body step: %s", safety.describe(_HALTED))
        return twist_from_checked(linear, angular)

    def evaluate(self, q: NDArray[np.float64], previous: ArrayLike | None, dt: float) -> NDArray[np.float64]:
        """The compiled step's row at already validated ``q``: ``STEP_OUT`` then q̇ (under the output contract)."""
        step = dt if type(dt) is float else finite("delta_time", dt)
        if not 0.0 <= step < math.inf:
            raise InvalidInput("delta_time", dt, "must be a finite number >= 0 s")
        given = optional_vector("prev_joint_velocities", previous, self.robot.n_joints)
        out = np.empty(self._size)
        outcome = self._row(np.ascontiguousarray(q, dtype=np.float64), given, step, out)
        if outcome < 0:  # every input was checked above
            raise InvalidInput("joint_angles", q, "refused by the compiled step")
        if outcome == _HALTED:
            _LOG.warning("whole-body step: %s", safety.describe(_HALTED))
        return out
