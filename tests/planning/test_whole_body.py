"""Whole-body planning: reaches the goal, never collides (checked with coal), respects joint limits."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pfield import errors
from pfield.field.config import FieldConfig
from pfield.field.field import PotentialField
from pfield.geometry import Obstacle, Sphere
from pfield.planning import CancelToken, PlanOptions, PlanStatus
from pfield.planning.result import PlannedPath
from pfield.planning.scenes import DEFAULT_PARAMS, SEED_GOAL, seed_obstacles, sphere_line_scene
from pfield.planning.whole_body import joint_velocity_sign_flips, plan_whole_body
from pfield.robot import RobotModel
from pfield.robot.collision import CollisionChecker
from pfield.spatial import Pose

Q0 = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])
REFERENCE_GOAL = Pose((0.6, 0.3, 0.3), (1.0, 0.0, 0.0, 0.0))
SEED_Q0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])


@pytest.fixture(scope="module")
def xarm() -> RobotModel:
    return RobotModel.builtin("xarm7")


def _check_plan_invariants(path: PlannedPath, robot: RobotModel, q0: np.ndarray, dt: float) -> None:
    assert path.joint_names == robot.joint_names
    assert path.joint_positions is not None and path.joint_velocities is not None
    np.testing.assert_allclose(path.joint_positions[0], q0, atol=1e-12)  # the start is waypoint 0
    np.testing.assert_allclose(path.times, np.arange(len(path)) * dt)
    assert np.all(path.joint_positions >= robot.lower_limits - 1e-12)
    assert np.all(path.joint_positions <= robot.upper_limits + 1e-12)
    assert np.all(np.abs(path.joint_velocities) <= robot.velocity_limits + 1e-9)
    # the recorded end-effector path is the forward kinematics of the joint path
    np.testing.assert_allclose(robot.end_effector_positions(path.joint_positions), path.positions, atol=1e-12)


def _assert_success(path: PlannedPath, goal: Pose, tolerance: float) -> None:
    assert path.success, path.failure_reason
    assert np.linalg.norm(path.positions[-1] - goal.position) <= tolerance
    assert path.final_pose.rotation_distance(goal) <= 0.05
    # chattering is measured and rare: far fewer sign flips than steps
    assert joint_velocity_sign_flips(path) <= max(5, 0.02 * len(path))


@pytest.mark.parametrize("config", [FieldConfig(), DEFAULT_PARAMS], ids=["rosYaml", "default"])
def test_reference_scene_without_obstacles_reaches_the_goal(xarm: RobotModel, config: FieldConfig) -> None:
    field = PotentialField(config, REFERENCE_GOAL)
    path = field.plan_whole_body(xarm, Q0, dt=0.01, goal_tolerance=0.01, max_iterations=30000)
    _check_plan_invariants(path, xarm, Q0, 0.01)
    _assert_success(path, REFERENCE_GOAL, 0.01)
    assert np.all(np.isinf(path.clearances))
    assert np.all(path.joint_velocities[-1] == 0.0)


def test_seed_whole_body_example_with_all_six_obstacles(xarm: RobotModel, tmp_path: Path) -> None:
    obstacles = seed_obstacles(tmp_path)
    field = PotentialField(FieldConfig(), SEED_GOAL, obstacles)
    path = plan_whole_body(field, xarm, SEED_Q0, dt=0.02, goal_tolerance=0.01, max_iterations=25000)
    _check_plan_invariants(path, xarm, SEED_Q0, 0.02)
    _assert_success(path, SEED_GOAL, 0.01)
    assert path.min_clearance > 0.0
    checker = CollisionChecker(xarm, obstacles)  # independent: coal on the robot's own collision meshes
    for q in path.joint_positions:
        distance, pair, own, own_pair = checker.distances(q)
        assert distance > 0.0, pair
        assert own > 0.0, own_pair


def test_reference_scene_with_five_spheres_is_solved_without_collision(xarm: RobotModel) -> None:
    obstacles = sphere_line_scene(5, lateral_offset=0.15)
    for config in (FieldConfig(), DEFAULT_PARAMS):
        path = PotentialField(config, REFERENCE_GOAL, obstacles).plan_whole_body(xarm, Q0, 0.01, 0.01, 30000)
        _check_plan_invariants(path, xarm, Q0, 0.01)
        _assert_success(path, REFERENCE_GOAL, 0.01)  # the C++ original fails both (REFERENCE §3)
        assert path.min_clearance >= config.safety_distance - 1e-4  # dampers hold d_s up to linearisation
        checker = CollisionChecker(xarm, obstacles)
        assert min(checker.distances(q)[0] for q in path.joint_positions[::5]) > 0.0


def test_iteration_limit_is_reported(xarm: RobotModel) -> None:
    path = PotentialField(FieldConfig(), REFERENCE_GOAL).plan_whole_body(xarm, Q0, 0.01, 0.01, 3)
    assert not path.success
    assert path.status == PlanStatus.ITERATION_LIMIT
    assert len(path) == 4 and path.iterations == 3


def test_unreachable_goal_stagnates(xarm: RobotModel) -> None:  # the field alone
    far = Pose((1.5, 0.0, 0.4), (1.0, 0.0, 0.0, 0.0))  # beyond the arm's reach (~0.7 m)
    config = FieldConfig(stagnation_window=1.0)
    path = PotentialField(config, far).plan_whole_body(xarm, Q0, 0.01, 0.01, 30000, global_fallback=False)
    assert not path.success
    assert path.status == PlanStatus.STAGNATION
    _check_plan_invariants(path, xarm, Q0, 0.01)


def test_goal_behind_an_obstacle_is_not_reached_through_it(xarm: RobotModel) -> None:
    goal = Pose((0.5, 0.0, 0.25), (1.0, 0.0, 0.0, 0.0))
    wall = Obstacle("ball", Sphere(0.12), Pose((0.5, 0.0, 0.25)))  # the goal lies inside the ball
    path = PotentialField(FieldConfig(stagnation_window=1.0), goal, [wall]).plan_whole_body(xarm, Q0, 0.01, 0.01,
                                                                                            30000)
    assert not path.success and path.failure_reason
    assert path.min_clearance > 0.0


def test_start_in_collision_is_reported(xarm: RobotModel) -> None:
    tip = xarm.forward_kinematics(Q0).position
    obstacle = Obstacle("ball", Sphere(0.05), Pose(tip))
    path = PotentialField(FieldConfig(), REFERENCE_GOAL, [obstacle]).plan_whole_body(xarm, Q0, 0.01, 0.01, 100)
    assert not path.success
    assert path.status == PlanStatus.START_INVALID and "ball" in path.failure_reason
    assert len(path) == 1 and path.min_clearance <= 0.0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"q0": [0.0] * 6}, "starting_joint_angles"),
        ({"q0": [0.0, 3.0, 0, 0, 0, 0, 0]}, "starting_joint_angles[1]"),
        ({"q0": [0.0, float("nan"), 0, 0, 0, 0, 0]}, "starting_joint_angles"),
        ({"dt": 0.0}, "dt"),
        ({"dt": float("nan")}, "dt"),
        ({"dt": True}, "dt"),
        ({"goal_tolerance": -0.01}, "goal_tolerance"),
        ({"max_iterations": True}, "max_iterations"),
        ({"max_iterations": 2.5}, "max_iterations"),
        ({"max_iterations": 10**9}, "max_iterations"),
        ({"rotation_tolerance": 3.5}, "rotation_tolerance"),
    ],
)
def test_bad_input_names_the_field(xarm: RobotModel, kwargs: dict[str, object], field: str) -> None:
    arguments: dict[str, object] = {"q0": Q0, "dt": 0.01, "goal_tolerance": 0.01, "max_iterations": 100}
    arguments.update(kwargs)
    with pytest.raises(errors.InvalidInput) as info:
        plan_whole_body(PotentialField(FieldConfig(), REFERENCE_GOAL), xarm, **arguments)  # type: ignore[arg-type]
    assert info.value.field == field


def test_sign_flip_counter() -> None:
    velocities = np.array([[0.1, 0.0], [-0.1, 0.0], [0.0, 0.2], [0.1, 0.3], [0.2, -0.3]])
    count = len(velocities)
    path = PlannedPath(True, "", np.arange(count) * 0.1, np.zeros((count, 3)), np.tile([0, 0, 0, 1.0], (count, 1)),
                       np.zeros((count, 6)), np.zeros(count), joint_names=("a", "b"),
                       joint_positions=np.zeros((count, 2)), joint_velocities=velocities)
    assert joint_velocity_sign_flips(path) == 3  # joint a: + → −, then − → + across a stop; joint b: + → −


def test_velocity_qp_matches_a_reference_solver() -> None:
    from pfield._core import qp

    rng = np.random.default_rng(12)
    n = 7
    for _ in range(30):
        jac = rng.normal(size=(6, n))
        hessian = jac.T @ jac + 1e-3 * np.eye(n)
        c = rng.normal(size=n)
        m = int(rng.integers(1, 6))
        rows = rng.normal(size=(m, n))
        bounds = rng.normal(size=m) * 0.5 - 0.2
        free = qp.solve(hessian, c, np.empty((0, n)), np.empty(0)).x
        np.testing.assert_allclose(hessian @ free, c, atol=1e-9)
        x = qp.solve(hessian, c, rows, bounds, 100000, 1e-12).x
        reference = _reference_qp(hessian, c, rows, bounds)
        assert np.all(rows @ x >= bounds - 1e-9)
        assert 0.5 * x @ hessian @ x - c @ x == pytest.approx(reference, rel=1e-6, abs=1e-6)


def test_velocity_qp_is_exact_on_nearly_parallel_rows() -> None:
    """Two links pressing on one surface give nearly parallel damper rows, where coordinate ascent alone
    gains ~θ² per sweep; the active-set finish reaches the KKT point within the sweeps a step allows."""
    from pfield._core import qp

    theta = 0.01
    rows = np.array([[1.0, 0.0, 0.0], [math.cos(theta), math.sin(theta), 0.0], [0.0, 0.0, -1.0]])
    bounds = np.array([1.0, 1.0, -5.0])  # the third row holds at the optimum: it must stay inactive
    solution = qp.solve(np.eye(3), np.zeros(3), rows, bounds, 200, 1e-12)
    x, mu = solution.x, solution.multipliers
    # both rows active: x = (1, (1 − cos θ)/sin θ, 0); λ = (A Aᵀ)⁻¹ b for H = I, c = 0
    np.testing.assert_allclose(x, [1.0, (1.0 - math.cos(theta)) / math.sin(theta), 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(mu[:2], np.linalg.solve(rows[:2] @ rows[:2].T, bounds[:2]), rtol=1e-9)
    assert mu[2] == 0.0 and solution.result.violation == 0.0


def _reference_qp(hessian: np.ndarray, c: np.ndarray, rows: np.ndarray, bounds: np.ndarray) -> float:
    """Optimal value of min ½xᵀHx − cᵀx s.t. rows·x ≥ bounds, by scipy's SLSQP."""
    from scipy.optimize import minimize

    result = minimize(lambda v: 0.5 * v @ hessian @ v - c @ v, np.zeros(len(c)), jac=lambda v: hessian @ v - c,
                      constraints=[{"type": "ineq", "fun": lambda v: rows @ v - bounds, "jac": lambda v: rows}],
                      method="SLSQP", options={"ftol": 1e-12, "maxiter": 500})
    return float(result.fun)


def test_goal_behind_an_obstacle_names_the_blocking_link_and_obstacle(xarm: RobotModel) -> None:
    goal = Pose((0.5, 0.0, 0.25), (1.0, 0.0, 0.0, 0.0))
    wall = Obstacle("ball", Sphere(0.12), Pose((0.5, 0.0, 0.25)))
    path = PotentialField(FieldConfig(stagnation_window=1.0), goal, [wall]).plan_whole_body(
        xarm, Q0, 0.01, 0.01, 30000, global_fallback=False)  # the field alone
    assert path.status == PlanStatus.STAGNATION
    links = {capsule.link for capsule in xarm.geometry.capsules}
    named = [link for link in links if f"link {link!r} is " in path.failure_reason]
    assert named and "from obstacle 'ball'" in path.failure_reason


def test_a_cancelled_token_ends_the_plan_with_cancelled(xarm: RobotModel) -> None:
    token = CancelToken()
    token.cancel()
    field = PotentialField(FieldConfig(), REFERENCE_GOAL)
    path = field.plan_whole_body(xarm, Q0, options=PlanOptions(max_iterations=1000, cancel=token))
    assert path.status == PlanStatus.CANCELLED and not path.success and len(path) == 1
    free = field.plan_whole_body(xarm, Q0, options=PlanOptions(max_iterations=1000, cancel=CancelToken()))
    assert free.status == PlanStatus.REACHED


def test_keyword_arguments_equal_the_options_they_build(xarm: RobotModel) -> None:
    field = PotentialField(FieldConfig(), REFERENCE_GOAL)
    by_keywords = field.plan_whole_body(xarm, Q0, dt=0.02, goal_tolerance=0.005, max_iterations=400)
    by_options = field.plan_whole_body(xarm, Q0, options=PlanOptions(dt=0.02, goal_tolerance=0.005,
                                                                      max_iterations=400))
    assert by_keywords.status == by_options.status
    np.testing.assert_array_equal(by_keywords.joint_positions, by_options.joint_positions)
