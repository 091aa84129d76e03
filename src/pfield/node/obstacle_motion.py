"""Velocities of ``Dynamic`` obstacles from successive poses of the same id.

Filter: the finite difference v_raw = (p_k − p_{k−1}) / (t_k − t_{k−1}) of the centre, smoothed exponentially,
v_k = v_{k−1} + β (v_raw − v_{k−1}) with β = :data:`VELOCITY_SMOOTHING` (a first-order low-pass whose time
constant is about one update period). It is reset to v = 0 (and starts again from the next pose) on a jump:
a displacement above :data:`MAX_OBSTACLE_JUMP` m, or updates further apart than the node's
``dynamic_obstacle_timeout`` (a re-appearing obstacle), or a change of the obstacle's shape. Poses arriving
within :data:`MIN_UPDATE_INTERVAL` s of the previous one keep the previous velocity (a burst of duplicate
publications would otherwise divide by ~0). ``Static`` and ``Robot`` obstacles stay at rest. A velocity given
explicitly on ``/pfield/obstacle_velocities`` replaces the estimate and is kept while the obstacle is held.
An estimate faster than :data:`pfield.safety.MAX_OBSTACLE_SPEED` is scaled down to it (a given one is refused).
"""

from __future__ import annotations

import math
from typing import Any

from pfield.node._manager_state import Held
from pfield.safety import clip_obstacle_velocity

__all__ = ["MAX_OBSTACLE_JUMP", "MIN_UPDATE_INTERVAL", "VELOCITY_SMOOTHING", "Held", "updated_held"]

VELOCITY_SMOOTHING = 0.5
"""β of the exponential filter (0 < β ≤ 1; 1 = the raw finite difference)."""
MAX_OBSTACLE_JUMP = 0.5
"""m: a displacement between two updates above this is a jump (another object, a re-detection), not motion."""
MIN_UPDATE_INTERVAL = 1e-3
"""s: updates closer than this keep the previous velocity."""


def updated_held(previous: Held | None, obstacle: Any, now: float, timeout: float) -> Held:
    """The :class:`Held` entry for ``obstacle`` received at monotonic time ``now`` (s)."""
    if obstacle.group != "Dynamic" or previous is None:
        return Held(obstacle, now)
    if previous.explicit:
        return Held(obstacle, now, previous.velocity, True)
    elapsed = now - previous.updated
    old, new = previous.obstacle.pose.position, obstacle.pose.position
    delta = [float(new[k] - old[k]) for k in range(3)]
    jump = math.sqrt(sum(x * x for x in delta)) > MAX_OBSTACLE_JUMP
    if jump or (timeout > 0 and elapsed > timeout) or previous.obstacle.shape != obstacle.shape:
        return Held(obstacle, now)
    if elapsed < MIN_UPDATE_INTERVAL:
        return Held(obstacle, now, previous.velocity)
    v = previous.velocity
    smoothed = [v[k] + VELOCITY_SMOOTHING * (delta[k] / elapsed - v[k]) for k in range(3)]
    return Held(obstacle, now, clip_obstacle_velocity(smoothed[0], smoothed[1], smoothed[2]))
