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

``evaluate(dt)`` is one call of the compiled core on the bound arrays, between the output contract's checks
(:mod:`pfield.safety`, applied by the core): a ``previous`` beyond the speed limits is used as if scaled within
them (a non-finite one is refused), and the answer is finite and within the limits. It checks the pose inside
compiled code (finite, unit quaternion within 1e-9) and raises :class:`~pfield.errors.InvalidInput` otherwise, leaving
``twist`` unchanged. The results are those of ``field.twist(Pose(p, q), Twist(previous[:3], previous[3:]), dt)``
bit for bit (``dt`` = 0: no previous twist). One prepared object per thread: its arrays are its state.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from pfield._core import field as _core_field
from pfield.errors import InvalidInput

__all__ = ["PreparedTwist"]

OK, BAD_POSITION, BAD_ORIENTATION, BAD_PREVIOUS = 0, 1, 2, 3
"""The core's answers of ``Field.evaluate``: done, or which input it refused (leaving ``twist`` unchanged)."""


class PreparedTwist:
    """The limited twist of ``field`` at one pose per call, through bound arrays (see the module docstring).

    ``pose`` (7,): position (m) then unit quaternion (x, y, z, w), world frame; ``previous`` (6,): the previous
    twist (m/s, rad/s) used when ``evaluate`` gets ``dt`` > 0; ``twist`` (6,): the answer (linear then angular).
    """

    def __init__(self, field: object) -> None:
        from pfield.field.field import PotentialField

        if not isinstance(field, PotentialField):
            raise InvalidInput("field", field, "expected a pfield.PotentialField")
        self.field = field
        self._prepared = _core_field.Prepared(field.compiled)
        # NumPy views of the core object's memory: write the pose and the previous twist in place
        self.pose: NDArray[np.float64] = self._prepared.pose
        self.previous: NDArray[np.float64] = self._prepared.previous
        self.twist: NDArray[np.float64] = self._prepared.twist

    def evaluate(self, dt: float = 0.0) -> NDArray[np.float64]:
        """Evaluate at ``pose`` into ``twist`` (returned); with ``dt`` > 0 (s) rate-limited against ``previous``."""
        if dt.__class__ is not float or not 0.0 <= dt < math.inf:
            dt = _check_dt(dt)
        status = self._prepared.evaluate(dt)
        if status:
            raise _pose_error(status, self.pose, self.previous)
        return self.twist


def _check_dt(dt: object) -> float:
    try:
        value = float(dt)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InvalidInput("dt", dt, "must be a number") from None
    if isinstance(dt, bool) or not 0.0 <= value < math.inf:
        raise InvalidInput("dt", dt, "must be a finite number >= 0 s")
    return value


def _pose_error(status: int, pose: NDArray[np.float64], previous: NDArray[np.float64]) -> InvalidInput:
    if status == BAD_PREVIOUS:
        return InvalidInput("previous", previous.tolist(), "must be finite (no NaN or inf)")
    if status == BAD_POSITION:
        return InvalidInput("pose[0:3]", pose[:3].tolist(), "position must be finite")
    return InvalidInput("pose[3:7]", pose[3:].tolist(), "orientation must be a unit quaternion (x, y, z, w)")
