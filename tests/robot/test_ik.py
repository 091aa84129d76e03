"""Inverse kinematics and joint trajectories attached to task-space plans."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pfield import errors
from pfield.field.config import FieldConfig
from pfield.field.field import PotentialField
from pfield.planning import PlanStatus
from pfield.planning.joint_trajectory import attach_joint_trajectory
from pfield.planning.result import PlannedPath
from pfield.planning.scenes import SEED_GOAL, SEED_START
from pfield.robot import RobotModel
from pfield.robot.ik import differential_ik, solve_ik
from pfield.spatial import Pose, Twist

SEED_Q0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])


@pytest.mark.parametrize("name", ["xarm7", "panda"])
def test_ik_recovers_reachable_poses_within_limits(name: str, xarm: RobotModel, panda: RobotModel) -> None:
    robot = xarm if name == "xarm7" else panda
    rng = np.random.default_rng(7)
    lower, upper = np.maximum(robot.lower_limits, -3.0), np.minimum(robot.upper_limits, 3.0)
    for _ in range(30):
        q_true = rng.uniform(lower, upper)
        target = robot.forward_kinematics(q_true)
        seed = np.clip(q_true + rng.normal(scale=0.2, size=robot.n_joints), robot.lower_limits, robot.upper_limits)
        result = solve_ik(robot, target, seed)
        assert result.success
        reached = robot.forward_kinematics(result.q)
        assert np.linalg.norm(reached.position - target.position) <= 1e-4
        assert reached.rotation_distance(target) <= 1e-3
        assert np.all(result.q >= robot.lower_limits) and np.all(result.q <= robot.upper_limits)


def test_ik_reports_an_unreachable_pose(xarm: RobotModel) -> None:
    result = solve_ik(xarm, Pose((1.5, 0.0, 0.4)), SEED_Q0, max_iterations=50)
    assert not result.success
    assert result.position_error > 0.5
    assert np.all(result.q >= xarm.lower_limits) and np.all(result.q <= xarm.upper_limits)


def test_ik_bad_input(xarm: RobotModel) -> None:
    with pytest.raises(errors.InvalidInput) as info:
        solve_ik(xarm, Pose(), [0.0] * 3)
    assert info.value.field == "q_seed"
    with pytest.raises(errors.InvalidInput) as info:
        solve_ik(xarm, Pose(), SEED_Q0, position_tolerance=0.0)
    assert info.value.field == "position_tolerance"
    with pytest.raises(errors.InvalidInput):
        solve_ik(xarm, (0.3, 0.0, 0.4), SEED_Q0)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ["xarm", "panda"])
def test_differential_ik_is_damped_least_squares(name: str, xarm: RobotModel, panda: RobotModel) -> None:
    """q̇ = Jᵀ(J Jᵀ + λ²I)⁻¹ v, the closed form; it realises v to O(λ²) away from singularities and tends to the
    minimum-norm solution as λ → 0; a Twist and 6 numbers give the same answer."""
    robot = xarm if name == "xarm" else panda
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(np.maximum(robot.lower_limits, -2.5), np.minimum(robot.upper_limits, 2.5))
        v = rng.normal(size=6) * [0.1, 0.1, 0.1, 0.3, 0.3, 0.3]
        jac = robot.jacobian(q)
        qd = differential_ik(robot, q, v)
        np.testing.assert_allclose(qd, jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(6), v), atol=1e-12)
        exact = differential_ik(robot, q, v, damping=1e-12)
        np.testing.assert_allclose(jac @ exact, v, atol=1e-6)
        np.testing.assert_allclose(exact, np.linalg.pinv(jac) @ v, atol=1e-6)  # the minimum-norm solution
        np.testing.assert_array_equal(differential_ik(robot, list(q), Twist(v[:3], v[3:])), qd)


def test_differential_ik_bad_input(xarm: RobotModel) -> None:
    for args, field in (((SEED_Q0[:3], np.zeros(6)), "q"), ((SEED_Q0, np.zeros(5)), "twist"),
                        ((SEED_Q0, [0, 0, np.nan, 0, 0, 0]), "twist"), ((np.full(7, 9.0), np.zeros(6)), "q[0]")):
        with pytest.raises(errors.InvalidInput) as info:
            differential_ik(xarm, *args)
        assert info.value.field == field
    with pytest.raises(errors.InvalidInput) as info:
        differential_ik(xarm, SEED_Q0, np.zeros(6), damping=0.0)
    assert info.value.field == "damping"


def test_task_space_plan_gets_joint_angles_for_every_waypoint(xarm: RobotModel) -> None:
    plan = PotentialField(FieldConfig(), SEED_GOAL).plan(SEED_START, dt=0.02, goal_tolerance=0.01,
                                                         max_iterations=25000)
    assert plan.success
    assert xarm.forward_kinematics(SEED_Q0).isclose(SEED_START, atol=1e-3)
    path = attach_joint_trajectory(plan, xarm, SEED_Q0)
    assert path.success and path.joint_names == xarm.joint_names
    assert path.joint_positions is not None and path.joint_velocities is not None
    assert path.joint_positions.shape == (len(plan), 7)  # the start included: no off-by-one
    for i in (0, len(plan) // 2, len(plan) - 1):
        pose = xarm.forward_kinematics(path.joint_positions[i])
        assert np.linalg.norm(pose.position - plan.positions[i]) <= 1e-4
        assert pose.rotation_distance(plan.poses[i]) <= 1e-3
    np.testing.assert_allclose(path.joint_velocities[0], (path.joint_positions[1] - path.joint_positions[0]) / 0.02)
    assert np.all(path.joint_velocities[-1] == 0.0)
    # consecutive waypoints stay on one IK branch: small joint steps
    assert np.abs(np.diff(path.joint_positions, axis=0)).max() < 0.05


def test_ik_failure_names_the_waypoint(xarm: RobotModel) -> None:
    start = xarm.forward_kinematics(SEED_Q0)
    positions = np.array([start.position, start.position + np.array([0.01, 0, 0]), (1.5, 0.0, 0.4), start.position])
    count = len(positions)
    plan = PlannedPath(True, "", np.arange(count) * 0.1, positions, np.tile(start.orientation, (count, 1)),
                       np.zeros((count, 6)), np.full(count, np.inf))
    path = attach_joint_trajectory(plan, xarm, SEED_Q0)
    assert not path.success and path.status == PlanStatus.IK_FAILED
    assert "waypoint 2 of 4" in path.failure_reason and "starting joint angles" not in path.failure_reason
    assert path.joint_positions is None
    # a path whose start is out of reach from where the seed's end effector is (a start pose not given for the seed)
    away = positions.copy()
    away[0] = (2.0, 0.0, 0.0)
    failed = attach_joint_trajectory(replace(plan, positions=away), xarm, SEED_Q0)
    offset = float(np.linalg.norm(away[0] - start.position))
    assert "waypoint 0 of 4" in failed.failure_reason
    assert f"its start is {offset:.4g} m from the end effector at the starting joint angles" in failed.failure_reason
    assert "an unset pose is the origin" in failed.failure_reason


def test_attach_joint_trajectory_bad_seed(xarm: RobotModel) -> None:
    plan = PlannedPath(True, "", np.zeros(1), np.zeros((1, 3)), np.array([[0, 0, 0, 1.0]]), np.zeros((1, 6)),
                       np.zeros(1))
    with pytest.raises(errors.InvalidInput) as info:
        attach_joint_trajectory(plan, xarm, [0.0, 4.0, 0, 0, 0, 0, 0])
    assert info.value.field == "q_seed[1]"
