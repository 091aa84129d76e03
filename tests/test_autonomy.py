"""Autonomy vectors: whole-body (joint angles in, end-effector twist out) and task-space."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pfield import errors
from pfield.field.config import FieldConfig
from pfield.field.field import PotentialField
from pfield.planning.scenes import SEED_GOAL, seed_obstacles
from pfield.robot import RobotModel
from pfield.shared_control.autonomy import (
    task_space_autonomy_vector,
    whole_body_autonomy,
    whole_body_autonomy_vector,
)
from pfield.spatial import Pose

Q0 = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])
GOAL = Pose((0.6, 0.3, 0.3), (1.0, 0.0, 0.0, 0.0))


@pytest.fixture(scope="module")
def xarm() -> RobotModel:
    return RobotModel.builtin("xarm7")


def test_twist_is_the_jacobian_times_the_joint_velocities(xarm: RobotModel) -> None:
    field = PotentialField(FieldConfig(), GOAL)
    result = whole_body_autonomy(field, xarm, Q0)
    np.testing.assert_allclose(result.twist.as_array(), xarm.jacobian(Q0) @ result.joint_velocities, atol=1e-12)
    assert result.pose.isclose(xarm.forward_kinematics(Q0), atol=1e-12)
    toward = GOAL.position - result.pose.position
    assert result.twist.linear @ toward > 0.0
    assert np.all(np.abs(result.joint_velocities) <= xarm.velocity_limits)
    assert np.isinf(result.clearance)
    np.testing.assert_array_equal(whole_body_autonomy_vector(field, xarm, Q0).as_array(), result.twist.as_array())


def test_equals_the_first_step_of_the_whole_body_plan(xarm: RobotModel, tmp_path: Path) -> None:
    q = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
    field = PotentialField(FieldConfig(), SEED_GOAL, seed_obstacles(tmp_path))
    plan = field.plan_whole_body(xarm, q, dt=0.02, goal_tolerance=0.01, max_iterations=3)
    result = whole_body_autonomy(field, xarm, q, prev_joint_velocities=np.zeros(7), dt=0.02)
    assert plan.joint_velocities is not None
    np.testing.assert_allclose(result.joint_velocities, plan.joint_velocities[0], atol=1e-12)
    np.testing.assert_allclose(result.twist.as_array(), plan.twists[0], atol=1e-12)
    assert result.clearance == pytest.approx(plan.clearances[0], abs=1e-12)


def test_previous_velocities_apply_the_joint_acceleration_limit(xarm: RobotModel) -> None:
    # speed limits that do not bind here: the output contract's scaling comes after the rate limit (below)
    config = FieldConfig(max_angular_acceleration=0.5, max_linear_velocity=5.0, max_angular_velocity=5.0)
    field = PotentialField(config, GOAL)
    free = whole_body_autonomy(field, xarm, Q0).joint_velocities
    rng = np.random.default_rng(11)
    for _ in range(20):
        previous = rng.uniform(-0.3, 0.3, 7)
        dt = float(rng.uniform(0.005, 0.05))
        limited = whole_body_autonomy(field, xarm, Q0, prev_joint_velocities=previous, dt=dt).joint_velocities
        assert np.all(np.abs(limited - previous) <= 0.5 * dt + 1e-12)
    # dt = 0 (or no previous velocities) means no rate limit
    unlimited = whole_body_autonomy(field, xarm, Q0, prev_joint_velocities=np.full(7, 0.3), dt=0.0)
    np.testing.assert_allclose(unlimited.joint_velocities, free, atol=1e-12)


def test_velocity_limits_take_precedence_over_the_acceleration_limit(xarm: RobotModel) -> None:
    """The output contract (pfield.safety rule 2) scales the rate-limited step into the speed limits."""
    config = FieldConfig(max_angular_acceleration=0.5, max_linear_velocity=0.01)
    result = whole_body_autonomy(PotentialField(config, GOAL), xarm, Q0, prev_joint_velocities=np.full(7, 0.3), dt=0.01)
    assert np.linalg.norm(result.twist.linear) == pytest.approx(0.01, rel=1e-12)
    assert np.all(np.abs(result.joint_velocities - 0.3) > 0.5 * 0.01)  # decelerated beyond a_max·dt


def test_query_pose_mismatch_is_flagged(xarm: RobotModel, caplog: pytest.LogCaptureFixture,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    import pfield.shared_control.autonomy

    monkeypatch.setattr(pfield.shared_control.autonomy, "_last_mismatch_warning", [-np.inf, 0])  # none in period
    field = PotentialField(FieldConfig(), GOAL)
    here = xarm.forward_kinematics(Q0)
    assert not whole_body_autonomy(field, xarm, Q0, query_pose=here).pose_mismatch
    nearby = Pose(here.position + np.array([0.005, 0.0, 0.0]), here.orientation)
    assert not whole_body_autonomy(field, xarm, Q0, query_pose=nearby).pose_mismatch
    elsewhere = Pose((0.3, 0.1, 0.35), (0.707, 0.0, 0.707, 0.0))
    with caplog.at_level("WARNING"):
        flagged = whole_body_autonomy(field, xarm, Q0, query_pose=elsewhere)
    assert flagged.pose_mismatch and "disagrees" in caplog.text
    # the joints are the truth: same twist with or without the (wrong) query pose
    np.testing.assert_array_equal(flagged.twist.as_array(), whole_body_autonomy(field, xarm, Q0).twist.as_array())
    # at control rate the warning is not repeated within its period, but every answer is still flagged
    caplog.clear()
    with caplog.at_level("WARNING"):
        assert all(whole_body_autonomy(field, xarm, Q0, query_pose=elsewhere).pose_mismatch for _ in range(50))
    assert "disagrees" not in caplog.text


def test_obstacles_slow_the_approach(xarm: RobotModel) -> None:
    from pfield.geometry import Obstacle, Sphere

    here = xarm.forward_kinematics(Q0).position
    toward = (GOAL.position - here) / np.linalg.norm(GOAL.position - here)
    blocker = Obstacle("ball", Sphere(0.03), Pose(here + 0.04 * toward + np.array([0.0, 0.0, -0.02])))
    free = whole_body_autonomy(PotentialField(FieldConfig(), GOAL), xarm, Q0)
    near = whole_body_autonomy(PotentialField(FieldConfig(), GOAL, [blocker]), xarm, Q0)
    assert near.clearance < FieldConfig().influence_distance
    assert not np.allclose(near.twist.as_array(), free.twist.as_array())


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"q": [0.0] * 6}, "joint_angles"),
        ({"q": [0.0, float("nan"), 0, 0, 0, 0, 0]}, "joint_angles"),
        ({"q": [0.0, 3.0, 0, 0, 0, 0, 0]}, "joint_angles[1]"),
        ({"prev_joint_velocities": [0.0] * 3, "dt": 0.01}, "prev_joint_velocities"),
        ({"prev_joint_velocities": [float("inf")] * 7, "dt": 0.01}, "prev_joint_velocities"),
        ({"dt": -0.01}, "delta_time"),
    ],
)
def test_bad_input(xarm: RobotModel, kwargs: dict[str, object], field: str) -> None:
    arguments: dict[str, object] = {"q": Q0}
    arguments.update(kwargs)
    target = PotentialField(FieldConfig(), GOAL)
    with pytest.raises(errors.InvalidInput) as info:
        whole_body_autonomy_vector(target, xarm, **arguments)  # type: ignore[arg-type]
    assert info.value.field == field


def test_task_space_vector_is_the_field_twist() -> None:
    field = PotentialField(FieldConfig(), GOAL)
    pose = Pose((0.3, 0.1, 0.35), (0.707, 0.0, 0.707, 0.0))
    assert task_space_autonomy_vector(field, pose) == field.twist(pose)


def test_several_fields_in_turn_keep_their_steppers(xarm: RobotModel) -> None:
    """Shared autonomy asks for the autonomy vector toward each candidate goal every period: each field keeps its
    compiled stepper on the thread (the last ``RECENT`` used), and the answers are those of a field asked alone."""
    from concurrent.futures import ThreadPoolExecutor

    from pfield.shared_control._recent import RECENT
    from pfield.shared_control.autonomy import whole_body_stepper

    goals = [Pose(GOAL.position + np.array((0.0, 0.02 * k, 0.0)), GOAL.orientation) for k in range(RECENT + 1)]
    fields = [PotentialField(FieldConfig(), goal) for goal in goals]
    alone = [whole_body_autonomy_vector(PotentialField(FieldConfig(), goal), xarm, Q0).as_array() for goal in goals]
    first = [whole_body_stepper(field, xarm) for field in fields[:2]]
    for _ in range(3):  # in turn: every answer the field's own, and no stepper built again
        for field, expected in zip(fields[:2], alone, strict=False):
            np.testing.assert_array_equal(whole_body_autonomy_vector(field, xarm, Q0).as_array(), expected)
    assert [whole_body_stepper(field, xarm) for field in fields[:2]] == first
    for field in fields:  # RECENT + 1 fields: the least recently used goes
        whole_body_stepper(field, xarm)
    assert whole_body_stepper(fields[0], xarm) is not first[0]
    with ThreadPoolExecutor(1) as pool:  # another thread builds its own (a stepper owns its buffers)
        assert pool.submit(whole_body_stepper, fields[1], xarm).result() is not whole_body_stepper(fields[1], xarm)


def test_the_default_stepper_is_never_one_built_with_other_options(xarm: RobotModel) -> None:
    from pfield.planning import WholeBodyOptions
    from pfield.shared_control.autonomy import whole_body_stepper

    field = PotentialField(FieldConfig(), GOAL)
    other = WholeBodyOptions(damping=0.2)
    default = whole_body_autonomy_vector(PotentialField(FieldConfig(), GOAL), xarm, Q0).as_array()
    assert whole_body_autonomy(field, xarm, Q0, options=other).joint_velocities is not None
    # the service's hot path right after it: the stepper used last has other options, so not that one
    np.testing.assert_array_equal(whole_body_autonomy_vector(field, xarm, Q0).as_array(), default)
    assert whole_body_autonomy(field, xarm, Q0, options=other).joint_velocities is not None
    assert whole_body_stepper(field, xarm).options == WholeBodyOptions()
    np.testing.assert_array_equal(whole_body_autonomy_vector(field, xarm, Q0).as_array(), default)
