"""The 2D potential, its analytic gradient and the functional API (pfield.mobile)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfield._core.mobile import fast_exp
from pfield.errors import InvalidInput
from pfield.mobile import VectorFieldParams, field_components, gradient, potential, velocity

RNG = np.random.default_rng(7)
OBSTACLES = np.array([[1.0, 0.5], [-0.8, 1.2], [0.3, -1.1], [2.0, 2.0]])
GOAL = np.array([0.4, 0.2])


def _central_difference(points, goal, obstacles, params, step=1e-5):
    grad = np.empty_like(points)
    for axis in range(2):
        offset = np.zeros(2)
        offset[axis] = step
        grad[:, axis] = (potential(points + offset, goal, obstacles, params)
                         - potential(points - offset, goal, obstacles, params)) / (2 * step)
    return grad


def _query_points(count=60):
    points = RNG.uniform(-3.0, 3.0, size=(count, 2))
    far = np.min(np.linalg.norm(points[:, None, :] - np.vstack([OBSTACLES, GOAL])[None], axis=2), axis=1) > 0.05
    return points[far]


@pytest.mark.parametrize("law", ["power", "linear"])
@pytest.mark.parametrize("ka", [1.0, 2.0, 3.0])
def test_gradient_matches_central_differences(law, ka):
    params = VectorFieldParams(ka=ka, kr_dist=0.3, kr_height=1.5, kr_slope=2.0, attraction=law)
    points = _query_points()
    analytic = gradient(points, GOAL, OBSTACLES, params)
    numeric = _central_difference(points, GOAL, OBSTACLES, params)
    relative = np.linalg.norm(analytic - numeric, axis=1) / np.linalg.norm(numeric, axis=1)
    assert relative.max() < 1e-6


def test_potential_exact_values():
    params = VectorFieldParams(ka=2.0, kr_dist=0.5, kr_height=2.0, kr_slope=4.0)
    # attraction ‖d‖^2 at distance 3, one hill of height h/s = 0.5 at r = kr_dist
    assert potential([[3.0, 0.0]], [0.0, 0.0], None, params)[0] == pytest.approx(9.0, rel=1e-15)
    assert potential([[0.5, 0.0]], None, [[0.0, 0.0]], params)[0] == pytest.approx(0.5, rel=1e-14)
    linear = VectorFieldParams(ka=3.0, attraction="linear", kr_height=0.0)
    assert potential([[0.0, 2.0]], [0.0, 0.0], None, linear)[0] == pytest.approx(6.0)
    assert gradient([[0.0, 2.0]], [0.0, 0.0], None, linear)[0] == pytest.approx([0.0, 6.0])


def test_power_law_gradient_norm_is_ka_d_to_ka_minus_1():
    """The seed's typo: the exact gradient's norm is ka·‖d‖^(ka−1), not ka·‖d‖^ka."""
    params = VectorFieldParams(ka=3.0, kr_height=0.0)
    grad = gradient([[2.0, 0.0]], [0.0, 0.0], None, params)[0]
    assert grad == pytest.approx([3.0 * 2.0**2, 0.0], rel=1e-14)


def test_no_goal_means_no_attraction_and_weights_scale_hills():
    params = VectorFieldParams(ka=3.0, kr_dist=0.0, kr_height=2.0, kr_slope=1.0)
    parts = field_components([[1.0, 0.0]], None, [[0.0, 0.0]], params)
    assert np.all(parts.attraction == 0.0)
    assert parts.repulsion[0] == pytest.approx([2.0 * math.exp(-1.0), 0.0], rel=1e-14)
    doubled = field_components([[1.0, 0.0]], None, [[0.0, 0.0]], params, weights=[2.0])
    assert doubled.repulsion[0] == pytest.approx(2.0 * parts.repulsion[0], rel=1e-14)


def test_components_at_is_one_row_of_field_components_by_name():
    from pfield.mobile.field2d import components_at

    params = VectorFieldParams(ka=2.0, kr_dist=0.2, kr_height=1.5, kr_slope=3.0)
    obstacles = np.array([[0.5, 0.2], [-0.3, 0.8], [1.0, -1.0]])
    rows = field_components([[0.1, -0.2]], [2.0, 1.0], obstacles, params)
    one = components_at(0.1, -0.2, np.array([2.0, 1.0]), True, np.ascontiguousarray(obstacles[:, 0]),
                        np.ascontiguousarray(obstacles[:, 1]), np.ones(3), params.core_field)
    assert one.potential == pytest.approx(rows.potential[0], rel=1e-13)
    assert one.attraction == pytest.approx(tuple(rows.attraction[0]), rel=1e-13)
    assert one.repulsion == pytest.approx(tuple(rows.repulsion[0]), rel=1e-13)


def test_no_nan_on_goal_or_obstacle_point():
    params = VectorFieldParams(ka=0.5, kr_dist=0.0, kr_height=2.0, kr_slope=1.0)
    points = np.array([[0.0, 0.0], [1.0, 1.0]])
    for goal, obstacles in [([0.0, 0.0], [[0.0, 0.0]]), ([1.0, 1.0], [[0.0, 0.0], [1.0, 1.0]])]:
        for values in (potential(points, goal, obstacles, params), gradient(points, goal, obstacles, params),
                       velocity(points, goal, obstacles, params)):
            assert np.all(np.isfinite(values))
    # ka < 1 right next to the goal: the power law's ka·d^(ka−1) is capped, never inf or NaN
    tiny = np.array([[0.0, 5e-324], [1e-200, 0.0], [-1e-310, 1e-310]])
    for ka in (0.01, 0.5):
        weak = VectorFieldParams(ka=ka, kr_height=2.0)
        assert np.all(np.isfinite(gradient(tiny, [0.0, 0.0], [[0.0, 0.0]], weak)))
        command = velocity(tiny, [0.0, 0.0], [[0.0, 0.0]], weak)
        assert np.all(np.isfinite(command)) and np.linalg.norm(command, axis=1).max() <= 1.0
    # on an isolated obstacle point the repulsion has no direction: zero
    assert np.all(gradient([[0.0, 0.0]], None, [[0.0, 0.0]], params) == 0.0)


@pytest.mark.parametrize(("name", "kwargs"), [
    ("ka", {"ka": -1.0}), ("ka", {"ka": 11.0}), ("kr_slope", {"kr_slope": 0.0}), ("kr_height", {"kr_height": -1}),
    ("min_spd_norm", {"min_spd_norm": 2.0, "max_spd_norm": 1.0}), ("max_spd_norm", {"max_spd_norm": 0.0}),
    ("attraction", {"attraction": "quadratic"}), ("clamping", {"clamping": "soft"}),
    ("kr_dist", {"kr_dist": float("nan")}), ("kr_dist", {"kr_dist": 20.0, "kr_slope": 30.0}),
    ("goal_tolerance", {"goal_tolerance": -0.1}),
])
def test_bad_parameters_are_rejected_by_name(name, kwargs):
    with pytest.raises(InvalidInput) as info:
        VectorFieldParams(**kwargs)
    assert info.value.field == name


@pytest.mark.parametrize(("field", "args"), [
    ("points", ([[0.0, 0.0, 0.0]], None, None)),
    ("points", ([[np.nan, 0.0]], None, None)),
    ("goal", ([[0.0, 0.0]], [1.0], None)),
    ("obstacles", ([[0.0, 0.0]], None, [[1.0, np.inf]])),
])
def test_bad_arrays_are_rejected_by_name(field, args):
    with pytest.raises(InvalidInput) as info:
        velocity(*args, VectorFieldParams())
    assert info.value.field == field


def test_bad_weights_are_rejected():
    with pytest.raises(InvalidInput, match="weights"):
        potential([[0.0, 0.0]], None, [[1.0, 0.0]], VectorFieldParams(), weights=[1.0, 2.0])
    with pytest.raises(InvalidInput, match="weights"):
        potential([[0.0, 0.0]], None, [[1.0, 0.0]], VectorFieldParams(), weights=[-1.0])


def test_fast_exp_is_accurate_to_a_few_ulp():
    x = np.concatenate([np.linspace(-700.0, 700.0, 100_001), RNG.uniform(-50.0, 5.0, 10_000), [0.0]])
    assert np.max(np.abs(np.array([fast_exp(v) for v in x.tolist()]) / np.exp(x) - 1.0)) < 1e-15
    assert fast_exp(-1e308) == fast_exp(-700.0) > 0.0  # clipped below: never 0


def test_the_largest_exponents_the_parameters_allow_stay_finite():
    # fast_exp's domain ends at +700; the field's exponents end at kr_slope*kr_dist, which the parameters keep <= 300
    params = VectorFieldParams(kr_dist=2.0, kr_slope=150.0)
    with pytest.raises(InvalidInput, match="kr_slope"):
        VectorFieldParams(kr_dist=2.0, kr_slope=151.0)
    obstacle = np.array([[0.0, 0.0]])
    peak = potential([[0.0, 0.0]], None, obstacle, params)[0]
    assert peak == pytest.approx(params.kr_height / 150.0 * math.exp(300.0), rel=1e-14)
    far = potential([[1e150, -1e150], [3.0, 0.0]], None, obstacle, params)  # exponents far below -700: clipped
    assert np.all(np.isfinite(far)) and np.all(far > 0.0)
    assert np.all(np.isfinite(velocity([[1e-300, 0.0], [0.0, 0.0]], None, obstacle, params)))
