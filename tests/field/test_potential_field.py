"""PotentialField: wrench and twist values, gradients, limits, batches, immutability and bad input."""

from __future__ import annotations

import copy
import logging
import math
import pickle
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfield.errors import InvalidInput
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Obstacle, Sphere
from pfield.planning.scenes import BENCH_GOAL, DEFAULT_PARAMS, evaluation_query, evaluation_scene
from pfield.spatial import Pose, Twist, Wrench, quaternion_exp

BALL = Obstacle("ball", Sphere(radius=0.1), Pose((0.5, 0.0, 0.0)))


def test_attraction_with_gain_3_at_two_metres_is_minus_six() -> None:
    field = PotentialField(FieldConfig(attractive_gain=3.0, attractive_threshold=2.0), Pose())
    wrench = field.wrench(Pose((2.0, 0.0, 0.0)))
    np.testing.assert_array_equal(wrench.force, (-6.0, 0.0, 0.0))
    np.testing.assert_array_equal(wrench.torque, (0.0, 0.0, 0.0))


def test_repulsion_adds_the_khatib_force_along_the_normal() -> None:
    config = FieldConfig(repulsive_gain=0.3, influence_distance=0.1, max_repulsive_force=1e12)
    field = PotentialField(config, Pose(), [BALL])
    d = 0.05  # the query is 5 cm in front of the ball, on its −x side
    force = field.wrench(Pose((0.4 - d, 0.0, 0.0))).force
    khatib = 0.3 * (1 / d - 1 / 0.1) / d**2
    np.testing.assert_allclose(force, (-3.0 * 0.35 - khatib, 0.0, 0.0), rtol=1e-12)


def test_repulsion_is_bounded_inside_and_at_the_surface() -> None:
    config = FieldConfig(attractive_gain=1e-9, max_repulsive_force=7.0)
    field = PotentialField(config, Pose(), [BALL])
    for x in (0.4, 0.45, 0.5 - 1e-9):
        force = field.wrench(Pose((x, 0.0, 0.0))).force
        assert np.all(np.isfinite(force))
        assert np.linalg.norm(force) == pytest.approx(7.0, rel=1e-6)


def _potential(config: FieldConfig, point: np.ndarray) -> float:
    """U_att (quadratic/conical) + Khatib's U_rep = ½ η (1/d − 1/Q)² for the ball at (0.5, 0, 0)."""
    distance = float(np.linalg.norm(point))
    gamma, k = config.attractive_threshold, config.attractive_gain
    attractive = 0.5 * k * distance**2 if distance <= gamma else k * gamma * distance - 0.5 * k * gamma**2
    d = float(np.linalg.norm(point - (0.5, 0.0, 0.0))) - 0.1
    q = config.influence_distance
    repulsive = 0.5 * config.repulsive_gain * (1 / d - 1 / q) ** 2 if d < q else 0.0
    return attractive + repulsive


@pytest.mark.parametrize("point", [(0.33, 0.05, -0.02), (0.6, 0.15, 0.03), (1.7, 0.4, 0.2)])
def test_force_is_the_negative_gradient_of_the_potential(point: tuple[float, float, float]) -> None:
    config = FieldConfig(attractive_threshold=1.2, influence_distance=0.2, max_repulsive_force=1e9)
    field = PotentialField(config, Pose(), [BALL])
    p, h = np.array(point), 1e-6
    gradient = [(_potential(config, p + h * e) - _potential(config, p - h * e)) / (2 * h) for e in np.eye(3)]
    np.testing.assert_allclose(field.wrench(Pose(p)).force, -np.array(gradient), rtol=1e-5, atol=1e-7)


def test_torque_is_the_gain_times_the_world_frame_rotation_error() -> None:
    field = PotentialField(FieldConfig(rotational_attractive_gain=0.5), Pose())
    pose = Pose(orientation=quaternion_exp((0.0, 0.0, 0.3)))
    np.testing.assert_allclose(field.wrench(pose).torque, (0.0, 0.0, -0.15), atol=1e-15)


def test_free_space_twist_is_the_soft_saturated_attraction() -> None:
    config = FieldConfig()
    field = PotentialField(config, Pose((0.1, 0.0, 0.0)), [BALL])
    twist = field.twist(Pose(orientation=quaternion_exp((0.0, 0.0, 1.0))))
    np.testing.assert_allclose(twist.linear, (0.05 * math.tanh(0.3 / 0.05), 0.0, 0.0), rtol=1e-12)
    np.testing.assert_allclose(twist.angular, (0.0, 0.0, -0.4 * math.tanh(0.15 / 0.4)), rtol=1e-12)


def test_reference_outputs_of_the_empty_scene() -> None:
    """REFERENCE §4, empty scene: the C++ original's force and limited velocity are reproduced."""
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("empty"))
    query = evaluation_query()
    np.testing.assert_allclose(field.wrench(query).force, (0.3, 0.3, -0.2), atol=1e-15)
    np.testing.assert_allclose(
        field.twist(query).linear, (0.29912308660584902, 0.29912308660584902, -0.19941539107056605), rtol=1e-12
    )
    # our torque is k·log (0.7·0.3 = 0.21); the original's 2·vec(q_err) law gives 0.20921338546303894
    np.testing.assert_allclose(field.wrench(query).torque, (0.0, 0.0, -0.21), atol=1e-12)


def test_twist_slows_the_approach_toward_a_near_obstacle() -> None:
    config = FieldConfig()
    field = PotentialField(config, Pose((0.8, 0.0, 0.0)), [BALL])
    twist = field.twist(Pose((0.38, 0.0, 0.0)))  # 2 cm in front, heading straight into the ball
    allowed = config.damper_gain * config.max_linear_velocity * (0.02 - 0.01) / (0.1 - 0.01)
    assert twist.linear[0] == pytest.approx(allowed, rel=1e-9)
    assert np.linalg.norm(twist.linear) == pytest.approx(0.05 * math.tanh(0.42 * 3 / 0.05), rel=1e-9)


poses = st.tuples(st.floats(-0.3, 1.0), st.floats(-0.5, 0.5), st.floats(-0.5, 0.5),
                  st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1), st.floats(0.1, 1)))
velocity = st.floats(-0.5, 0.5)


@settings(max_examples=150, deadline=None)
@given(poses, st.tuples(*[velocity] * 6), st.floats(0.001, 0.1))
def test_limited_twist_obeys_velocity_and_rate_limits(
    pose: tuple[float, float, float, tuple[float, ...]], previous: tuple[float, ...], dt: float
) -> None:
    config = FieldConfig()
    field = PotentialField(config, Pose((0.8, 0.1, 0.0)), [BALL, Obstacle("box", Box(0.1, 0.2, 0.3), Pose((0.2,)*3))])
    prior = np.array(previous)
    prior[:3] *= min(1.0, 0.05 / max(np.linalg.norm(prior[:3]), 1e-12))  # a previous twist within the limits
    prior[3:] *= min(1.0, 0.4 / max(np.linalg.norm(prior[3:]), 1e-12))
    twist = field.twist(Pose(pose[:3], pose[3]), Twist(prior[:3], prior[3:]), dt)
    assert np.linalg.norm(twist.linear) <= 0.05 + 1e-12
    assert np.linalg.norm(twist.angular) <= 0.4 + 1e-12
    assert np.linalg.norm(twist.linear - prior[:3]) <= 1.0 * dt * (1 + 1e-9)
    assert np.linalg.norm(twist.angular - prior[3:]) <= 0.2 * dt * (1 + 1e-9)


@settings(max_examples=100, deadline=None)
@given(poses)
def test_twist_without_previous_obeys_the_velocity_limits(pose: tuple[float, float, float, tuple[float, ...]]) -> None:
    walls = [Obstacle("a", Box(0.1, 0.4, 0.4), Pose((0.3, 0.0, 0.0))),
             Obstacle("b", Sphere(0.1), Pose((0.45, 0.1, 0.0)))]
    field = PotentialField(FieldConfig(), Pose((0.8, 0.1, 0.0), (0.0, 1.0, 0.0, 0.0)), walls)
    twist = field.twist(Pose(pose[:3], pose[3]))
    assert np.linalg.norm(twist.linear) <= 0.05 * (1 + 1e-12)
    assert np.linalg.norm(twist.angular) <= 0.4 * (1 + 1e-12)


def test_batches_equal_single_evaluations() -> None:
    field = PotentialField(FieldConfig(), Pose((0.8, 0.0, 0.1)), [BALL])
    rng = np.random.default_rng(3)
    positions = rng.uniform(-0.2, 0.9, (50, 3))
    orientations = quaternion_exp(rng.normal(size=(50, 3)))
    wrenches, twists = field.wrenches(positions, orientations), field.twists(positions, orientations)
    for i in (0, 17, 49):
        pose = Pose(positions[i], orientations[i])
        np.testing.assert_allclose(wrenches[i], field.wrench(pose).as_array(), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(twists[i], field.twist(pose).as_array(), rtol=1e-12, atol=1e-15)
    default_orientation = field.twists(positions[:3])
    np.testing.assert_allclose(default_orientation[:, 3:], 0.0, atol=1e-15)
    np.testing.assert_allclose(field.clearances(positions[:2]), [BALL.signed_distance(p)[0][0] for p in positions[:2]])


def test_fields_are_immutable_values() -> None:
    field = PotentialField(FieldConfig(), Pose((0.8, 0.0, 0.0)), [BALL])
    moved = field.with_goal(Pose((0.0, 0.8, 0.0)))
    assert field.goal.position[0] == 0.8 and moved.goal.position[1] == 0.8
    assert moved.obstacles == field.obstacles
    assert field.with_obstacles([]).obstacles == () and len(field.obstacles) == 1
    assert field.with_config(FieldConfig(attractive_gain=1.0)).config.attractive_gain == 1.0
    with pytest.raises(ValueError):
        field.arrays.params[0] = 5.0


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: PotentialField({"attractive_gain": 1.0}, Pose()), "config"),  # type: ignore[arg-type]
        (lambda: PotentialField(FieldConfig(), (0, 0, 0)), "goal"),  # type: ignore[arg-type]
        (lambda: PotentialField(FieldConfig(), Pose(), ["ball"]), "obstacles[0]"),  # type: ignore[list-item]
        (lambda: PotentialField(FieldConfig(), Pose(), [BALL, BALL]), "obstacles[1].id"),
        (lambda: _field().wrench((0, 0, 0)), "pose"),  # type: ignore[arg-type]
        (lambda: _field().twist(None), "pose"),  # type: ignore[arg-type]
        (lambda: _field().twist(Pose(), previous=(0, 0, 0), dt=0.1), "previous"),  # type: ignore[arg-type]
        (lambda: _field().twist(Pose(), previous=Twist(), dt=0.0), "dt"),
        (lambda: _field().twist(Pose(), previous=Twist(), dt=math.nan), "dt"),
        (lambda: _field().twists(np.zeros((4, 2))), "positions"),
        (lambda: _field().twists([[0.0, 0.0, math.inf]]), "positions[0]"),
        (lambda: _field().wrenches(np.zeros((2, 3)), np.zeros((2, 4))), "orientations[0]"),
        (lambda: _field().twists(np.zeros((2, 3)), [[0, 0, 0, 1], [0, math.nan, 0, 1]]), "orientations[1]"),
        (lambda: _field().twists(np.zeros((2, 3)), "up"), "orientations"),
        (lambda: _field().wrenches(np.zeros((2, 3)), np.ones((3, 4))), "orientations"),
        (lambda: _field().with_goal("goal"), "goal"),  # type: ignore[arg-type]
        (lambda: _field().with_config(None), "config"),  # type: ignore[arg-type]
    ],
)
def test_bad_input_names_the_field(call: object, name: str) -> None:
    with pytest.raises(InvalidInput) as info:
        call()  # type: ignore[operator]
    assert info.value.field == name


def _field() -> PotentialField:
    return PotentialField(FieldConfig(), Pose(), [BALL])


@pytest.mark.parametrize(
    ("scene", "force"),
    [
        ("spheres_1", (-0.88389438129371345, -0.094631460431237879, 0.063087640287491809)),
        ("spheres_10", (2.8435829051116315, -16.071421877387614, 21.963651813674296)),
        ("boxes_10", (4.5363966231698543, -26.75504048792666, 26.599118491501791)),
        ("capsules_10", (12.372789628801518, -17.629969459961547, 23.521843243550027)),
    ],
)
def test_uncapped_khatib_sum_reproduces_the_reference_forces(scene: str, force: tuple[float, float, float]) -> None:
    """REFERENCE §4: with the repulsion cap lifted, the wrench equals the C++ original's."""
    config = DEFAULT_PARAMS.replace(max_repulsive_force=1e12)
    field = PotentialField(config, BENCH_GOAL, evaluation_scene(scene))
    np.testing.assert_allclose(field.wrench(evaluation_query()).force, force, rtol=1e-9)


def test_a_goal_near_a_wall_stays_an_equilibrium_of_the_twist_but_not_of_the_wrench() -> None:
    """Why the twist uses dampers instead of Khatib repulsion: 8 cm from a face, Khatib pushes off the goal."""
    wall = Obstacle("wall", Box(0.1, 0.6, 0.6), Pose((0.5, 0.0, 0.3)))
    goal = Pose((0.37, 0.0, 0.3))
    field = PotentialField(FieldConfig(influence_distance=0.1), goal, [wall])
    khatib = 0.3 * (1 / 0.08 - 1 / 0.1) / 0.08**2  # 117 N, bent toward the 10 N cap
    np.testing.assert_allclose(field.wrench(goal).force, (-khatib / math.sqrt(1 + (khatib / 10) ** 2), 0, 0))
    np.testing.assert_array_equal(field.twist(goal).linear, (0.0, 0.0, 0.0))


@pytest.mark.parametrize("scene", ["spheres_10", "boxes_10", "capsules_10", "ellipsoids_10"])
def test_twist_is_the_cores_one_pose_answer_to_the_bit(scene: str) -> None:
    """``twist`` (its fast path: the Pose's and Twist's arrays read as they are, dt a plain float) gives the core's
    binding's bits with and without a previous twist, for dt of every number type; each answer owns read-only arrays."""
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene(scene))
    rng = np.random.default_rng(5)
    for _ in range(20):
        pose = Pose(rng.uniform((0.0, -0.3, 0.0), (1.0, 0.7, 1.0)), quaternion_exp(rng.normal(size=3)))
        previous = Twist(rng.normal(scale=0.2, size=3), rng.normal(scale=0.2, size=3))
        plain = np.concatenate(field.compiled.twist(pose.position, pose.orientation)[:2])
        assert np.array_equal(field.twist(pose).as_array().view(np.int64), plain.view(np.int64))
        limited = np.concatenate(field.compiled.twist(pose.position, pose.orientation, previous.linear,
                                                      previous.angular, 0.01)[:2])
        for dt in (0.01, np.float64(0.01)):
            answer = field.twist(pose, previous, dt)
            assert np.array_equal(answer.as_array().view(np.int64), limited.view(np.int64))
            assert not answer.linear.flags.writeable and not answer.angular.flags.writeable
    first, second = field.twist(Pose()), field.twist(Pose())
    assert first.linear is not second.linear and first == second
    assert field.twist(Pose(), Twist(), 1) == field.twist(Pose(), Twist(), 1.0)  # an int dt is a number


@dataclass(frozen=True, eq=False, init=False)
class _NamedPose(Pose):
    """A user's subclass of Pose: not the class the core reads (the Python layer checks and answers it)."""

    name: str = "tool"


def test_a_subclass_of_a_value_type_gets_the_same_answers() -> None:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("spheres_10"))
    query = evaluation_query()
    named = _NamedPose(query.position, query.orientation)
    previous = Twist((0.1, 0.0, 0.0), (0.0, 0.0, 0.1))
    assert field.compiled.twist_value(named, previous, 0.01) is None  # not the registered class
    assert field.twist(named, previous, 0.01) == field.twist(query, previous, 0.01)
    assert field.wrench(named) == field.wrench(query)
    assert field.compiled.wrench_value(named) is None


def test_the_cores_answers_are_value_types_like_any_other() -> None:
    """A Twist or a Wrench the core made (python/values.hpp) is one as pfield.spatial builds it: read-only arrays
    of its own, equal to the one built from the same numbers, pickled and copied the same way."""
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("boxes_10"))
    twist, wrench = field.twist(evaluation_query()), field.wrench(evaluation_query())
    assert type(twist) is Twist and type(wrench) is Wrench
    for value, built in ((twist, Twist(twist.linear, twist.angular)), (wrench, Wrench(wrench.force, wrench.torque))):
        assert value == built and hash(value) == hash(built)
        assert pickle.loads(pickle.dumps(value)) == value and copy.deepcopy(value) == value
        for array in (getattr(value, name) for name in value.__slots__):
            assert array.dtype == np.float64 and array.shape == (3,) and not array.flags.writeable
            assert array.base is None  # its own buffer
    with pytest.raises(AttributeError):
        twist.linear = np.zeros(3)  # type: ignore[misc]


def test_a_halted_twist_is_zero_and_reported(caplog: pytest.LogCaptureFixture) -> None:
    """An answer the output contract halts (a gain so large the field's twist is not finite) goes through the
    Python layer, which logs it: zeros, and a warning naming the pose."""
    config = DEFAULT_PARAMS.replace(attractive_gain=1e308, attractive_threshold=1e308)
    field = PotentialField(config, Pose((1e308, 0.0, 0.0)), [])
    with caplog.at_level(logging.WARNING, logger="pfield"):
        answer = field.twist(Pose((-1e308, 0.0, 0.0)))
    assert not answer.as_array().any()
    assert "was not finite: answered zero" in caplog.text


def test_the_rk4_figure_is_the_plans_first_step() -> None:
    """``rk4_steps`` (bench_field's RK4 row) from the start with a zero previous twist takes the plan's first step:
    one step's mean v_x is the plan's first twist's, to the bit, and n steps from one pose sum n equal ones."""
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("boxes_10"))
    query = evaluation_query()
    start = np.concatenate([query.position, query.orientation])
    poses, twists, clearances = np.empty((2, 7)), np.empty((2, 6)), np.empty(2)
    field.compiled.plan(start, 0.01, 0.0, 0.0, 1, 2, 0.0, np.zeros(1, np.uint8), poses, twists, clearances)
    assert field.compiled.rk4_steps(start, np.zeros(6), 0.01, 1) == twists[0, 0]
    # stage 0 of a later step moves along the previous step's first stage by h = 0: the same twists again
    assert field.compiled.rk4_steps(start, np.zeros(6), 0.01, 3) == twists[0, 0] + twists[0, 0] + twists[0, 0]
