"""The stagnation rule shared by every compiled planning loop (numba).

One rule, with the window and progress of :class:`~pfield.planning.PlanOptions`: the loop keeps the best
position and rotation errors reached so far, and every ``window`` steps compares them with their values
one window earlier. When neither improved by ``progress`` (m, and rad for the rotation), the plan
stagnates. Using the best errors rather than the current ones makes a limit cycle (errors oscillating
about a blocked configuration) stagnate as surely as a standstill, while steady slow progress, or trading
rotation for position, does not.

The state is four floats passed through the loop (best position and rotation errors, and their values at
the last window boundary, all ``inf`` at the start): as a returned tuple it stays in registers.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def track_progress(
    state: tuple[float, float, float, float], step: int, window: int, progress: float, position_error: float,
    rotation_error: float,
) -> tuple[tuple[float, float, float, float], bool]:
    """Record step ``step``'s goal errors (m, rad); returns (the new state, True when the window brought no
    progress)."""
    best_position, best_rotation, window_position, window_rotation = state
    best_position = min(best_position, position_error)
    best_rotation = min(best_rotation, rotation_error)
    if step % window != 0:
        return (best_position, best_rotation, window_position, window_rotation), False
    if window_position - best_position < progress and window_rotation - best_rotation < progress:
        return (best_position, best_rotation, window_position, window_rotation), True
    return (best_position, best_rotation, best_position, best_rotation), False
