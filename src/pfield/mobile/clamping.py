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

from pfield._core import mobile as _mobile

__all__ = ["HARD", "TANH", "clamp_norm", "clamped_sum", "clamped_sum_batch"]

HARD, TANH = _mobile.Clamping.HARD, _mobile.Clamping.TANH
clamp_norm = _mobile.clamp_norm
"""``clamp_norm(vx, vy, lower, upper, mode)``: (vx, vy) rescaled so its norm lies in [lower, upper], direction
kept; zero stays zero. Computed on v / max(|vx|, |vy|), so subnormal and 1e308 vectors keep their direction."""
clamped_sum = _mobile.clamped_sum
"""``clamped_sum(ax, ay, rx, ry, limits)``: the command from the raw attractive and repulsive parts (rules 1–3
above; ``limits`` is :attr:`VectorFieldParams.core_limits <pfield.mobile.VectorFieldParams.core_limits>`)."""
clamped_sum_batch = _mobile.clamped_sum_batch
"""``clamped_sum_batch(attraction, repulsion, limits)``: :func:`clamped_sum` over the rows of (N, 2) arrays."""
