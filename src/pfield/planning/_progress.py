"""The stagnation rule shared by every compiled planning loop (numba).

One rule, with the window and progress of :class:`~pfield.planning.PlanOptions`: the loop keeps the best
position and rotation errors reached so far, and every ``window`` steps compares them with their values
one window earlier. When neither improved by ``progress`` (m, and rad for the rotation), the plan
stagnates. Using the best errors rather than the current ones makes a limit cycle (errors oscillating
about a blocked configuration) stagnate as surely as a standstill, while steady slow progress, or trading
rotation for position, does not.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def new_progress() -> np.ndarray:
    """The (4,) state of :func:`stagnated`: best position and rotation errors, and their window values."""
    return np.full(4, math.inf)


@njit(cache=True, inline="always")
def stagnated(state: np.ndarray, step: int, window: int, progress: float, position_error: float,
              rotation_error: float) -> bool:
    """Record step ``step``'s goal errors (m, rad) in ``state``; True when the window brought no progress."""
    state[0] = min(state[0], position_error)
    state[1] = min(state[1], rotation_error)
    if step % window != 0:
        return False
    if state[2] - state[0] < progress and state[3] - state[1] < progress:
        return True
    state[2], state[3] = state[0], state[1]
    return False
