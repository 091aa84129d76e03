"""The output contract: every command pfield returns is finite and within its velocity limits.

A *command* is anything a robot could execute: a twist (the task-space or whole-body autonomy vector, the
blended command of the assistance) and joint velocities (whole body). Whatever the input, pfield returns a
command that is finite and within the configured limits, or a zero command and says why. Every public entry
point that returns a command ends here (:func:`limit_twist`, :func:`limit_joint_command`); the rules, with
their reasons, are in docs/assistance.md § "The output contract":

1. **Non-finite → zero.** A command with a NaN or an infinity (which finite but absurd inputs could produce
   through overflow) is replaced by zeros: :data:`HALTED`. Callers with a flag field report it
   (``FLAG_HALTED``), the others log it.
2. **Over a limit → scaled.** A twist whose linear part is longer than ``max_linear_velocity`` or whose angular
   part is longer than ``max_angular_velocity`` is scaled by the one factor s ∈ (0, 1) that brings both within
   (direction kept); joint velocities with some |q̇_j| > v_max,j are scaled by s = min_j v_max,j / |q̇_j| (MoveIt
   Servo's velocity scaling: the joint-space direction, and so the twist J q̇ it produces, are kept): :data:`SCALED`.
   A whole-body command scales its joints and its twist by one factor, the smallest of both rules, so the
   twist stays J q̇. Scaling toward zero keeps every velocity damper satisfied whose allowed approach speed
   is ≥ 0 (a smaller approach is still allowed); joint acceleration limits yield to velocity limits.
3. **Inputs beyond the limits are clipped** before they are used: the operator's twist and a previous twist
   by rule 2, the operator's joint velocities (a joint jog) by rule 2's joint rule (a command beyond the limits
   would have been scaled before it was sent); previous joint velocities joint by joint to ±v_max,j (a previous
   command that the limits never allowed).
4. **Obstacle speeds** above :data:`MAX_OBSTACLE_SPEED` are refused when given (library, node topic) and
   clipped when estimated from poses (:func:`clip_obstacle_velocity`).

The norms are computed without overflow (each part scaled by its largest component first), so 1e308 m/s
scales to the limit instead of overflowing to inf and zero. Rules 1 and 2 are computed in the compiled core
(``src/core/safety/limits.hpp``, their one home, which the core's own commands use directly); this module is
their Python face.
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import safety as _core
from pfield._validation import as_vector
from pfield.errors import InvalidInput

__all__ = ["HALTED", "MAX_OBSTACLE_SPEED", "SCALED", "WITHIN", "check_obstacle_velocity", "clip_joint_command",
           "clip_joint_velocities", "clip_obstacle_velocity", "clip_twist", "describe", "limit_joint_command",
           "limit_twist", "limit_twists", "twist_scale"]

WITHIN: Final = 0
"""The command was finite and within the limits: returned unchanged."""
SCALED: Final = 1
"""The command exceeded a limit and was scaled down to it (rule 2)."""
HALTED: Final = 2
"""The command was not finite: zeros were returned instead (rule 1)."""

MAX_OBSTACLE_SPEED: Final = 10.0
"""m/s: the fastest obstacle pfield takes (a thrown object; a walking person is 1.5 m/s). A manipulator's
dampers cannot react to anything faster, and a speed far beyond it only makes the relative dampers overflow."""


def twist_scale(values: ArrayLike, max_linear: float, max_angular: float) -> float:
    """The factor s ∈ [0, 1] that brings the twist ``values`` (6: linear, angular) within both limits (1: within);
    NaN when a component is not finite."""
    return float(_core.twist_scale(np.ascontiguousarray(values, dtype=np.float64), max_linear, max_angular))


def limit_twist(values: NDArray[np.float64], max_linear: float, max_angular: float) -> int:
    """Rules 1 and 2 on the writable twist ``values`` (6,) in place; :data:`WITHIN`, :data:`SCALED` or
    :data:`HALTED`."""
    outcome: int = _core.limit_twist(values, max_linear, max_angular)
    return outcome


def limit_twists(values: NDArray[np.float64], max_linear: float, max_angular: float) -> int:
    """Rules 1 and 2 on each row of the writable twists ``values`` (N, 6) in place; the number of rows scaled or
    zeroed."""
    changed: int = _core.limit_twists(values, max_linear, max_angular)
    return changed


def limit_joint_command(joint_velocities: NDArray[np.float64], twist: NDArray[np.float64],
                        joint_limits: NDArray[np.float64], max_linear: float, max_angular: float) -> int:
    """Rules 1 and 2 on a whole-body command in place: q̇ (n,) and its twist J q̇ (6,) scaled by one factor,
    the smaller of the joint rule and the twist rule (both zeroed if either is not finite)."""
    outcome: int = _core.limit_joint_command(joint_velocities, twist, np.ascontiguousarray(joint_limits), max_linear,
                                             max_angular)
    return outcome


def clip_twist(values: ArrayLike, max_linear: float, max_angular: float) -> tuple[NDArray[np.float64], bool]:
    """Rule 3 for an input twist (finite, 6 values): a copy scaled within the limits, and whether it was."""
    array = np.array(values, dtype=np.float64)
    return array, limit_twist(array, max_linear, max_angular) == SCALED


def clip_joint_command(values: ArrayLike, joint_limits: NDArray[np.float64]) -> tuple[NDArray[np.float64], bool]:
    """Rule 3 for an input joint command (the operator's joint jog; finite, n values): a copy scaled by rule 2's
    joint rule, s = min_j v_max,j / |q̇_j| (direction kept), and whether it was (:func:`limit_joint_command` with a
    zero twist, which no twist limit scales)."""
    array = np.array(values, dtype=np.float64)
    return array, limit_joint_command(array, np.zeros(6), joint_limits, 1.0, 1.0) == SCALED


def clip_joint_velocities(values: NDArray[np.float64], joint_limits: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rule 3 for previous joint velocities: ``values`` itself when every |q̇_j| ≤ v_max,j, else a copy clipped
    joint by joint to ±v_max,j (joints without a positive finite limit unchanged). Values that are not all
    finite are returned as they are, for the caller's validation to refuse (never clipped into finite ones)."""
    listed = values.tolist()
    if all(abs(v) <= limit or not 0.0 < limit < math.inf for v, limit in zip(listed, joint_limits.tolist(),
                                                                               strict=True)) \
            or not all(map(math.isfinite, listed)):
        return values
    bounded = np.where((joint_limits > 0.0) & np.isfinite(joint_limits), joint_limits, np.inf)
    return np.clip(values, -bounded, bounded)


def check_obstacle_velocity(field: str, value: ArrayLike) -> NDArray[np.float64]:
    """Rule 4 for a given velocity: 3 finite values of speed ≤ :data:`MAX_OBSTACLE_SPEED`, else ``InvalidInput``."""
    velocity = as_vector(field, value, 3)
    x, y, z = velocity.tolist()
    if _core.part_scale(x, y, z, MAX_OBSTACLE_SPEED) < 1.0:
        raise InvalidInput(field, velocity.tolist(), f"an obstacle speed above {MAX_OBSTACLE_SPEED:g} m/s is not "
                           "physical for pfield's dampers (safety.MAX_OBSTACLE_SPEED); check the units (m/s)")
    return velocity


def clip_obstacle_velocity(x: float, y: float, z: float) -> tuple[float, float, float]:
    """Rule 4 for an estimated velocity (finite): scaled to speed ≤ :data:`MAX_OBSTACLE_SPEED`."""
    scale = _core.part_scale(x, y, z, MAX_OBSTACLE_SPEED)
    return (x * scale, y * scale, z * scale) if scale < 1.0 else (x, y, z)


def describe(outcome: int) -> str:
    """The words for an outcome, as answers' messages carry them ('' for :data:`WITHIN`)."""
    if outcome == SCALED:
        return "velocity limited: the command was scaled down to the velocity limits"
    if outcome == HALTED:
        return "halted: no finite command could be computed from these inputs, so the command is zero"
    return ""
