"""The clamping strategy: bounds and directions of every clamp, no NaN, free-space speeds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pfield.mobile import VectorFieldParams, field_components, velocity
from pfield.mobile.clamping import HARD, TANH, clamp_norm, clamped_sum

finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(vx=finite, vy=finite, lower=st.floats(0.0, 1.0), span=st.floats(0.01, 2.0),
       mode=st.sampled_from([HARD, TANH]))
@example(vx=0.0, vy=2.225073858507203e-309, lower=1.0, span=1.0, mode=HARD)  # subnormal: 1/norm overflows
@example(vx=0.0, vy=1.0913167793951157e-194, lower=0.0, span=1.0, mode=HARD)  # vx²+vy² underflows
@example(vx=5e-324, vy=5e-324, lower=1.0, span=0.25, mode=HARD)  # hypot of subnormals loses the direction
def test_clamp_norm_keeps_direction_and_bounds(vx, vy, lower, span, mode):
    upper = lower + span
    cx, cy = clamp_norm(vx, vy, lower, upper, mode)
    norm_in, norm_out = math.hypot(vx, vy), math.hypot(cx, cy)
    if norm_in == 0.0:
        assert (cx, cy) == (0.0, 0.0)
        return
    assert lower * (1 - 1e-12) <= norm_out <= upper * (1 + 1e-12)
    if norm_out > 1e-290:  # a subnormal result cannot carry its direction to 1e-12
        raw = np.array([vx, vy]) / max(abs(vx), abs(vy))  # exact rescaling: a reference direction for subnormals
        assert np.array([cx, cy]) / norm_out == pytest.approx(raw / np.linalg.norm(raw), abs=1e-12)
    if mode == HARD and lower <= norm_in <= upper:
        assert norm_out == pytest.approx(norm_in, rel=1e-12)


def test_hard_clamp_matches_the_original_strategy_by_hand():
    # attraction 3 m/s -> 1, repulsion 0.0996 stays, opposite: 1 - 0.0996
    limits = VectorFieldParams(min_spd_norm=0.1, max_spd_norm=1.0).core_limits
    vx, vy = clamped_sum(-3.0, 0.0, 2.0 * math.exp(-3.0), 0.0, limits)
    assert (vx, vy) == pytest.approx((-(1.0 - 2.0 * math.exp(-3.0)), 0.0), rel=1e-14)
    # tiny attraction is lifted to min_spd_norm, the sum is then clamped to max
    assert clamped_sum(0.0, 0.01, 0.0, 0.0, limits) == pytest.approx((0.0, 0.1))
    assert clamped_sum(5.0, 0.0, 5.0, 0.0, limits) == pytest.approx((1.0, 0.0))


@pytest.mark.parametrize("clamping", ["hard", "tanh"])
@pytest.mark.parametrize("law", ["power", "linear"])
def test_speed_never_exceeds_max_anywhere_even_on_obstacles(clamping, law):
    obstacles = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [-2.0, 0.5]])
    params = VectorFieldParams(ka=3.0, kr_dist=1.0, kr_height=50.0, kr_slope=5.0, min_spd_norm=0.2,
                               max_spd_norm=0.7, attraction=law, clamping=clamping)
    grid = np.stack(np.meshgrid(np.linspace(-3, 3, 61), np.linspace(-3, 3, 61)), axis=-1).reshape(-1, 2)
    points = np.vstack([grid, obstacles, [[0.5, 0.5]]])
    for goal in ([0.5, 0.5], [1.0, 0.0], None):
        command = velocity(points, goal, obstacles, params)
        assert np.all(np.isfinite(command))
        assert np.linalg.norm(command, axis=1).max() <= params.max_spd_norm * (1 + 1e-12)


@pytest.mark.parametrize("clamping", ["hard", "tanh"])
@pytest.mark.parametrize(("law", "ka"), [("power", 3.0), ("power", 1.0), ("linear", 0.5)])
def test_free_space_speed_lies_between_min_and_max_away_from_goal(clamping, law, ka):
    params = VectorFieldParams(ka=ka, min_spd_norm=0.1, max_spd_norm=1.0, attraction=law, clamping=clamping)
    rng = np.random.default_rng(3)
    points = rng.uniform(-20.0, 20.0, size=(2000, 2))
    points = np.vstack([points, [[1e-4, 0.0], [0.0, 1e-9]]])
    speed = np.linalg.norm(velocity(points, [0.0, 0.0], None, params), axis=1)
    assert speed.min() >= 0.1 * (1 - 1e-12)
    assert speed.max() <= 1.0 * (1 + 1e-12)


def test_clamped_command_points_along_raw_direction_when_only_one_part_acts():
    params = VectorFieldParams(ka=3.0, kr_height=0.0)
    points = np.array([[3.0, 4.0], [-0.2, 0.1]])
    raw = field_components(points, [0.0, 0.0], None, params).attraction
    command = velocity(points, [0.0, 0.0], None, params)
    cos = np.sum(raw * command, axis=1) / (np.linalg.norm(raw, axis=1) * np.linalg.norm(command, axis=1))
    assert cos == pytest.approx([1.0, 1.0], abs=1e-12)


coordinate = st.floats(min_value=-10.0, max_value=10.0, allow_nan=False)
point = st.tuples(coordinate, coordinate)


@settings(max_examples=150, deadline=None)
@given(ka=st.floats(0.0, 10.0), kr_dist=st.floats(-2.0, 2.0), kr_height=st.floats(0.0, 100.0),
       kr_slope=st.floats(0.1, 50.0), bounds=st.tuples(st.floats(0.0, 2.0), st.floats(0.01, 2.0)),
       law=st.sampled_from(["power", "linear"]), clamping=st.sampled_from(["hard", "tanh"]),
       obstacles=st.lists(point, max_size=6), queries=st.lists(point, min_size=1, max_size=6),
       goal=st.one_of(st.none(), point))
def test_command_is_finite_and_bounded_for_any_parameters(ka, kr_dist, kr_height, kr_slope, bounds, law, clamping,
                                                          obstacles, queries, goal):
    low, span = bounds
    params = VectorFieldParams(ka=ka, kr_dist=kr_dist, kr_height=kr_height, kr_slope=kr_slope, min_spd_norm=low,
                               max_spd_norm=low + span, attraction=law, clamping=clamping)
    points = np.array(queries + obstacles + ([goal] if goal else []), dtype=float)
    command = velocity(points, goal, obstacles or None, params)
    assert np.all(np.isfinite(command))
    assert np.linalg.norm(command, axis=1).max() <= params.max_spd_norm * (1 + 1e-12)
