"""The compiled core's SO(3) batches (pfield._core.spatial, under pfield.spatial): the group axioms, the series
branch at its threshold, and the numba kernels' exact values.

Until issue 32 removed them, numba's scalar kernels (``so3_exp``, ``so3_log``, the Hamilton product and
Shepperd's ``matrix_to_quat``) computed the same maps for the kernels that inlined them, and the core's batches
were held equal to them bit for bit. :data:`NUMBA_DIGEST` holds the core's outputs on the seeded inputs of
:func:`_outputs`, recorded when exp, log, multiply and from_matrix equalled numba's on every one of them.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from digests import digest
from pfield._core import spatial as core

SMALL_ANGLE = 1e-8
"""Below this angle (rad) exp and log use their Taylor series (``src/core/math/so3.hpp``)."""

angles = st.floats(-3.0, 3.0, allow_nan=False)
rotvecs = st.tuples(angles, angles, angles).filter(lambda v: math.hypot(*v) < math.pi - 1e-3)


def _exp(v: tuple[float, float, float]) -> np.ndarray:
    return core.exp(np.array([v]))[0]  # type: ignore[no-any-return]


@settings(max_examples=200, deadline=None)
@given(rotvecs)
def test_log_of_exp_is_the_identity(v: tuple[float, float, float]) -> None:
    q = _exp(v)
    np.testing.assert_allclose(core.log(q[None, :])[0], v, atol=1e-12)
    assert math.isclose(float(np.sum(q * q)), 1.0, rel_tol=1e-12)
    np.testing.assert_array_equal(core.log(-q[None, :])[0], core.log(q[None, :])[0])  # −q is q


@settings(max_examples=100, deadline=None)
@given(rotvecs, rotvecs)
def test_composition_inverse_matrices_and_the_world_frame_error(a: tuple[float, float, float],
                                                                  b: tuple[float, float, float]) -> None:
    qa, qb = _exp(a), _exp(b)
    inverse = np.array([-qa[0], -qa[1], -qa[2], qa[3]])
    np.testing.assert_allclose(core.multiply(qa[None, :], inverse[None, :])[0], (0.0, 0.0, 0.0, 1.0), atol=1e-15)
    matrix = core.to_matrix(qa[None, :])
    np.testing.assert_allclose(matrix[0] @ matrix[0].T, np.eye(3), atol=1e-14)
    back = core.from_matrix(matrix)[0]
    np.testing.assert_allclose(back * (1.0 if np.dot(back, qa) >= 0 else -1.0), qa, atol=1e-14)
    vector = np.array([[0.3, -0.2, 0.5]])
    np.testing.assert_allclose(core.rotate(qa[None, :], vector)[0], matrix[0] @ vector[0], atol=1e-14)
    # rotating q_a on the left by exp(error) reaches q_b: error = log(q_b ⊗ q_a⁻¹), of angle angle(q_a, q_b) (to
    # √ε ≈ 1.5e-8 rad near 0, where the angle's arc cosine is flat)
    error = core.log(core.multiply(qb[None, :], inverse[None, :]))
    reached = core.multiply(core.exp(error), qa[None, :])[0]
    np.testing.assert_allclose(reached * (1.0 if np.dot(reached, qb) >= 0 else -1.0), qb, atol=1e-12)
    assert math.isclose(float(np.linalg.norm(error)), float(core.angle(qa[None, :], qb[None, :])[0]),
                        rel_tol=1e-9, abs_tol=1e-7)


def test_the_series_branch_meets_the_closed_form_at_the_threshold() -> None:
    for theta in (SMALL_ANGLE * 0.999, SMALL_ANGLE * 1.001):
        q = _exp((theta, 0.0, 0.0))
        assert math.isclose(q[0], math.sin(0.5 * theta), rel_tol=1e-15)
        assert math.isclose(core.log(q[None, :])[0, 0], theta, rel_tol=1e-15)
    assert core.log(np.array([[0.0, 0.0, 0.0, 1.0]])).tolist() == [[0.0, 0.0, 0.0]]
    assert core.log(np.array([[0.0, 0.0, 0.0, -1.0]])).tolist() == [[0.0, 0.0, 0.0]]  # −q is q


def test_a_half_turn_has_angle_pi() -> None:
    half_turn = np.array([[0.0, 0.0, 1.0, 0.0]])
    assert math.isclose(float(np.linalg.norm(core.log(half_turn)[0])), math.pi, rel_tol=1e-12)


# ---- the numba kernels' values -------------------------------------------------------------------------------

def _inputs() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Seeded rotation vectors (zero, around the series threshold, up to beyond π), unit quaternions (both signs
    of w, the identity and its negative), pairs of them, and rotation matrices that take each branch of Shepperd's
    method (positive trace, then the largest diagonal entry first, second, third)."""
    rng = np.random.default_rng(32)
    directions = rng.normal(size=(2000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    lengths = np.concatenate([rng.uniform(0.0, 3.5, 1400), SMALL_ANGLE * rng.uniform(0.5, 1.5, 300),
                              10.0 ** rng.uniform(-16, -3, 290), np.zeros(5), np.full(5, math.pi)])
    rotvecs = directions * lengths[:, None]
    quaternions = rng.normal(size=(2000, 4))
    quaternions /= np.linalg.norm(quaternions, axis=1, keepdims=True)
    quaternions[:4] = [[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, -1.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]]
    others = np.ascontiguousarray(quaternions[::-1])
    half_turns = core.to_matrix(np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0],
                                          [0.6, 0.8, 0.0, 0.0], [0.0, 0.6, 0.8, 0.0]]))
    matrices = np.concatenate([core.to_matrix(quaternions), half_turns])
    return rotvecs, quaternions, others, matrices


def _outputs() -> Iterator[np.ndarray]:
    rotvecs, quaternions, others, matrices = _inputs()
    yield core.exp(rotvecs)
    yield core.log(quaternions)
    yield core.log(core.exp(rotvecs))
    yield core.multiply(quaternions, others)
    yield core.to_matrix(quaternions)
    yield core.from_matrix(matrices)
    yield core.rotate(quaternions, np.ascontiguousarray(rotvecs[:2000]))
    yield core.angle(quaternions, others)



NUMBA_DIGEST = "fb0e1ed8449bc54e403ec61cd5a0589ac4e02101743bc170b4b697613a946965"
"""``digest(_outputs())`` when exp, log, multiply and from_matrix equalled numba's ``so3_exp``, ``so3_log``,
``hamilton`` and ``matrix_to_quat`` on every input, bit for bit (issue 32, before numba was removed)."""


def test_the_batches_give_the_numba_kernels_bits() -> None:
    assert digest(_outputs()) == NUMBA_DIGEST
