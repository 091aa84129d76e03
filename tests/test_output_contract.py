"""The output contract (:mod:`pfield.safety`): every command pfield returns is finite and within its limits.

Property tests over finite float64 inputs, absurd ones included (±1e308, subnormals, obstacle speeds at the
bound, previous commands far beyond the limits), for each call kind that returns a command: the task-space
autonomy vector (``PotentialField.twist``, ``PreparedTwist``, ``twists``), the whole-body autonomy vector, the
task-space and whole-body assistance, and the mobile base controller's command. Each property runs
:data:`CASES` generated cases (derandomised, the same cases on every run), :data:`BATCH` to a hypothesis example.
Then the rules of :mod:`pfield.safety` one by one, with exact values. An absurd input warns of nothing either: a
numpy ``RuntimeWarning`` (an overflow on the way to a finite answer) fails the test.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, example, given, note, settings
from hypothesis import strategies as st

from pfield import Box, Capsule, FieldConfig, Obstacle, Pose, PotentialField, PreparedTwist, Sphere, Twist, safety
from pfield._core import safety as core_safety
from pfield.errors import InvalidInput
from pfield.mobile import ControllerConfig
from pfield.mobile.controller import BaseController
from pfield.mobile.scan import point_obstacles
from pfield.robot import RobotModel
from pfield.shared_control.assistance import (
    ARBITRATIONS,
    AssistanceScene,
    Flag,
    task_space_assistance,
    whole_body_assistance,
)
from pfield.shared_control.autonomy import whole_body_autonomy, whole_body_autonomy_vector
from property_cases import cases

CASES = cases(10_000)
"""Generated cases per call kind: 10 000 in make test, the count the output contract was accepted with (about
250 s of CPU for the five kinds: one of make test's two workers runs this file while the other runs the rest;
``tests/conftest.py`` starts it first), 100 000 in the nightly run (``HYPOTHESIS_PROFILE=nightly``,
tests/property_cases.py)."""
BATCH = 10
"""Cases checked per hypothesis example. Hypothesis spends about 3 ms of its own on an example (its seeding, its
choice tree, its bookkeeping), far more than a case costs to check (0.02-0.3 ms): drawing the cases ten to an
example checks the same :data:`CASES` cases per kind in half the time. A failing batch shrinks to its simplest
cases, and the failing one is printed (``note``)."""
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

CONTRACT = settings(max_examples=CASES // BATCH, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck), phases=[Phase.explicit, Phase.generate, Phase.shrink])
SLACK = 1.0 + 1e-12  # a scaled norm may exceed its limit by rounding of the last bit

EXTREMES = [1e308, -1e308, 1.7976931348623157e308, -1.7976931348623157e308, 5e-324, -5e-324, 2.2250738585072014e-308,
            1e38, -1e38, 1e6, -1e6, 10.0, -10.0, 0.0, -0.0, 1e-300]
ABSURD = st.one_of(st.sampled_from(EXTREMES), st.floats(allow_nan=False, allow_infinity=False),
                   st.floats(min_value=-2.0, max_value=2.0))
"""Any finite float64, weighted toward the extremes and toward ordinary values."""
TWISTS = st.lists(ABSURD, min_size=6, max_size=6)
SPEED_VALUES = [0.0, 1.0, -1.0, 3.0, -7.0, 5e-324, 1e-300]
OBSTACLE_SPEEDS = st.sampled_from([speed for speed in itertools.product(SPEED_VALUES, repeat=3)
                                   if math.hypot(*speed) <= safety.MAX_OBSTACLE_SPEED])
"""An obstacle's velocity (m/s): three components from the values above, its norm within the bound. Drawn from the
list of every such triple (rather than filtering drawn triples: the same triples, without a rejection per draw)."""
Speed = Sequence[float]
DTS = st.one_of(st.just(0.0), st.sampled_from([5e-324, 1e-300, 0.001, 0.02, 1.0, 1e6, 1e308]),
                st.floats(min_value=0.0, max_value=1.0))

CONFIG = FieldConfig()
GOAL = Pose((0.5, 0.2, 0.4), (0.707, 0.0, 0.707, 0.0))
OBSTACLES = [Obstacle("ball", Sphere(radius=0.1), Pose((0.4, 0.0, 0.1))),
             Obstacle("table", Box(length=0.6, width=0.8, height=0.05), Pose((0.5, 0.0, -0.03))),
             Obstacle("post", Capsule(radius=0.04, height=0.3), Pose((0.3, 0.3, 0.3)), group="Dynamic")]
FIELD = PotentialField(CONFIG, GOAL, OBSTACLES)


def assert_twist_within(values: Any, config: FieldConfig = CONFIG) -> None:
    array = np.asarray(values, dtype=float)
    assert np.isfinite(array).all(), array
    assert safety.twist_scale(array.tolist(), config.max_linear_velocity * SLACK,
                              config.max_angular_velocity * SLACK) == 1.0, array


def assert_joints_within(values: Any, robot: RobotModel) -> None:
    array = np.asarray(values, dtype=float)
    assert np.isfinite(array).all(), array
    assert (np.abs(array) <= robot.velocity_limits * SLACK).all(), (array, robot.velocity_limits)


def poses() -> st.SearchStrategy[Pose]:
    positions = st.one_of(st.lists(ABSURD, min_size=3, max_size=3),
                          st.lists(st.floats(min_value=-1.0, max_value=1.0), min_size=3, max_size=3))
    quaternions = st.lists(st.floats(min_value=-1.0, max_value=1.0), min_size=4, max_size=4).filter(
        lambda q: math.hypot(*q) > 1e-3)
    return st.builds(Pose, positions, quaternions)


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel.builtin("panda")


@functools.cache
def joint_angles(robot: RobotModel) -> st.SearchStrategy[list[float]]:
    """Joint angles within the limits: uniform, or at a limit. One strategy per robot (drawn in every case: a new
    strategy per draw would be built and validated again each time, a third of the case's time)."""
    columns = [st.one_of(st.floats(min_value=float(low), max_value=float(high)),
                         st.sampled_from([float(low), float(high)]))
               for low, high in zip(robot.lower_limits, robot.upper_limits, strict=True)]
    return st.tuples(*columns).map(list)


# ------------------------------------------------------------------------------------------ the properties


def batches(**fields: st.SearchStrategy[Any]) -> st.SearchStrategy[list[dict[str, Any]]]:
    """:data:`BATCH` cases, each a dictionary of one value per field."""
    return st.lists(st.fixed_dictionaries(fields), min_size=BATCH, max_size=BATCH)


def check_each(cases: list[dict[str, Any]], check: Callable[..., None]) -> None:
    for case in cases:
        note(f"case: {case}")  # printed with a failure: the case that broke the contract
        check(**case)


def task_space_autonomy(pose: Pose, previous: list[float] | None, dt: float) -> None:
    last = None if previous is None else Twist(previous[:3], previous[3:])
    step = 0.0 if last is None else (dt or 0.02)  # a previous twist needs dt > 0
    twist = FIELD.twist(pose, last, step)
    assert_twist_within(twist.as_array())
    prepared = PreparedTwist(FIELD)
    prepared.pose[:3], prepared.pose[3:] = pose.position, pose.orientation
    if previous is not None:
        prepared.previous[:] = previous
    np.testing.assert_array_equal(prepared.evaluate(step), twist.as_array())  # the same answer, bit for bit
    assert_twist_within(FIELD.twists([pose.position], [pose.orientation])[0])


@CONTRACT
@given(cases=batches(pose=poses(), previous=st.one_of(st.none(), TWISTS), dt=DTS))
@example(cases=[{"pose": Pose((1e308, -1e308, 1e308)), "previous": [1e308] * 6, "dt": 1e308}])
def test_task_space_autonomy_is_finite_and_within_limits(cases: list[dict[str, Any]]) -> None:
    check_each(cases, task_space_autonomy)


@CONTRACT
@given(data=st.data())
def test_whole_body_autonomy_is_finite_and_within_limits(panda: RobotModel, data: st.DataObject) -> None:
    def whole_body(q: list[float], previous: list[float] | None, dt: float) -> None:
        answer = whole_body_autonomy(FIELD, panda, q, previous, dt)
        assert_twist_within(answer.twist.as_array())
        assert_joints_within(answer.joint_velocities, panda)
        np.testing.assert_array_equal(whole_body_autonomy_vector(FIELD, panda, q, previous, dt).as_array(),
                                      answer.twist.as_array())

    check_each(data.draw(batches(q=joint_angles(panda), previous=st.one_of(st.none(), st.lists(ABSURD, min_size=7,
                                                                                               max_size=7)),
                                 dt=DTS)), whole_body)


def scene_with(speeds: list[Speed]) -> AssistanceScene:
    return AssistanceScene(field=FIELD, velocities={o.id: v for o, v in zip(OBSTACLES, speeds, strict=True)})


def task_space_assist(pose: Pose, user: list[float], speeds: list[Speed], arbitration: str,
                      previous: list[float] | None, dt: float) -> None:
    last = None if previous is None else Twist(previous[:3], previous[3:])
    answer = task_space_assistance(scene_with(speeds), pose, Twist(user[:3], user[3:]), arbitration, previous=last,
                                   dt=dt if dt > 0.0 else 0.02)
    assert_twist_within(answer.blended_command.as_array())
    assert_twist_within(answer.autonomy_vector.as_array())
    assert 0.0 <= answer.alpha <= 1.0 and 0.0 <= answer.speed_scale <= 1.0


@CONTRACT
@given(cases=batches(pose=poses(), user=TWISTS, speeds=st.lists(OBSTACLE_SPEEDS, min_size=3, max_size=3),
                     arbitration=st.sampled_from(["", *ARBITRATIONS]), previous=st.one_of(st.none(), TWISTS),
                     dt=DTS))
@example(cases=[{"pose": Pose((0.4, 0.0, 0.3)), "user": [1e308, 0, 0, 0, 0, 0], "speeds": [[-7.0, -7.0, 0.0]] * 3,
                 "arbitration": "", "previous": None, "dt": 0.0}])
def test_task_space_assistance_is_finite_and_within_limits(cases: list[dict[str, Any]]) -> None:
    check_each(cases, task_space_assist)


@CONTRACT
@given(data=st.data())
def test_whole_body_assistance_is_finite_and_within_limits(panda: RobotModel, data: st.DataObject) -> None:
    def whole_body(q: list[float], user: list[float], speeds: list[Speed], arbitration: str,
                   previous: list[float] | None, dt: float) -> None:
        answer = whole_body_assistance(scene_with(speeds), panda, q, Twist(user[:3], user[3:]), arbitration,
                                       prev_joint_velocities=previous, dt=dt)
        assert_twist_within(answer.blended_command.as_array())
        assert_twist_within(answer.autonomy_vector.as_array())
        assert_joints_within(answer.joint_velocities, panda)

    check_each(data.draw(batches(q=joint_angles(panda), user=TWISTS,
                                 speeds=st.lists(OBSTACLE_SPEEDS, min_size=3, max_size=3),
                                 arbitration=st.sampled_from(["", *ARBITRATIONS]),
                                 previous=st.one_of(st.none(), st.lists(ABSURD, min_size=7, max_size=7)), dt=DTS)),
               whole_body)


def mobile_base(obstacles: list[list[float]], goal: list[float] | None, teleop: list[float] | None,
                pose: list[float], drive: str) -> None:
    controller = BaseController(config=ControllerConfig(drive=drive))
    controller.set_obstacles(point_obstacles(obstacles))
    controller.set_goal(goal)
    if teleop is not None:
        controller.set_teleop(*teleop, now=0.0)
    for now in (0.0, 0.1):
        command = controller.step(pose, now)
        assert math.isfinite(command.linear_x) and math.isfinite(command.linear_y) and math.isfinite(command.angular_z)
        assert command.speed <= controller.params.max_spd_norm * SLACK, command
        assert abs(command.angular_z) <= controller.config.max_angular_speed * SLACK, command


@CONTRACT
@given(cases=batches(obstacles=st.lists(st.lists(ABSURD, min_size=2, max_size=2), max_size=4),
                     goal=st.one_of(st.none(), st.lists(ABSURD, min_size=2, max_size=2)),
                     teleop=st.one_of(st.none(), st.lists(ABSURD, min_size=3, max_size=3)),
                     pose=st.lists(ABSURD, min_size=3, max_size=3),
                     drive=st.sampled_from(["holonomic", "diff_drive"])))
@example(cases=[{"obstacles": [[0.0, 0.0]], "goal": None, "teleop": [1e308, 1e308, 0.0], "pose": [1e308, -1e308, 0.0],
                 "drive": "holonomic"}])
def test_mobile_base_commands_are_finite_and_within_limits(cases: list[dict[str, Any]]) -> None:
    check_each(cases, mobile_base)


# ------------------------------------------------------------------------------------------ the reproductions


def test_f1_an_operator_command_of_1e308_gives_a_finite_whole_body_answer_flagged_limited(panda: RobotModel) -> None:
    """F1: ``user_command.twist.linear.x`` = 1e308 made every joint velocity NaN, with no flag."""
    q = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
    answer = whole_body_assistance(scene_with([[0, 0, 0]] * 3), panda, q, Twist((1e308, 0.0, 0.0)))
    assert_joints_within(answer.joint_velocities, panda)
    assert_twist_within(answer.blended_command.as_array())
    assert answer.flags & Flag.VELOCITY_LIMITED and "velocity limited" in answer.message
    assert not answer.flags & Flag.HALTED


def test_f1_f2_absurd_obstacle_speeds_are_refused_naming_the_obstacle() -> None:
    """F1/F2: (−1.7e308, −1.7e308, 0) made the blend NaN, −1e6 m/s made it −500 000 m/s: now refused."""
    for velocity in ([-1.7e308, -1.7e308, 0.0], [-1e6, 0.0, 0.0], [0.0, 10.001, 0.0]):
        with pytest.raises(InvalidInput, match=r"velocities\['ball'\].*10 m/s"):
            AssistanceScene(field=FIELD, velocities={"ball": velocity})
    AssistanceScene(field=FIELD, velocities={"ball": [0.0, 0.0, safety.MAX_OBSTACLE_SPEED]})  # the bound itself


def test_f2_previous_joint_velocities_beyond_the_limits_are_clipped(panda: RobotModel) -> None:
    """F2: ``prev_joint_velocities`` of 10 rad/s answered 5.35 m/s and 17 rad/s; 1e38 answered 3.7e37 m/s."""
    q = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
    for value in (10.0, 1e38, -1e38):
        answer = whole_body_autonomy(FIELD, panda, q, [value] * 7, 0.02)
        assert_twist_within(answer.twist.as_array())
        assert_joints_within(answer.joint_velocities, panda)
    # clipping is rule 3: the same answer as the previous command at the limits themselves
    at_limits = whole_body_autonomy(FIELD, panda, q, panda.velocity_limits, 0.02)
    beyond = whole_body_autonomy(FIELD, panda, q, 10.0 * panda.velocity_limits, 0.02)
    np.testing.assert_array_equal(beyond.joint_velocities, at_limits.joint_velocities)


# ------------------------------------------------------------------------------------------ the rules, exactly


def test_a_twist_within_the_limits_is_returned_unchanged() -> None:
    values = np.array([0.03, 0.0, -0.04, 0.1, 0.2, 0.0])
    assert safety.limit_twist(values, 0.05, 0.4) == safety.WITHIN
    np.testing.assert_array_equal(values, [0.03, 0.0, -0.04, 0.1, 0.2, 0.0])


def test_a_twist_over_a_limit_is_scaled_by_one_factor_keeping_its_direction() -> None:
    values = np.array([0.3, 0.0, -0.4, 0.0, 0.0, 0.2])  # ‖v‖ = 0.5 m/s: ten times 0.05
    assert safety.limit_twist(values, 0.05, 0.4) == safety.SCALED
    np.testing.assert_allclose(values, [0.03, 0.0, -0.04, 0.0, 0.0, 0.02], rtol=1e-15)
    values = np.array([1e308, 1e308, 1e308, -1e308, 0.0, 0.0])  # no overflow: the direction is kept
    assert safety.limit_twist(values, 0.05, 0.4) == safety.SCALED
    np.testing.assert_allclose(values[:3], [0.05 / math.sqrt(3)] * 3, rtol=1e-14)
    np.testing.assert_allclose(values[3:], [-0.05 / math.sqrt(3), 0.0, 0.0], rtol=1e-14)  # the same factor


@settings(max_examples=400, deadline=None)
@given(st.tuples(*[st.floats(-3.0, 3.0, allow_subnormal=False)] * 3), st.floats(1e-3, 3.0),
       st.sampled_from([-1e-3, -1e-9, -1e-12, 0.0, 1e-12, 1e-9, 1e-3]))
def test_a_parts_scale_is_the_same_whether_it_is_clearly_within_or_not(
        direction: tuple[float, float, float], limit: float, excess: float) -> None:
    """part_scale answers a part clearly within its limit without the scaled norm (limits.cpp); the same part and
    limit times 2^600 or 2^-600 take the scaled norm (squares that would overflow, or fall among the subnormals),
    whose factor does not change under a power of two: the bits agree."""
    norm = math.hypot(*direction)
    if norm == 0.0:
        return
    v = [c / norm * limit * (1.0 + excess) for c in direction]
    near = core_safety.part_scale(*v, limit)
    for power in (600, -600):
        assert near == core_safety.part_scale(*(math.ldexp(c, power) for c in v), math.ldexp(limit, power))
    assert (near == 1.0) if excess < -1e-10 else (excess <= 0.0 or near < 1.0)


def test_a_non_finite_command_is_zeroed_and_halted() -> None:
    values = np.array([0.01, math.nan, 0.0, 0.0, 0.0, 0.0])
    assert safety.limit_twist(values, 0.05, 0.4) == safety.HALTED
    np.testing.assert_array_equal(values, np.zeros(6))
    joints, twist = np.array([0.1, math.inf]), np.array([0.01, 0, 0, 0, 0, 0.0])
    assert safety.limit_joint_command(joints, twist, np.array([1.0, 1.0]), 0.05, 0.4) == safety.HALTED
    assert not joints.any() and not twist.any()


def test_joint_commands_scale_joints_and_twist_by_the_smallest_factor() -> None:
    joints, twist = np.array([2.0, -0.5, 4.0]), np.array([0.02, 0.0, 0.0, 0.0, 0.0, 0.1])
    assert safety.limit_joint_command(joints, twist, np.array([1.0, 1.0, 1.0]), 0.05, 0.4) == safety.SCALED
    np.testing.assert_allclose(joints, [0.5, -0.125, 1.0])  # s = 1/4, from the third joint
    np.testing.assert_allclose(twist, [0.005, 0.0, 0.0, 0.0, 0.0, 0.025])
    joints, twist = np.array([0.1, 0.1]), np.array([0.2, 0.0, 0.0, 0.0, 0.0, 0.0])  # the twist decides: s = 1/4
    assert safety.limit_joint_command(joints, twist, np.array([0.0, math.inf]), 0.05, 0.4) == safety.SCALED
    np.testing.assert_allclose(joints, [0.025, 0.025])  # joints without a positive finite limit: finite only


def test_input_rules_clip_previous_joint_velocities_and_obstacle_estimates() -> None:
    limits = np.array([1.0, 2.0, 0.0])
    inside = np.array([0.5, -2.0, 7.0])
    assert safety.clip_joint_velocities(inside, limits) is inside
    np.testing.assert_array_equal(safety.clip_joint_velocities(np.array([3.0, -1e38, 7.0]), limits), [1.0, -2.0, 7.0])
    assert safety.clip_obstacle_velocity(3.0, 4.0, 0.0) == (3.0, 4.0, 0.0)
    np.testing.assert_allclose(safety.clip_obstacle_velocity(300.0, 400.0, 0.0), (6.0, 8.0, 0.0))


def test_the_operator_command_is_clipped_and_the_blend_flagged() -> None:
    far = Pose((0.0, -0.5, 0.8))  # beyond every obstacle's influence: alpha 0, the operator's command alone
    scene = AssistanceScene(field=FIELD)
    answer = task_space_assistance(scene, far, Twist((0.3, 0.0, 0.4), (0.0, 0.0, 0.8)), "safety_only")
    # one factor for both parts: the linear one decides (0.05 / 0.5 = 0.1)
    np.testing.assert_allclose(answer.blended_command.linear, [0.03, 0.0, 0.04], rtol=1e-15)
    np.testing.assert_allclose(answer.blended_command.angular, [0.0, 0.0, 0.08], rtol=1e-15)
    assert answer.flags & Flag.VELOCITY_LIMITED and not answer.flags & Flag.HALTED
    within = task_space_assistance(scene, far, Twist((0.03, 0.0, 0.0)), "safety_only")
    assert not within.flags & Flag.VELOCITY_LIMITED
    np.testing.assert_array_equal(within.blended_command.linear, [0.03, 0.0, 0.0])


def test_a_previous_twist_beyond_the_limits_counts_as_the_limit() -> None:
    pose = Pose((0.3, 0.1, 0.35), GOAL.orientation)
    beyond = FIELD.twist(pose, Twist((5.0, 0.0, 0.0)), 0.02)
    at_limit = FIELD.twist(pose, Twist((CONFIG.max_linear_velocity, 0.0, 0.0)), 0.02)
    np.testing.assert_array_equal(beyond.as_array(), at_limit.as_array())
    with pytest.raises(InvalidInput, match="previous"):
        prepared = PreparedTwist(FIELD)
        prepared.previous[0] = math.nan
        prepared.evaluate(0.02)
