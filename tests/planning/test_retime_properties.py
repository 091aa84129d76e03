"""Properties of the retiming on arbitrary joint paths (issue 34): whatever the polyline, its sampling and the limits,
the trajectory keeps every waypoint, starts and ends at rest, keeps |q̇| and |q̈| within the limits at every
waypoint, and moves no joint between two waypoints faster than its velocity limit allows."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pfield.planning.retime import retime_joint_path

_TOLERANCE = 1e-6  # relative: the retiming settles within 1e-9 of a limit, and sums round


@st.composite
def _paths(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """A polyline of 2–5 random vertices in [−2, 2]ⁿ (n = 1..7), each segment sampled by 2–60 points (as the
    planners' dense paths are; sharp corners and reversals included), limits v ∈ [0.2, 3], a ∈ [0.5, 10], dt."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n, count = int(rng.integers(1, 8)), int(rng.integers(2, 6))
    vertices = rng.uniform(-2.0, 2.0, (count, n))
    pieces = [np.linspace(vertices[k], vertices[k + 1], int(rng.integers(2, 61)))[1 if k else 0:]
              for k in range(count - 1)]
    dt = float(rng.choice([0.005, 0.01, 0.02, 0.05]))
    return np.vstack(pieces), rng.uniform(0.2, 3.0, n), rng.uniform(0.5, 10.0, n), dt


@settings(max_examples=150, deadline=None)
@given(_paths())
def test_a_retimed_path_never_exceeds_its_limits_and_rests_at_both_ends(
        case: tuple[np.ndarray, np.ndarray, np.ndarray, float]) -> None:
    points, v_max, a_max, dt = case
    names = tuple(f"j{k}" for k in range(points.shape[1]))
    trajectory = retime_joint_path(names, points, v_max, a_max, dt)
    np.testing.assert_array_equal(trajectory.positions, points)
    assert trajectory.times[0] == 0.0 and np.all(np.diff(trajectory.times) > 0.0)
    # at rest at both ends
    np.testing.assert_array_equal(trajectory.velocities[[0, -1]], 0.0)
    # the limits hold at every waypoint, as reported
    assert np.all(np.abs(trajectory.velocities) <= v_max * (1 + _TOLERANCE))
    assert np.all(np.abs(trajectory.accelerations) <= a_max * (1 + _TOLERANCE))
    # and between waypoints: the mean speed |Δq_j| / Δt never exceeds v_j (a controller that interpolates the
    # positions moves at least that fast somewhere in the interval)
    mean = np.abs(np.diff(points, axis=0)) / np.diff(trajectory.times)[:, None]
    assert np.all(mean <= v_max * (1 + _TOLERANCE))
    # so no joint can arrive sooner than its travel at full speed allows
    travel = np.sum(np.abs(np.diff(points, axis=0)), axis=0)
    assert trajectory.duration >= float(np.max(travel / v_max)) * (1 - _TOLERANCE)
