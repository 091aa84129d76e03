"""Inverse kinematics: damped least squares with joint limits, position and orientation (compiled).

Each iteration solves for the joint step (Wampler 1986; Buss, "Introduction to inverse kinematics with
Jacobian transpose, pseudoinverse and damped least squares methods", 2004, eq. 11)::

    Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e,     e = [p* − p(q);  log(R* R(q)ᵀ)]   (world frame, m and rad)

then clips ``q + Δq`` to the joint limits; joints that sit on a limit and would be pushed past it are
frozen (their Jacobian column removed) and the step recomputed, so the remaining joints make the
progress (a projected DLS). The step is scaled so that no joint moves more than ``max_step`` rad per
iteration. It stops when ‖p* − p‖ ≤ ``position_tolerance`` and the angle ≤ ``rotation_tolerance``.

The iterations run in the compiled core (``src/core/robot/ik``, the DLS step in ``src/core/math/dls.hpp``) over
the robot's arrays bound once per :class:`~pfield.robot.RobotModel`; this module validates and names the results.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import robot_kinematics as _core_kinematics
from pfield._validation import as_vector, positive
from pfield.errors import InvalidInput
from pfield.robot.model import RobotModel
from pfield.spatial import Pose, Twist

__all__ = ["IKResult", "IKSolver", "differential_ik", "solve_ik"]

_VALID = _core_kinematics.IKInput.Valid
_BAD_POSITION, _BAD_ORIENTATION = _core_kinematics.IKInput.BadPosition, _core_kinematics.IKInput.BadOrientation


@dataclass(frozen=True, eq=False)
class IKResult:
    """Outcome of :func:`solve_ik`: ``q`` is the last iterate (within limits) even when ``success`` is False."""

    success: bool
    q: NDArray[np.float64]
    iterations: int
    position_error: float
    rotation_error: float


def ik_settings(max_iterations: int, position_tolerance: float, rotation_tolerance: float, damping: float,
                max_step: float) -> _core_kinematics.IKSettings:
    """The validated settings of the core's solver (tolerances in m and rad, ``damping`` λ² in m², ``max_step``
    rad or m)."""
    if int(max_iterations) != max_iterations or max_iterations < 1:
        raise InvalidInput("max_iterations", max_iterations, "must be an integer >= 1")
    return _core_kinematics.IKSettings(int(max_iterations), positive("position_tolerance", position_tolerance),
                                       positive("rotation_tolerance", rotation_tolerance),
                                       positive("damping", damping), positive("max_step", max_step))


_DEFAULT_SETTINGS = ik_settings(200, 1e-4, 1e-3, 1e-4, 0.3)


def solve_ik(robot: RobotModel, target: Pose, q_seed: ArrayLike, *, max_iterations: int = 200,
             position_tolerance: float = 1e-4, rotation_tolerance: float = 1e-3, damping: float = 1e-4,
             max_step: float = 0.3) -> IKResult:
    """Joint angles putting the end effector at ``target`` (world frame), starting from ``q_seed``.

    ``damping`` is λ² (m²); ``max_step`` (rad or m) bounds each iteration's largest joint move. Returns an
    :class:`IKResult`; failure (``success=False``) is a result, not an exception.
    """
    if not isinstance(target, Pose):
        raise InvalidInput("target", target, "expected a pfield.Pose")
    if (max_iterations, position_tolerance, rotation_tolerance, damping, max_step) == (200, 1e-4, 1e-3, 1e-4, 0.3):
        settings = _DEFAULT_SETTINGS  # the defaults, validated once
    else:
        try:
            settings = ik_settings(max_iterations, position_tolerance, rotation_tolerance, damping, max_step)
        except InvalidInput:
            robot.check_joint_angles(q_seed, "q_seed")  # a bad seed is named first
            raise
    core, q = robot._core_kinematics, np.empty(robot.n_joints)
    # the core checks the seed as check_joint_angles does; when it breaks the rule, that raises the worded error
    try:
        outcome = core.solve_ik(q_seed, target.position, target.orientation, settings, q)
    except TypeError:  # not an array the core reads as float64 (a list): validated in Python below
        outcome = None
    if outcome is None:
        outcome = core.solve_ik(robot.check_joint_angles(q_seed, "q_seed"), target.position, target.orientation,
                                settings, q)
    result = object.__new__(IKResult)  # the frozen dataclass's fields, without its per-field __setattr__ calls
    result.__dict__.update(success=outcome.success, q=q, iterations=outcome.iterations,
                           position_error=outcome.position_error, rotation_error=outcome.rotation_error)
    return result


def differential_ik(robot: RobotModel, q: ArrayLike, twist: Twist | ArrayLike, damping: float = 1e-4
                    ) -> NDArray[np.float64]:
    """Joint velocities q̇ (n,) that realise an end-effector ``twist`` at ``q`` in the damped least-squares sense:
    q̇ = Jᵀ (J Jᵀ + λ² I)⁻¹ v (Wampler 1986; Buss 2004, eq. 11), with J the world-aligned Jacobian
    (:meth:`RobotModel.jacobian`) and v = ``twist`` (a :class:`~pfield.spatial.Twist`, or 6 values: linear m/s then
    angular rad/s, world frame). ``damping`` is λ² (as :func:`solve_ik`'s): near a singularity it trades accuracy for
    bounded joint speeds. No limits are applied (:func:`pfield.safety.limit_joint_command` does that): this is the
    step of a plain teleoperation, the baseline the field's assistance is compared with."""
    velocity = np.concatenate([twist.linear, twist.angular]) if isinstance(twist, Twist) else \
        as_vector("twist", twist, 6)
    lam2 = positive("damping", damping)
    out = np.empty(robot.n_joints)
    try:  # as forward_kinematics: the core takes q as given when it is n float64 values within the limits
        done = robot._core_kinematics.differential_ik(q, velocity, lam2, out)
    except TypeError:
        done = False
    if not done:
        robot._core_kinematics.differential_ik(robot.check_joint_angles(q, "q"), velocity, lam2, out)
    return out


def solve_ik_path(robot: RobotModel, q_seed: NDArray[np.float64], positions: ArrayLike, orientations: ArrayLike,
                  settings: _core_kinematics.IKSettings) -> tuple[NDArray[np.float64], _core_kinematics.IKPathOutcome]:
    """The IK of every waypoint (positions (N, 3) m, unit quaternions (N, 4)), each seeded from the previous
    solution and the first from ``q_seed`` (validated by the caller, :meth:`RobotModel.check_joint_angles`).

    Returns the joint angles (N, n) and the outcome: ``failed`` the first waypoint not reached (−1: none; rows
    after it are zero) with its ``position_error`` and ``rotation_error``."""
    qs, outcome = robot._core_kinematics.solve_ik_path(
        q_seed, np.ascontiguousarray(positions, dtype=np.float64), np.ascontiguousarray(orientations, dtype=np.float64),
        settings)
    return qs, outcome


class IKSolver:
    """:func:`solve_ik` prepared for a control loop: settings validated and arrays bound once.

    Write the target pose into ``target`` (7,: position m, unit quaternion x, y, z, w; world frame) and the
    seed into ``seed`` (n,), call :meth:`solve` (one call into the core, no argument); the answer is in
    ``q`` (n,), and ``iterations``, ``position_error``, ``rotation_error``. Results equal
    ``solve_ik(robot, Pose(target[:3], target[3:]), seed, ...)`` bit for bit. Bad input (non-finite target,
    a quaternion whose norm is not 1 within 1e-9, a seed beyond the limits) raises
    :class:`~pfield.errors.InvalidInput`. One solver per thread: its arrays are its state.
    """

    def __init__(self, robot: RobotModel, *, max_iterations: int = 200, position_tolerance: float = 1e-4,
                 rotation_tolerance: float = 1e-3, damping: float = 1e-4, max_step: float = 0.3) -> None:
        if not isinstance(robot, RobotModel):
            raise InvalidInput("robot", robot, "expected a pfield.RobotModel")
        self.robot = robot
        self.settings = ik_settings(max_iterations, position_tolerance, rotation_tolerance, damping, max_step)
        # the core solver owns its buffers; target, seed and q are NumPy views of them
        self._solver = _core_kinematics.IKSolver(robot._core_kinematics, self.settings)
        self.target: NDArray[np.float64] = self._solver.target
        self.seed: NDArray[np.float64] = self._solver.seed
        self.q: NDArray[np.float64] = self._solver.q

    def solve(self) -> bool:
        """Solve from ``seed`` for ``target`` into ``q``; True when within both tolerances."""
        status = self._solver.solve()
        if status is not _VALID:
            raise self._error(status)
        return bool(self._solver.success)

    @property
    def iterations(self) -> int:
        return int(self._solver.outcome.iterations)

    @property
    def position_error(self) -> float:
        """m, of the last :meth:`solve`."""
        return float(self._solver.outcome.position_error)

    @property
    def rotation_error(self) -> float:
        """rad, of the last :meth:`solve`."""
        return float(self._solver.outcome.rotation_error)

    def _error(self, status: _core_kinematics.IKInput) -> InvalidInput:
        if status is _BAD_POSITION:
            return InvalidInput("target[0:3]", self.target[:3].tolist(), "position must be finite")
        if status is _BAD_ORIENTATION:
            return InvalidInput("target[3:7]", self.target[3:].tolist(),
                                "orientation must be a unit quaternion (x, y, z, w)")
        try:
            self.robot.check_joint_angles(self.seed, "seed")
        except InvalidInput as error:
            return error
        return InvalidInput("seed", self.seed.tolist(), "must be finite and within the joint limits")
