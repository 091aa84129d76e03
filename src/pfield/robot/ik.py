"""Inverse kinematics: damped least squares with joint limits, position and orientation (compiled).

Each iteration solves for the joint step (Wampler 1986; Buss, "Introduction to inverse kinematics with
Jacobian transpose, pseudoinverse and damped least squares methods", 2004, eq. 11)::

    Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e,     e = [p* − p(q);  log(R* R(q)ᵀ)]   (world frame, m and rad)

then clips ``q + Δq`` to the joint limits; joints that sit on a limit and would be pushed past it are
frozen (their Jacobian column removed) and the step recomputed, so the remaining joints make the
progress (a projected DLS). The step is scaled so that no joint moves more than ``max_step`` rad per
iteration. It stops when ‖p* − p‖ ≤ ``position_tolerance`` and the angle ≤ ``rotation_tolerance``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from pfield._bound import BoundArrays, float_view1, float_view2, float_view3, int_view1, int_view2
from pfield._linalg import cholesky_inplace, cholesky_solve
from pfield._spatial_kernels import matrix_to_quat, rotation_error
from pfield._validation import positive
from pfield.errors import InvalidInput
from pfield.robot._kinematics import check_limits, end_effector_kinematics
from pfield.robot.model import LIMIT_TOLERANCE, RobotModel
from pfield.spatial import Pose

__all__ = ["IKResult", "IKSolver", "solve_ik"]


@dataclass(frozen=True, eq=False)
class IKResult:
    """Outcome of :func:`solve_ik`: ``q`` is the last iterate (within limits) even when ``success`` is False."""

    success: bool
    q: NDArray[np.float64]
    iterations: int
    position_error: float
    rotation_error: float


@njit(cache=True)
def _error(rot, pos, target_p, target_q, e):  # type: ignore[no-untyped-def]
    quat = matrix_to_quat(rot)
    for k in range(3):
        e[k] = target_p[k] - pos[k]
    rx, ry, rz = rotation_error(quat[0], quat[1], quat[2], quat[3], target_q[0], target_q[1], target_q[2],
                                target_q[3])
    e[3], e[4], e[5] = rx, ry, rz
    return math.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2), math.sqrt(rx * rx + ry * ry + rz * rz)


@njit(cache=True, inline="always")
def _dls_step_into(jac, e, frozen, damping, step, a, y):  # type: ignore[no-untyped-def]
    """step = J_fᵀ (J_f J_fᵀ + λ² I)⁻¹ e with the columns of frozen joints removed, in the workspace ``a``
    (6, 6; every entry is written) and ``y`` (6,)."""
    n = jac.shape[1]
    for r in range(6):
        for c in range(r + 1):
            s = 0.0
            for j in range(n):
                if not frozen[j]:
                    s += jac[r, j] * jac[c, j]
            a[r, c] = s
            a[c, r] = s
        a[r, r] += damping
    size = a.shape[0]  # a run-time 6, not the literal: the same QP specialisation as the whole-body planner's
    cholesky_inplace(a, size)
    cholesky_solve(a, e, y, size)
    for j in range(n):
        step[j] = 0.0 if frozen[j] else jac[0, j] * y[0] + jac[1, j] * y[1] + jac[2, j] * y[2] + \
            jac[3, j] * y[3] + jac[4, j] * y[4] + jac[5, j] * y[5]


@njit(cache=True)
def ik_kernel(  # type: ignore[no-untyped-def]
        q_seed, target_p, target_q, parents, place_rot, place_pos, axes, kinds, support, ee_joint, ee_rot, ee_pos,
        lower, upper, settings):
    """DLS iterations from ``q_seed``; settings = (max_iterations, tol_pos, tol_rot, λ², max_step).

    Returns (q, success, iterations, position error, rotation error).
    """
    n = q_seed.shape[0]
    q = np.minimum(np.maximum(q_seed, lower), upper)
    rotations, origins, jac = np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((6, n))
    e, step, frozen = np.empty(6), np.empty(n), np.zeros(n, dtype=np.bool_)
    success, iterations, pos_err, rot_err = ik_iterate(
        q, target_p, target_q, parents, place_rot, place_pos, axes, kinds, support, ee_joint, ee_rot, ee_pos, lower,
        upper, settings, rotations, origins, jac, e, step, frozen, np.zeros((6, 6)), np.empty(6))
    return q, success, iterations, pos_err, rot_err


@njit(cache=True, inline="always")
def ik_iterate(  # type: ignore[no-untyped-def]
        q, target_p, target_q, parents, place_rot, place_pos, axes, kinds, support, ee_joint, ee_rot, ee_pos, lower,
        upper, settings, rotations, origins, jac, e, step, frozen, a, y):
    """The DLS iterations of :func:`ik_kernel` on ``q`` (already within the limits) in place, in the given
    workspace; returns (success, iterations, position error, rotation error)."""
    n = q.shape[0]
    pos_err, rot_err = math.inf, math.inf
    for iteration in range(int(settings[0]) + 1):
        rot, pos = end_effector_kinematics(q, parents, place_rot, place_pos, axes, kinds, support, ee_joint, ee_rot,
                                           ee_pos, rotations, origins, jac)
        pos_err, rot_err = _error(rot, pos, target_p, target_q, e)
        if pos_err <= settings[1] and rot_err <= settings[2]:
            return True, iteration, pos_err, rot_err
        if iteration == int(settings[0]):
            break
        frozen[:] = False
        for _ in range(3):  # freeze joints pushed past a limit, then recompute the step
            _dls_step_into(jac, e, frozen, settings[3], step, a, y)
            changed = False
            for j in range(n):
                if not frozen[j] and ((q[j] <= lower[j] and step[j] < 0.0) or (q[j] >= upper[j] and step[j] > 0.0)):
                    frozen[j] = True
                    changed = True
            if not changed:
                break
        largest = np.max(np.abs(step))
        scale = 1.0 if largest <= settings[4] else settings[4] / largest
        for j in range(n):
            q[j] = min(max(q[j] + scale * step[j], lower[j]), upper[j])
    return False, int(settings[0]), pos_err, rot_err


def ik_settings(max_iterations: int, position_tolerance: float, rotation_tolerance: float, damping: float,
                max_step: float) -> NDArray[np.float64]:
    """Validated settings vector of :func:`ik_kernel`: (max_iterations, tol_pos, tol_rot, λ², max_step)."""
    if int(max_iterations) != max_iterations or max_iterations < 1:
        raise InvalidInput("max_iterations", max_iterations, "must be an integer >= 1")
    return np.array([max_iterations, positive("position_tolerance", position_tolerance),
                     positive("rotation_tolerance", rotation_tolerance), positive("damping", damping),
                     positive("max_step", max_step)], dtype=np.float64)


def solve_ik(robot: RobotModel, target: Pose, q_seed: ArrayLike, *, max_iterations: int = 200,
             position_tolerance: float = 1e-4, rotation_tolerance: float = 1e-3, damping: float = 1e-4,
             max_step: float = 0.3) -> IKResult:
    """Joint angles putting the end effector at ``target`` (world frame), starting from ``q_seed``.

    ``damping`` is λ² (m²); ``max_step`` (rad or m) bounds each iteration's largest joint move. Returns an
    :class:`IKResult`; failure (``success=False``) is a result, not an exception.
    """
    if not isinstance(target, Pose):
        raise InvalidInput("target", target, "expected a pfield.Pose")
    seed = robot.check_joint_angles(q_seed, "q_seed")
    settings = ik_settings(max_iterations, position_tolerance, rotation_tolerance, damping, max_step)
    q, success, iterations, pos_err, rot_err = ik_kernel(
        seed, np.array(target.position), np.array(target.orientation), *robot.kinematics,
        np.array(robot.lower_limits), np.array(robot.upper_limits), settings)
    return IKResult(bool(success), q, int(iterations), float(pos_err), float(rot_err))


_UNIT_TOLERANCE = 1e-9
BAD_SEED, BAD_POSITION, BAD_ORIENTATION = -1, -2, -3


@njit(cache=True)
def bound_ik(table):  # type: ignore[no-untyped-def]
    """:func:`ik_kernel` on the arrays bound by :class:`IKSolver`: seed (slot 13) → q (14), result (15) =
    (iterations, position error, rotation error). Returns 1 (success), 0 (not reached) or a negative defect
    of the input: :data:`BAD_SEED` (not finite, or beyond the limits), :data:`BAD_POSITION`, :data:`BAD_ORIENTATION`."""
    lower, upper, target, seed, q = (float_view1(table, 9), float_view1(table, 10), float_view1(table, 12),
                                     float_view1(table, 13), float_view1(table, 14))
    for k in range(3):
        if not math.isfinite(target[k]):
            return BAD_POSITION
    norm2 = target[3] * target[3] + target[4] * target[4] + target[5] * target[5] + target[6] * target[6]
    if not abs(norm2 - 1.0) <= 2.0 * _UNIT_TOLERANCE:
        return BAD_ORIENTATION
    for j in range(q.shape[0]):
        q[j] = seed[j]
    if check_limits(q, lower, upper, LIMIT_TOLERANCE) != -1:
        return BAD_SEED
    for j in range(q.shape[0]):  # as ik_kernel's np.minimum(np.maximum(seed, lower), upper)
        q[j] = min(max(seed[j], lower[j]), upper[j])
    frozen = int_view1(table, 21)
    success, iterations, pos_err, rot_err = ik_iterate(
        q, target[:3], target[3:], int_view1(table, 0), float_view3(table, 1), float_view2(table, 2),
        float_view2(table, 3), int_view1(table, 4), int_view2(table, 5), int_view1(table, 6)[0], float_view2(table, 7),
        float_view1(table, 8), lower, upper, float_view1(table, 11), float_view3(table, 16), float_view2(table, 17),
        float_view2(table, 18), float_view1(table, 19), float_view1(table, 20), frozen, float_view2(table, 22),
        float_view1(table, 23))
    result = float_view1(table, 15)
    result[0], result[1], result[2] = iterations, pos_err, rot_err
    return 1 if success else 0


class IKSolver:
    """:func:`solve_ik` prepared for a control loop: settings validated and arrays bound once.

    Write the target pose into ``target`` (7,: position m, unit quaternion x, y, z, w; world frame) and the
    seed into ``seed`` (n,), call :meth:`solve` (one compiled call, one array argument); the answer is in
    ``q`` (n,), and ``iterations``, ``position_error``, ``rotation_error``. Results equal
    ``solve_ik(robot, Pose(target[:3], target[3:]), seed, ...)`` bit for bit. Bad input (non-finite target,
    a quaternion whose norm is not 1 within 1e-9, a seed beyond the limits) raises
    :class:`~pfield.errors.InvalidInput`. One solver per thread: its arrays are its state.
    """

    def __init__(self, robot: RobotModel, *, max_iterations: int = 200, position_tolerance: float = 1e-4,
                 rotation_tolerance: float = 1e-3, damping: float = 1e-4, max_step: float = 0.3) -> None:
        if not isinstance(robot, RobotModel):
            raise InvalidInput("robot", robot, "expected a pfield.RobotModel")
        n, k = robot.n_joints, robot.kinematics
        self.robot = robot
        self.settings = ik_settings(max_iterations, position_tolerance, rotation_tolerance, damping, max_step)
        self.target = np.zeros(7)
        self.target[6] = 1.0
        self.seed, self.q, self._result = np.zeros(n), np.zeros(n), np.zeros(3)
        arrays = [k.parents, k.place_rot, k.place_pos, k.axes, k.kinds, k.support, np.array([k.ee_joint]), k.ee_rot,
                  k.ee_pos, robot.lower_limits, robot.upper_limits, self.settings, self.target, self.seed, self.q,
                  self._result, np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((6, n)), np.empty(6), np.empty(n),
                  np.zeros(n, dtype=np.int64), np.zeros((6, 6)), np.empty(6)]
        self._bound = BoundArrays([np.ascontiguousarray(a) for a in arrays])
        self._table = self._bound.table

    def solve(self) -> bool:
        """Solve from ``seed`` for ``target`` into ``q``; True when within both tolerances."""
        status = bound_ik(self._table)
        if status < 0:
            raise self._error(status)
        return status == 1

    @property
    def iterations(self) -> int:
        return int(self._result[0])

    @property
    def position_error(self) -> float:
        """m, of the last :meth:`solve`."""
        return float(self._result[1])

    @property
    def rotation_error(self) -> float:
        """rad, of the last :meth:`solve`."""
        return float(self._result[2])

    def _error(self, status: int) -> InvalidInput:
        if status == BAD_POSITION:
            return InvalidInput("target[0:3]", self.target[:3].tolist(), "position must be finite")
        if status == BAD_ORIENTATION:
            return InvalidInput("target[3:7]", self.target[3:].tolist(),
                                "orientation must be a unit quaternion (x, y, z, w)")
        try:
            self.robot.check_joint_angles(self.seed, "seed")
        except InvalidInput as error:
            return error
        return InvalidInput("seed", self.seed.tolist(), "must be finite and within the joint limits")


@njit(cache=True)
def ik_path_kernel(  # type: ignore[no-untyped-def]
        q_seed, positions, quaternions, parents, place_rot, place_pos, axes, kinds, support, ee_joint, ee_rot, ee_pos,
        lower, upper, settings):
    """IK of every waypoint, each seeded from the previous solution; returns (qs, index of the first failure
    or −1, its position error, its rotation error)."""
    count, n = positions.shape[0], q_seed.shape[0]
    qs = np.empty((count, n))
    q = q_seed.copy()
    for k in range(count):
        q, success, _, pos_err, rot_err = ik_kernel(q, positions[k], quaternions[k], parents, place_rot, place_pos,
                                                    axes, kinds, support, ee_joint, ee_rot, ee_pos, lower, upper,
                                                    settings)
        qs[k] = q
        if not success:
            return qs, k, pos_err, rot_err
    return qs, -1, 0.0, 0.0
