"""The speed clamping strategy of the original vector-field controller (seed document 004).

Raw −∇V is unbounded (a steep hill near an obstacle, ‖p − p_a‖^(ka−1) far from the goal), so the command is
built from norm-clamped parts, each clamp keeping the vector's direction:

1. repulsive part  v_r = −∇V_r, norm clamped to [0, max_spd_norm];
2. attractive part v_a = −∇V_a, norm clamped to [min_spd_norm, max_spd_norm] (the lower bound keeps the
   robot moving slowly but surely towards a far goal when ``ka`` makes the hole flat);
3. command v = v_r + v_a, norm clamped to [0, max_spd_norm].

A zero vector has no direction and stays zero (at the goal, exactly on an obstacle point), so the
result is never NaN and ‖v‖ ≤ max_spd_norm always holds.

``hard`` (default, the original's): n ↦ min(max(n, lower), upper). ``tanh`` (smooth, optional):
n ↦ max(lower, upper·tanh(n / upper)) for the two parts (≈ identity for small n, no kink at the upper
bound), while the sum keeps the hard clamp (it only binds when both parts push the same way, and a second
tanh would pull free-space speeds below ``min_spd_norm``). Choose it when the kink's chattering matters.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["HARD", "TANH", "clamp_norm", "clamped_sum", "clamped_sum_batch"]

HARD, TANH = 0, 1


@njit(cache=True, inline="always")
def clamp_norm(vx: float, vy: float, lower: float, upper: float, mode: int) -> tuple[float, float]:
    """Rescale (vx, vy) so its norm lies in [lower, upper], keeping the direction; zero stays zero."""
    # work on (vx, vy)/max(|vx|, |vy|): exact, and neither the norm nor 1/norm under- or overflows, so even
    # subnormal vectors keep their direction
    scale = max(abs(vx), abs(vy))
    if scale == 0.0:
        return 0.0, 0.0
    ux = vx / scale
    uy = vy / scale
    length = math.hypot(ux, uy)  # in [1, √2]
    norm = scale * length
    if mode == TANH:
        target = max(lower, upper * math.tanh(norm / upper))
    else:
        target = min(max(norm, lower), upper)
    factor = target / length
    return ux * factor, uy * factor


@njit(cache=True, inline="always")
def clamped_sum(ax: float, ay: float, rx: float, ry: float, min_spd: float, max_spd: float,
                mode: int) -> tuple[float, float]:
    """The command of the clamping strategy from the raw attractive (ax, ay) and repulsive (rx, ry) parts."""
    rx, ry = clamp_norm(rx, ry, 0.0, max_spd, mode)
    ax, ay = clamp_norm(ax, ay, min_spd, max_spd, mode)
    # the sum's clamp is hard in both modes: a second tanh would pull free-space speeds below min_spd_norm
    return clamp_norm(ax + rx, ay + ry, 0.0, max_spd, HARD)


@njit(cache=True)
def clamped_sum_batch(attraction: NDArray[np.float64], repulsion: NDArray[np.float64], min_spd: float,
                      max_spd: float, mode: int) -> NDArray[np.float64]:
    """:func:`clamped_sum` over rows of (N, 2) arrays."""
    out = np.empty_like(attraction)
    for i in range(attraction.shape[0]):
        out[i, 0], out[i, 1] = clamped_sum(attraction[i, 0], attraction[i, 1], repulsion[i, 0],
                                           repulsion[i, 1], min_spd, max_spd, mode)
    return out
