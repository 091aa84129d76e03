"""The scalar SO(3) kernels of pfield._spatial_kernels against the group axioms, and the compiled core's batches
(pfield._core.spatial, under pfield.spatial) against them to the last bit."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pfield._core import spatial as core
from pfield._spatial_kernels import (
    _SMALL_ANGLE,
    hamilton,
    left_increment,
    matrix_to_quat,
    rotation_error,
    so3_exp,
    so3_log,
)

angles = st.floats(-3.0, 3.0, allow_nan=False)
rotvecs = st.tuples(angles, angles, angles).filter(lambda v: math.hypot(*v) < math.pi - 1e-3)


@settings(max_examples=200, deadline=None)
@given(rotvecs)
def test_log_of_exp_is_the_identity_and_the_array_forms_agree(v: tuple[float, float, float]) -> None:
    q = so3_exp(*v)
    np.testing.assert_allclose(so3_log(*q), v, atol=1e-12)
    np.testing.assert_array_equal(core.exp(np.array([v]))[0], q)
    np.testing.assert_array_equal(core.log(np.array([q]))[0], so3_log(*q))
    assert math.isclose(sum(c * c for c in q), 1.0, rel_tol=1e-12)


@settings(max_examples=100, deadline=None)
@given(rotvecs, rotvecs)
def test_composition_inverse_and_the_world_frame_error(a: tuple[float, float, float],
                                                        b: tuple[float, float, float]) -> None:
    qa, qb = so3_exp(*a), so3_exp(*b)
    np.testing.assert_array_equal(core.multiply(np.array([qa]), np.array([qb]))[0], hamilton(*qa, *qb))
    matrix = core.to_matrix(np.array([qa]))
    np.testing.assert_array_equal(core.from_matrix(matrix)[0], matrix_to_quat(matrix[0]))
    inverse = (-qa[0], -qa[1], -qa[2], qa[3])
    np.testing.assert_allclose(hamilton(*qa, *inverse), (0.0, 0.0, 0.0, 1.0), atol=1e-15)
    # rotating q_a on the left by exp(error) reaches q_b: error = log(q_b ⊗ q_a⁻¹)
    error = rotation_error(*qa, *qb)
    reached = left_increment(*qa, *error, 1.0)
    sign = 1.0 if np.dot(reached, qb) >= 0 else -1.0
    np.testing.assert_allclose(np.array(reached) * sign, qb, atol=1e-12)


def test_the_series_branch_meets_the_closed_form_at_the_threshold() -> None:
    for theta in (_SMALL_ANGLE * 0.999, _SMALL_ANGLE * 1.001):
        q = so3_exp(theta, 0.0, 0.0)
        assert math.isclose(q[0], math.sin(0.5 * theta), rel_tol=1e-15)
        assert math.isclose(so3_log(*q)[0], theta, rel_tol=1e-15)
    assert so3_log(0.0, 0.0, 0.0, 1.0) == (0.0, 0.0, 0.0)
    assert so3_log(0.0, 0.0, 0.0, -1.0) == (0.0, 0.0, 0.0)  # −q is q
