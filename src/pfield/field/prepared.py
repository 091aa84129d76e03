"""A prepared single-pose field evaluation for control loops: :class:`PreparedTwist`.

:meth:`PotentialField.twist` validates a :class:`~pfield.spatial.Pose` and builds a :class:`~pfield.spatial.Twist`
on every call, which costs more than the evaluation itself. A control loop that asks the same field for one
twist per cycle can bind its arrays once instead (the model/data split of pinocchio: the field is the model,
the prepared call owns the data) and then call with arrays in, arrays out::

    prepared = PreparedTwist(field)          # validated and bound once
    prepared.pose[:] = (x, y, z, qx, qy, qz, qw)
    prepared.evaluate()                      # limited twist into prepared.twist (6,)
    prepared.previous[:] = prepared.twist    # rate limits against the previous command:
    prepared.evaluate(0.01)                  # dt = 0.01 s

``evaluate(dt)`` is one compiled call with one array argument, between the output contract's checks
(:mod:`pfield.safety`): a ``previous`` beyond the speed limits is scaled within them in place (a non-finite one
is refused), and the answer is finite and within the limits. It checks the pose inside compiled code
(finite, unit quaternion within 1e-9) and raises :class:`~pfield.errors.InvalidInput` otherwise, leaving
``twist`` unchanged. The results are those of ``field.twist(Pose(p, q), Twist(previous[:3], previous[3:]), dt)``
bit for bit (``dt`` = 0: no previous twist). One prepared object per thread: its arrays are its state.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from pfield import safety
from pfield._bound import BoundArrays, float_view1, float_view2, float_view3, int_view1, int_view2
from pfield.errors import InvalidInput
from pfield.field._evaluate import constrained_twist
from pfield.geometry._packed import PackedObstacles

__all__ = ["PreparedTwist"]

_UNIT_TOLERANCE = 1e-9
_POSE, _PREVIOUS, _TWIST, _GOAL, _PARAMS, _AUX = range(6)
_KINDS, _ROWS, _TRIANGLES, _NORMALS, _LOWER, _UPPER, _NODES, _MESHES = range(6, 14)
OK, BAD_POSITION, BAD_ORIENTATION = 0, 1, 2


@njit(cache=True)
def prepared_twist(table: np.ndarray, use_previous: bool, dt: float) -> int:
    """The limited twist at the bound pose into the bound twist; 0, or the pose's defect (1 position, 2 quaternion)."""
    pose = float_view1(table, _POSE)
    for k in range(3):
        if not math.isfinite(pose[k]):
            return BAD_POSITION
    norm2 = pose[3] * pose[3] + pose[4] * pose[4] + pose[5] * pose[5] + pose[6] * pose[6]
    if not abs(norm2 - 1.0) <= 2.0 * _UNIT_TOLERANCE:
        return BAD_ORIENTATION
    packed = PackedObstacles(int_view1(table, _KINDS), float_view2(table, _ROWS), float_view3(table, _TRIANGLES),
                             float_view3(table, _NORMALS), float_view2(table, _LOWER), float_view2(table, _UPPER),
                             int_view2(table, _NODES), int_view2(table, _MESHES))
    out, previous = float_view1(table, _TWIST), float_view1(table, _PREVIOUS)
    scratch = np.zeros(6)  # the previous twist (also steering the dampers' tangential side), zero without
    if use_previous:
        for k in range(6):
            scratch[k] = previous[k]
    out[0], out[1], out[2], out[3], out[4], out[5], _, _ = constrained_twist(
        pose[:3], pose[3], pose[4], pose[5], pose[6], float_view1(table, _GOAL), float_view1(table, _PARAMS), packed,
        float_view2(table, _AUX), scratch, use_previous, dt)
    return OK


class PreparedTwist:
    """The limited twist of ``field`` at one pose per call, through bound arrays (see the module docstring).

    ``pose`` (7,): position (m) then unit quaternion (x, y, z, w), world frame; ``previous`` (6,): the previous
    twist (m/s, rad/s) used when ``evaluate`` gets ``dt`` > 0; ``twist`` (6,): the answer (linear then angular).
    """

    def __init__(self, field: object) -> None:
        from pfield.field.field import PotentialField

        if not isinstance(field, PotentialField):
            raise InvalidInput("field", field, "expected a pfield.PotentialField")
        goal, params, packed, aux = field.arrays
        self.field = field
        self.pose = np.zeros(7)
        self.pose[6] = 1.0
        self.previous = np.zeros(6)
        self.twist = np.zeros(6)
        self._bound = BoundArrays([self.pose, self.previous, self.twist, goal, params, aux, *packed])
        self._table = self._bound.table

    def evaluate(self, dt: float = 0.0) -> NDArray[np.float64]:
        """Evaluate at ``pose`` into ``twist`` (returned); with ``dt`` > 0 (s) rate-limited against ``previous``."""
        if dt.__class__ is not float or not 0.0 <= dt < math.inf:
            dt = _check_dt(dt)
        config = self.field.config
        if dt > 0.0:
            scale = safety.twist_scale(self.previous.tolist(), config.max_linear_velocity, config.max_angular_velocity)
            if scale != scale:  # NaN: a component is not finite
                raise InvalidInput("previous", self.previous.tolist(), "must be finite (no NaN or inf)")
            if scale < 1.0:
                self.previous *= scale
        status = prepared_twist(self._table, dt > 0.0, dt)
        if status:
            raise _pose_error(status, self.pose)
        safety.limit_twist(self.twist, config.max_linear_velocity, config.max_angular_velocity)
        return self.twist


def _check_dt(dt: object) -> float:
    try:
        value = float(dt)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InvalidInput("dt", dt, "must be a number") from None
    if isinstance(dt, bool) or not 0.0 <= value < math.inf:
        raise InvalidInput("dt", dt, "must be a finite number >= 0 s")
    return value


def _pose_error(status: int, pose: NDArray[np.float64]) -> InvalidInput:
    if status == BAD_POSITION:
        return InvalidInput("pose[0:3]", pose[:3].tolist(), "position must be finite")
    return InvalidInput("pose[3:7]", pose[3:].tolist(), "orientation must be a unit quaternion (x, y, z, w)")
