"""The force and limit laws of pfield.field.forces (the compiled core's ``src/core/field/forces.hpp``): exact
values, continuity, bounds, and the numba kernels' bits.

Until issue 32 removed them, numba kernels computed these laws for the whole-body planner and the assistance; the
core's laws were held equal to them bit for bit. :data:`NUMBA_DIGEST` holds the laws' outputs on the seeded inputs
of :func:`_outputs`, recorded when every one of them equalled numba's."""

from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfield._core.field import braking_rate_limit, rate_limit
from pfield.field.config import PARAM_NAMES, PARAMS
from pfield.field.forces import (
    attraction,
    damper_speed,
    deflect,
    khatib_magnitude,
    project_damper,
    soft_saturate,
)

(ATTRACTIVE_GAIN, ATTRACTIVE_THRESHOLD, CIRCULATION_GAIN, DAMPER_GAIN, INFLUENCE_DISTANCE, MAX_ANGULAR_ACCELERATION,
 MAX_ANGULAR_VELOCITY, MAX_LINEAR_ACCELERATION, MAX_LINEAR_VELOCITY, MAX_REPULSIVE_FORCE, REPULSIVE_GAIN,
 ROTATION_TOLERANCE, ROTATIONAL_GAIN, SAFETY_DISTANCE, STAGNATION_PROGRESS, STAGNATION_WINDOW) = (
    PARAMS.index(name) for name in (
        "attractive_gain", "attractive_threshold", "circulation_gain", "damper_gain", "influence_distance",
        "max_angular_acceleration", "max_angular_velocity", "max_linear_acceleration", "max_linear_velocity",
        "max_repulsive_force", "repulsive_gain", "rotation_tolerance", "rotational_attractive_gain",
        "safety_distance", "stagnation_progress", "stagnation_window"))

finite = st.floats(-10.0, 10.0, allow_nan=False)
vectors = st.tuples(finite, finite, finite)


def test_the_core_parameter_struct_is_the_config_fields_in_order() -> None:
    """FieldConfig.packed() is read in place as the core's FieldParams struct: its members (offsetof, exported by
    the binding) must be the config's fields in declaration order."""
    from pfield._core import field as core

    assert core.PARAM_OFFSETS == {name: PARAM_NAMES.index(name) for name in PARAM_NAMES}


@pytest.mark.parametrize("threshold", [2.0, 5.0])
def test_attraction_is_quadratic_within_the_threshold(threshold: float) -> None:
    # at (2, 0, 0) toward the origin: e = g − p = (−2, 0, 0), F = k e = (−6, 0, 0)
    assert attraction(-2.0, 0.0, 0.0, 3.0, threshold) == (-6.0, 0.0, 0.0)


def test_attraction_is_conical_beyond_the_threshold_and_continuous_at_it() -> None:
    far = np.array(attraction(-4.0, 3.0, 0.0, 3.0, 2.0))
    np.testing.assert_allclose(far, 3.0 * 2.0 * np.array([-0.8, 0.6, 0.0]), rtol=1e-15)
    inside = np.array(attraction(-2.0 + 1e-12, 0.0, 0.0, 3.0, 2.0))
    outside = np.array(attraction(-2.0 - 1e-12, 0.0, 0.0, 3.0, 2.0))
    np.testing.assert_allclose(inside, outside, atol=1e-10)


@settings(max_examples=100, deadline=None)
@given(vectors)
def test_attraction_magnitude_never_exceeds_gain_times_threshold(error: tuple[float, float, float]) -> None:
    force = np.array(attraction(*error, 3.0, 0.5))
    assert np.linalg.norm(force) <= 3.0 * 0.5 * (1 + 1e-12)
    assert np.dot(force, error) >= 0.0


def test_khatib_magnitude_matches_the_formula_and_is_capped_smoothly() -> None:
    eta, q, cap = 0.3, 0.1, 1e9
    for d in (0.02, 0.05, 0.09):
        assert math.isclose(khatib_magnitude(d, eta, q, cap), eta * (1 / d - 1 / q) / d**2, rel_tol=1e-9)
    assert khatib_magnitude(0.1, eta, q, 10.0) == 0.0
    assert khatib_magnitude(0.5, eta, q, 10.0) == 0.0
    assert khatib_magnitude(0.0, eta, q, 10.0) == 10.0
    assert khatib_magnitude(-0.3, eta, q, 10.0) == 10.0
    assert math.isclose(khatib_magnitude(1e-4, eta, q, 10.0), 10.0, rel_tol=1e-12)
    samples = [khatib_magnitude(d, eta, q, 10.0) for d in np.linspace(1e-4, 0.1, 400)]
    assert all(earlier >= later for earlier, later in itertools.pairwise(samples))
    assert max(samples) <= 10.0


@settings(max_examples=100, deadline=None)
@given(vectors, st.floats(0.01, 5.0))
def test_soft_saturation_keeps_direction_and_bounds_the_norm(v: tuple[float, float, float], limit: float) -> None:
    out = np.array(soft_saturate(*v, limit))
    assert np.linalg.norm(out) <= limit * (1 + 1e-12)
    if np.linalg.norm(v) > 1e-9:
        np.testing.assert_allclose(np.cross(out, v), 0.0, atol=1e-9)
        assert np.dot(out, v) > 0.0


def test_soft_saturation_is_near_identity_for_small_inputs() -> None:
    np.testing.assert_allclose(soft_saturate(1e-4, 0.0, 0.0, 1.0), (1e-4, 0.0, 0.0), rtol=1e-8)


@settings(max_examples=100, deadline=None)
@given(vectors, vectors, st.floats(0.0, 1.0))
def test_rate_limit_moves_at_most_max_change(
    v: tuple[float, float, float], previous: tuple[float, float, float], change: float
) -> None:
    out = np.array(rate_limit(*v, *previous, change))
    assert np.linalg.norm(out - previous) <= change * (1 + 1e-12) + 1e-15
    if np.linalg.norm(np.subtract(v, previous)) <= change:
        np.testing.assert_array_equal(out, v)


def test_damper_speed_is_linear_then_braking_limited_and_negative_inside_the_margin() -> None:
    q, ds, xi = 0.1, 0.01, 0.05
    assert math.isclose(damper_speed(0.1, q, ds, xi, 0.05, 1.0), xi)
    assert math.isclose(damper_speed(0.055, q, ds, xi, 0.05, 1.0), xi * 0.5)
    assert damper_speed(ds, q, ds, xi, 0.05, 1.0) == 0.0
    assert damper_speed(0.0, q, ds, xi, 0.05, 1.0) < 0.0
    assert damper_speed(-5.0, q, ds, xi, 0.05, 1.0) == -0.05
    # a weak brake (a = 0.001 m/s²) caps the speed at √(a (d − d_s))
    assert math.isclose(damper_speed(0.06, q, ds, xi, 0.05, 0.001), math.sqrt(0.001 * 0.05))


def test_deflect_leaves_allowed_motion_alone() -> None:
    assert deflect(0.01, 0.02, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.05, 1.0) == (0.01, 0.02, 0.0, False)


def test_deflect_turns_a_head_on_approach_around_the_obstacle() -> None:
    # moving along −x into an obstacle whose outward normal at the point is +x; circulation axis +y
    vx, vy, vz, active = deflect(-0.05, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.01, 1.0)
    assert active
    assert math.isclose(vx, -0.01)  # the normal part is exactly the allowed approach
    assert math.isclose(math.hypot(vx, vy, vz), 0.05)  # the speed is kept
    assert vz > 0.0 and vy == 0.0  # tangential motion along n × c = x̂ × ŷ = +ẑ


@settings(max_examples=100, deadline=None)
@given(vectors, st.floats(-0.05, 0.1))
def test_deflect_enforces_the_damper_and_keeps_the_speed(v: tuple[float, float, float], allowed: float) -> None:
    normal = np.array([0.0, 0.6, 0.8])
    out = np.array(deflect(*v, *normal, 1.0, 0.0, 0.0, allowed, 1.0)[:3])
    assert -np.dot(out, normal) <= allowed + 1e-9
    assert np.linalg.norm(out) <= max(np.linalg.norm(v), abs(allowed)) * (1 + 1e-9) + 1e-12


def test_deflect_is_continuous_where_the_damper_starts_to_act() -> None:
    v = (-0.03, 0.02, 0.0)
    normal = (1.0, 0.0, 0.0)
    just_active = deflect(*v, *normal, 0.0, 0.0, 1.0, 0.03 - 1e-9, 1.0)[:3]
    np.testing.assert_allclose(just_active, v, atol=1e-6)


@settings(max_examples=150, deadline=None)
@given(vectors, vectors, st.floats(0.001, 0.5), vectors)
def test_braking_rate_limit_obeys_both_limits_and_brakes_first(
    v: tuple[float, float, float], previous: tuple[float, float, float], change: float,
    direction: tuple[float, float, float],
) -> None:
    limit = 2.0
    prior = np.array(previous)
    prior *= min(1.0, limit / max(np.linalg.norm(prior), 1e-12))
    desired = np.array(v)
    desired *= min(1.0, limit / max(np.linalg.norm(desired), 1e-12))
    n = np.array(direction)
    n = n / np.linalg.norm(n) if np.linalg.norm(n) > 1e-6 else np.zeros(3)
    out = np.array(braking_rate_limit(*desired, *prior, change, *n, limit))
    assert np.linalg.norm(out - prior) <= change * (1 + 1e-9) + 1e-12
    assert np.linalg.norm(out) <= limit * (1 + 1e-12)
    along = float(np.dot(desired - prior, n))
    if along > 0.0 and np.linalg.norm(out) < limit * (1 - 1e-9):  # braking is served first
        assert np.dot(out - prior, n) >= min(along, change) * (1 - 1e-9) - 1e-12


def test_braking_rate_limit_without_a_direction_is_the_plain_rate_limit() -> None:
    args = (0.3, -0.2, 0.1, 0.0, 0.1, 0.0, 0.05)
    np.testing.assert_allclose(braking_rate_limit(*args, 0.0, 0.0, 0.0, 1.0), rate_limit(*args), atol=1e-15)


@settings(max_examples=100, deadline=None)
@given(vectors, st.floats(-0.05, 0.1))
def test_project_damper_is_the_half_space_projection(v: tuple[float, float, float], allowed: float) -> None:
    normal = np.array([0.6, 0.0, -0.8])
    out = np.array(project_damper(*v, *normal, allowed)[:3])
    assert -np.dot(out, normal) <= allowed + 1e-9
    if -np.dot(v, normal) <= allowed:
        np.testing.assert_array_equal(out, v)
    else:
        np.testing.assert_allclose(np.cross(out - np.array(v), normal), 0.0, atol=1e-12)


# ---- the numba kernels' values -------------------------------------------------------------------------------

LAWS = (("attraction", 5), ("khatib_magnitude", 4), ("soft_saturate", 4), ("damper_speed", 6),
        ("stepped_damper_speed", 5), ("deflect", 11), ("project_damper", 7))
"""Each law of :mod:`pfield.field.forces` and its number of arguments."""


def _arguments(rng: np.random.Generator, count: int, arity: int) -> np.ndarray:
    """(count, arity) arguments over twelve decades, a fifth of them exact values (zeros, ties, the 1e-12 cut)."""
    values = rng.normal(size=(count, arity)) * 10.0 ** rng.integers(-6, 2, (count, arity))
    special = rng.random((count, arity)) < 0.2
    values[special] = rng.choice([0.0, -0.0, 1.0, -1.0, 0.5, 1e-12, 1e-13, 2.0, 0.1, 0.01], int(special.sum()))
    return values


def _outputs() -> Iterator[tuple[float, ...]]:
    """Every law on 3000 seeded argument rows each (the last argument positive where it divides: a limit, a cap
    or dt); rows where numba divided by zero (it raised ZeroDivisionError, the core gives inf or NaN) left out."""
    from pfield.field import forces

    rng = np.random.default_rng(32)
    for name, arity in LAWS:
        law = getattr(forces, name)
        rows = _arguments(rng, 3000, arity)
        if name in ("khatib_magnitude", "soft_saturate", "stepped_damper_speed"):
            rows[:, -1] = np.abs(rows[:, -1]) + 1e-3
        for row in rows.tolist():
            if _divides_by_zero(name, row):
                continue
            out = law(*row)
            yield tuple(float(v) for v in out) if isinstance(out, tuple) else (float(out),)


def _divides_by_zero(name: str, row: list[float]) -> bool:
    if name == "attraction":
        return math.sqrt(row[0] ** 2 + row[1] ** 2 + row[2] ** 2) == 0.0 and row[4] < 0.0
    if name in ("damper_speed", "stepped_damper_speed"):
        return row[1] == row[2]
    return False


def _digest(outputs: Iterator[tuple[float, ...]]) -> str:
    digest = hashlib.sha256()
    for out in outputs:
        digest.update(np.array(out, dtype=np.float64).tobytes())
    return digest.hexdigest()


NUMBA_DIGEST = "e9faae5dadf98f984c17a88da9a7aa2958168afa4e6967dd539d3b6118d4ac7b"
"""``_digest(_outputs())`` when each output equalled, bit for bit, the numba kernel's of the same law on the same
arguments (issue 32, before numba was removed)."""


def test_the_laws_give_the_numba_kernels_bits() -> None:
    assert _digest(_outputs()) == NUMBA_DIGEST
