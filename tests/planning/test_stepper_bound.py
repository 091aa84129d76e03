"""WholeBodyStepper's compiled entry (inputs checked in the compiled core) against its validating path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfield import FieldConfig, Obstacle, Pose, PotentialField, Sphere, errors
from pfield.planning import WholeBodyStepper
from pfield.robot import RobotModel

Q0 = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])


@pytest.fixture(scope="module")
def stepper() -> WholeBodyStepper:
    robot = RobotModel.builtin("xarm7")
    tip = robot.forward_kinematics(Q0).position
    obstacles = [Obstacle("near", Sphere(0.03), Pose(tip + np.array([0.0, 0.08, 0.0]))),
                 Obstacle("far", Sphere(0.05), Pose((0.2, -0.4, 0.3)))]
    field = PotentialField(FieldConfig(), Pose((0.5, 0.2, 0.3), (1.0, 0.0, 0.0, 0.0)), obstacles)
    return WholeBodyStepper(field, robot)


def _validated(stepper: WholeBodyStepper, q: object, previous: object, dt: float) -> np.ndarray:
    return stepper.evaluate(stepper.robot.check_joint_angles(q, "joint_angles"), previous, dt)  # type: ignore[arg-type]


@pytest.mark.parametrize("dt", [0.0, 0.01, 0.02, 0.01])
def test_rows_equal_the_validating_path(stepper: WholeBodyStepper, dt: float) -> None:
    rng = np.random.default_rng(11)
    for _ in range(10):
        q = Q0 + rng.normal(scale=0.2, size=7)
        previous = rng.normal(scale=0.3, size=7)
        for prev in (None, previous):
            assert np.array_equal(stepper.row(q, prev, dt), _validated(stepper, q, prev, dt))


def test_other_argument_types_take_the_validating_path(stepper: WholeBodyStepper) -> None:
    expected = _validated(stepper, Q0, None, 0.0)
    for q in (Q0.tolist(), tuple(Q0), Q0.reshape(1, 7)[0], np.tile(Q0, 2)[::2] * 0 + Q0):
        assert np.array_equal(stepper.row(q), expected)
    single = Q0.astype(np.float32)  # another dtype: converted as check_joint_angles converts it
    assert np.array_equal(stepper.row(single), _validated(stepper, single, None, 0.0))
    strided = np.repeat(Q0, 2)[::2]  # a non-contiguous view
    assert np.array_equal(stepper.row(strided), expected)
    assert np.array_equal(stepper.row(Q0, [], 0.01), _validated(stepper, Q0, None, 0.01))
    assert np.array_equal(stepper.row(Q0, [0.1] * 7, 0.01), _validated(stepper, Q0, np.full(7, 0.1), 0.01))


def _read_only(values: np.ndarray) -> np.ndarray:
    frozen = values.copy()
    frozen.setflags(write=False)  # as an array over a message's buffer arrives
    return frozen


def test_every_argument_type_gives_the_same_row(stepper: WholeBodyStepper) -> None:
    """A read-only float64 array goes straight into the compiled step, a strided or rank-2 one through the
    validating path: the same row either way."""
    expected = _validated(stepper, Q0, np.full(7, 0.1), 0.01)
    previous = np.full(7, 0.1)
    for q, prev in ((Q0, previous), (_read_only(Q0), previous), (Q0, _read_only(previous)),
                    (np.repeat(Q0, 2)[::2], previous), (Q0, np.repeat(previous, 2)[::2])):
        assert np.array_equal(stepper.row(q, prev, 0.01), expected)
    assert np.array_equal(stepper.row(Q0[None, :]), _validated(stepper, Q0, None, 0.0))


def test_within_the_tolerance_beyond_a_limit_is_clamped(stepper: WholeBodyStepper) -> None:
    q = Q0.copy()
    q[1] = stepper.robot.lower_limits[1] - 5e-5
    assert np.array_equal(stepper.row(q), _validated(stepper, q, None, 0.0))


@pytest.mark.parametrize(("q", "previous", "dt", "field"), [
    (np.r_[Q0[:6], math.nan], None, 0.0, "joint_angles"),
    (np.r_[10.0, Q0[1:]], None, 0.0, "joint_angles[0]"),
    (Q0[:6].copy(), None, 0.0, "joint_angles"),
    (Q0, np.r_[np.zeros(6), math.inf], 0.01, "prev_joint_velocities"),
    (Q0, np.zeros(5), 0.01, "prev_joint_velocities"),
    (Q0, None, -0.01, "delta_time"),
    (Q0, None, math.nan, "delta_time"),
])
def test_bad_input_raises_as_before(stepper: WholeBodyStepper, q: np.ndarray, previous: np.ndarray | None, dt: float,
                                    field: str) -> None:
    before = stepper.row(Q0).copy()
    with pytest.raises(errors.InvalidInput) as info:
        stepper.row(q, previous, dt)
    assert info.value.field == field
    assert np.array_equal(stepper.row(Q0), before)  # nothing changed
