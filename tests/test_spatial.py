"""Tests of pfield.spatial: quaternion algebra, exp/log, Euler angles and the value types."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfield.errors import InvalidInput
from pfield.spatial import (
    Pose,
    Twist,
    Wrench,
    euler_zyx_from_quaternion,
    geodesic_angle,
    matrix_from_quaternion,
    pose_from_checked,
    quaternion_exp,
    quaternion_from_euler_zyx,
    quaternion_from_matrix,
    quaternion_inverse,
    quaternion_log,
    quaternion_multiply,
    rotate_vectors,
    twist_from_checked,
    wrench_from_checked,
)

unit = st.floats(-1.0, 1.0, allow_nan=False)


def random_quaternions(n: int, seed: int = 0) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_rotation_about_z_by_quarter_turn() -> None:
    q = quaternion_exp([0.0, 0.0, math.pi / 2])
    np.testing.assert_allclose(rotate_vectors(q, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(q, [0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)], atol=1e-15)


def test_product_matches_matrix_product() -> None:
    a, b = random_quaternions(50, 1), random_quaternions(50, 2)
    lhs = matrix_from_quaternion(quaternion_multiply(a, b))
    rhs = matrix_from_quaternion(a) @ matrix_from_quaternion(b)
    np.testing.assert_allclose(lhs, rhs, atol=1e-12)


def test_inverse_composes_to_identity() -> None:
    q = random_quaternions(20, 3)
    ident = quaternion_multiply(q, quaternion_inverse(q))
    np.testing.assert_allclose(np.abs(ident[:, 3]), 1.0, atol=1e-12)


def test_exp_log_round_trip_including_small_and_half_turn_angles() -> None:
    rng = np.random.default_rng(4)
    axes = rng.normal(size=(40, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate([np.linspace(0.0, math.pi - 1e-9, 30), [1e-12, 1e-9, 1e-7, 1e-5] * 2, [0.0, 0.0]])
    rotvecs = axes * angles[:, None]
    np.testing.assert_allclose(quaternion_log(quaternion_exp(rotvecs)), rotvecs, atol=1e-9)


def test_log_takes_the_short_arc() -> None:
    q = -quaternion_exp([0.0, 0.3, 0.0])  # same rotation, negative hemisphere
    np.testing.assert_allclose(quaternion_log(q), [0.0, 0.3, 0.0], atol=1e-12)


def test_matrix_round_trip_covers_every_shepperd_branch() -> None:
    q = np.vstack([random_quaternions(200, 5), [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]])
    back = quaternion_from_matrix(matrix_from_quaternion(q))
    np.testing.assert_allclose(np.abs(np.sum(back * q, axis=1)), 1.0, atol=1e-12)
    assert np.all(back[:, 3] >= 0.0)


@given(st.floats(-3.1, 3.1), st.floats(-1.5, 1.5), st.floats(-3.1, 3.1))
@settings(max_examples=200, deadline=None)
def test_euler_zyx_round_trip(yaw: float, pitch: float, roll: float) -> None:
    q = quaternion_from_euler_zyx(yaw, pitch, roll)
    np.testing.assert_allclose(euler_zyx_from_quaternion(q), [yaw, pitch, roll], atol=1e-9)


def test_euler_zyx_is_intrinsic_z_then_y_then_x() -> None:
    q = quaternion_from_euler_zyx(0.4, -0.2, 0.7)
    expected = quaternion_multiply(
        quaternion_multiply(quaternion_exp([0, 0, 0.4]), quaternion_exp([0, -0.2, 0])), quaternion_exp([0.7, 0, 0])
    )
    np.testing.assert_allclose(q, expected, atol=1e-15)


@given(st.tuples(unit, unit, unit, unit).filter(lambda t: np.linalg.norm(t) > 0.1))
@settings(max_examples=100, deadline=None)
def test_geodesic_angle_is_log_norm(raw: tuple[float, float, float, float]) -> None:
    q = np.array(raw) / np.linalg.norm(raw)
    ident = np.array([0.0, 0.0, 0.0, 1.0])
    assert geodesic_angle(ident, q) == pytest.approx(np.linalg.norm(quaternion_log(q)), abs=1e-7)
    assert 0.0 <= geodesic_angle(q, ident) <= math.pi + 1e-12


def test_pose_normalises_orientation_and_defaults_to_identity() -> None:
    pose = Pose(position=(0.4, 0, 0.1), orientation=(0, 0, 2.0, 0))
    np.testing.assert_array_equal(pose.orientation, [0, 0, 1, 0])
    np.testing.assert_array_equal(Pose().orientation, [0, 0, 0, 1])


def test_pose_composition_inverse_and_point_transform() -> None:
    a = Pose((1.0, 2.0, 3.0), quaternion_from_euler_zyx(0.3, 0.2, 0.1))
    b = Pose((-0.5, 0.1, 0.7), quaternion_from_euler_zyx(-1.0, 0.4, 2.0))
    np.testing.assert_allclose((a * b).matrix(), a.matrix() @ b.matrix(), atol=1e-12)
    assert (a.inverse() * a).isclose(Pose())
    pts = np.random.default_rng(0).normal(size=(10, 3))
    homog = (a.matrix() @ np.c_[pts, np.ones(10)].T).T[:, :3]
    np.testing.assert_allclose(a.transform_points(pts), homog, atol=1e-12)
    assert Pose.from_matrix(a.matrix()).isclose(a)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"orientation": (0, 0, 0, 0)}, "orientation"),
        ({"orientation": (0, 0, float("nan"), 1)}, "orientation"),
        ({"position": (0, float("inf"), 0)}, "position"),
        ({"position": (0, 0)}, "position"),
        ({"position": "abc"}, "position"),
    ],
)
def test_pose_rejects_bad_input_naming_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(InvalidInput) as info:
        Pose(**kwargs)
    assert info.value.field == field
    assert field in str(info.value)


def test_twist_round_trip() -> None:
    t = Twist.from_array([1, 2, 3, 4, 5, 6])
    np.testing.assert_array_equal(t.linear, [1, 2, 3])
    assert Twist.from_array(t.as_array()) == t


class _Unslotted:
    """A class whose fields are plain class attributes: not a value type the core can read."""

    position = orientation = linear = angular = force = torque = None


class _Borrowed:
    """A slotted class whose fields are Pose's member descriptors: their offsets are Pose's, not its own."""

    __slots__ = ()
    position = Pose.position
    orientation = Pose.orientation


def test_the_core_registers_slotted_value_types_only_and_a_refusal_changes_nothing() -> None:
    from pfield._core import spatial as core

    with pytest.raises(TypeError, match="slotted"):
        core.register_value_types(Pose, _Unslotted, Wrench)
    with pytest.raises(TypeError, match="classes"):
        core.register_value_types(Pose, Twist, "Wrench")
    with pytest.raises(TypeError, match="its own class"):  # another class's slots: offsets of another layout
        core.register_value_types(_Borrowed, Twist, Wrench)
    position, orientation = np.array([0.1, 0.2, 0.3]), np.array([0.0, 0.0, 0.0, 1.0])
    for array in (position, orientation):
        array.flags.writeable = False
    pose = pose_from_checked(position, orientation)  # still the registered classes
    assert type(pose) is Pose and pose.position is position and pose.orientation is orientation
    assert type(twist_from_checked(position, position)) is Twist
    assert type(wrench_from_checked(position, position)) is Wrench
