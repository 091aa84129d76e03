"""Task-space planning: convergence, rotations, obstacle avoidance, stagnation, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pfield.errors import InvalidInput
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Obstacle, Sphere
from pfield.planning import CancelToken, PlannedPath, PlanOptions, PlanStatus
from pfield.planning.scenes import SEED_GOAL, SEED_PLAN, SEED_START, seed_obstacles
from pfield.spatial import Pose, geodesic_angle, quaternion_exp, quaternion_multiply


def _dense_clearance(field: PotentialField, path: PlannedPath, samples: int = 8) -> float:
    """Smallest clearance over the waypoints and points between them (straight segments)."""
    p = path.positions
    between = [p[:-1] + (p[1:] - p[:-1]) * t for t in np.linspace(0.0, 1.0, samples)]
    return float(field.clearances(np.concatenate([p, *between])).min())


def test_a_plan_that_starts_at_the_goal_has_one_point() -> None:
    goal = Pose((0.5, 0.2, 0.4), (0.707, 0.0, 0.707, 0.0))
    path = PotentialField(FieldConfig(), goal).plan(goal)
    assert path.success and len(path) == 1 and path.iterations == 0
    assert path.final_pose.isclose(goal)


def test_free_space_plan_converges_monotonically() -> None:
    goal = Pose((0.6, 0.3, 0.3))
    path = PotentialField(FieldConfig(), goal).plan(Pose((0.3, 0.0, 0.5)), dt=0.01)
    assert path.success and path.failure_reason == ""
    errors = np.linalg.norm(path.positions - goal.position, axis=1)
    assert np.all(np.diff(errors) <= 1e-12)
    assert errors[-1] <= 0.01 < errors[-2]
    np.testing.assert_allclose(path.times, np.arange(len(path)) * 0.01)
    np.testing.assert_array_equal(path.positions[0], (0.3, 0.0, 0.5))
    assert np.all(np.isinf(path.clearances))


def test_recorded_twists_obey_the_limits_and_integrate_to_the_path() -> None:
    config = FieldConfig()
    start = Pose((0.0, 0.0, 0.0), quaternion_exp((0.0, 2.0, 0.0)))
    path = PotentialField(config, Pose((0.3, -0.1, 0.2))).plan(start, dt=0.02)
    linear, angular = path.twists[:, :3], path.twists[:, 3:]
    assert np.linalg.norm(linear, axis=1).max() <= config.max_linear_velocity + 1e-12
    assert np.linalg.norm(angular, axis=1).max() <= config.max_angular_velocity + 1e-12
    assert np.linalg.norm(np.diff(linear, axis=0), axis=1).max() <= config.max_linear_acceleration * 0.02 + 1e-12
    assert np.linalg.norm(np.diff(angular, axis=0), axis=1).max() <= config.max_angular_acceleration * 0.02 + 1e-12
    # each step applies the recorded twist: p[i+1] = p[i] + dt v[i]
    np.testing.assert_allclose(np.diff(path.positions, axis=0), 0.02 * linear[:-1], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(path.orientations, axis=1), 1.0, atol=1e-12)


def test_200_random_orientations_up_to_half_a_turn_converge() -> None:
    rng = np.random.default_rng(7)
    field = PotentialField(FieldConfig(), Pose())
    axes = rng.normal(size=(200, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = rng.uniform(0.0, math.pi, 200)
    angles[:10] = math.pi  # exactly half a turn
    goals = quaternion_exp(rng.normal(size=(200, 3)))
    for axis, angle, goal in zip(axes, angles, goals, strict=True):
        start_q = quaternion_exp(axis * angle)
        # the start is `angle` away from the goal: rotate the goal by the start offset
        goal_pose = Pose((0.1, 0.0, 0.0), goal)
        start = Pose((0.1, 0.0, 0.0), quaternion_multiply(start_q, goal))
        path = field.with_goal(goal_pose).plan(start, dt=0.02, max_iterations=20000)
        assert path.success, path.failure_reason
        assert geodesic_angle(path.orientations[-1], goal) <= 0.05


def test_a_head_on_sphere_is_avoided_with_positive_clearance() -> None:
    ball = Obstacle("ball", Sphere(radius=0.1), Pose((0.5, 0.0, 0.3)))
    field = PotentialField(FieldConfig(), Pose((0.8, 0.0, 0.3)), [ball])
    path = field.plan(Pose((0.2, 0.0, 0.3)))
    assert path.success, path.failure_reason
    assert path.min_clearance > 0.0
    assert _dense_clearance(field, path) > 0.0
    np.testing.assert_allclose(path.clearances, ball.signed_distance(path.positions)[0], rtol=1e-12)


def test_a_head_on_sphere_is_avoided_with_the_original_parameters_too() -> None:
    from pfield.planning.scenes import DEFAULT_PARAMS

    ball = Obstacle("ball", Sphere(radius=0.1), Pose((0.5, 0.0, 0.3)))
    field = PotentialField(DEFAULT_PARAMS, Pose((0.8, 0.0, 0.3)), [ball])
    path = field.plan(Pose((0.2, 0.0, 0.3)))
    assert path.success and _dense_clearance(field, path) > 0.0


def _trap(closed: bool) -> list[Obstacle]:
    walls = [
        Obstacle("bottom", Box(0.05, 0.4, 0.4), Pose((0.6, 0.0, 0.3))),
        Obstacle("left", Box(0.3, 0.05, 0.4), Pose((0.45, 0.2, 0.3))),
        Obstacle("right", Box(0.3, 0.05, 0.4), Pose((0.45, -0.2, 0.3))),
    ]
    if closed:
        walls += [Obstacle("lid", Box(0.3, 0.4, 0.05), Pose((0.45, 0.0, 0.5))),
                  Obstacle("floor", Box(0.3, 0.4, 0.05), Pose((0.45, 0.0, 0.1)))]
    return walls


@pytest.mark.parametrize("closed", [False, True])
def test_a_u_shaped_trap_ends_in_stagnation_or_the_goal_never_inside(closed: bool) -> None:
    field = PotentialField(FieldConfig(), Pose((0.9, 0.0, 0.3)), _trap(closed))
    path = field.plan(Pose((0.45, 0.0, 0.3)), global_fallback=False)  # the field alone
    assert path.status in (PlanStatus.REACHED, PlanStatus.STAGNATION), path.failure_reason
    assert _dense_clearance(field, path) > 0.0
    if closed:  # a box open only toward the start cannot be left toward the goal
        assert not path.success and path.status == PlanStatus.STAGNATION


def test_a_goal_8_cm_in_front_of_a_box_face_is_reached() -> None:
    wall = Obstacle("wall", Box(0.1, 0.6, 0.6), Pose((0.5, 0.0, 0.3)))
    goal = Pose((0.37, 0.0, 0.3))  # the face is at x = 0.45
    assert wall.signed_distance(goal.position)[0][0] == pytest.approx(0.08)
    field = PotentialField(FieldConfig(influence_distance=0.1), goal, [wall])
    for start in (Pose((0.0, 0.0, 0.3)), Pose((0.2, 0.3, 0.5))):
        path = field.plan(start)
        assert path.success, path.failure_reason
        assert np.linalg.norm(path.positions[-1] - goal.position) <= 0.01


def test_the_seed_example_plans_through_the_six_seed_obstacles(tmp_path: Path) -> None:
    field = PotentialField(FieldConfig(), SEED_GOAL, seed_obstacles(tmp_path))
    path = field.plan(SEED_START, **SEED_PLAN)
    assert path.success, path.failure_reason
    assert np.linalg.norm(path.positions[-1] - SEED_GOAL.position) <= 0.01
    assert _dense_clearance(field, path) > 0.0


def test_the_iteration_limit_is_reported() -> None:
    field = PotentialField(FieldConfig(), Pose((1.0, 0.0, 0.0)))
    path = field.plan(Pose(), max_iterations=5)
    assert not path.success and len(path) == 6 and path.iterations == 5
    assert path.status == PlanStatus.ITERATION_LIMIT


def test_zero_max_iterations_means_the_default() -> None:
    field = PotentialField(FieldConfig(), Pose((1.0, 0.0, 0.0)))
    assert field.plan(Pose(), max_iterations=0).success
    assert field.plan(Pose(), max_iterations=-3).success


def test_a_start_inside_an_obstacle_is_a_collision() -> None:
    ball = Obstacle("ball", Sphere(radius=0.1), Pose((0.0, 0.0, 0.0)))
    path = PotentialField(FieldConfig(), Pose((1.0, 0.0, 0.0)), [ball]).plan(Pose((0.02, 0.0, 0.0)))
    assert not path.success and len(path) == 1
    assert path.status == PlanStatus.START_INVALID
    assert path.failure_reason == "collision: the start pose is inside 'ball'"


def test_a_goal_inside_an_obstacle_is_unreachable() -> None:
    ball = Obstacle("ball", Sphere(radius=0.1), Pose((1.0, 0.0, 0.0)))
    path = PotentialField(FieldConfig(), Pose((1.05, 0.0, 0.0)), [ball]).plan(Pose())
    assert not path.success and len(path) == 1
    assert path.status == PlanStatus.GOAL_INVALID and "'ball'" in path.failure_reason


@pytest.mark.parametrize(
    ("arguments", "name"),
    [
        ({"start": (0, 0, 0)}, "start"),
        ({"dt": 0.0}, "dt"),
        ({"dt": -0.01}, "dt"),
        ({"dt": math.nan}, "dt"),
        ({"dt": True}, "dt"),
        ({"goal_tolerance": 0.0}, "goal_tolerance"),
        ({"goal_tolerance": "small"}, "goal_tolerance"),
        ({"max_iterations": 10.5}, "max_iterations"),
        ({"max_iterations": True}, "max_iterations"),
        ({"max_iterations": 10**9}, "max_iterations"),
        ({"rotation_tolerance": 0.0}, "rotation_tolerance"),
        ({"rotation_tolerance": 4.0}, "rotation_tolerance"),
    ],
)
def test_bad_planning_input_names_the_argument(arguments: dict[str, object], name: str) -> None:
    field = PotentialField(FieldConfig(), Pose((1.0, 0.0, 0.0)))
    values: dict[str, object] = {"start": Pose()} | arguments
    with pytest.raises(InvalidInput) as info:
        field.plan(**values)  # type: ignore[arg-type]
    assert info.value.field == name


@pytest.mark.parametrize("params", ["rosYaml", "default"])
def test_random_cluttered_plans_never_enter_an_obstacle(params: str) -> None:
    """Spheres, boxes and capsules scattered along the start–goal line, 40 scenes per parameter set."""
    from pfield.geometry import Capsule
    from pfield.planning.scenes import DEFAULT_PARAMS

    config = FieldConfig() if params == "rosYaml" else DEFAULT_PARAMS
    rng = np.random.default_rng(11)
    outcomes = set()
    for _ in range(40):
        start, goal = rng.uniform(-0.5, 0.5, 3), rng.uniform(-0.5, 0.5, 3)
        obstacles = []
        for k in range(int(rng.integers(1, 6))):
            centre = start + rng.uniform(0.2, 0.8) * (goal - start) + rng.normal(0.0, 0.05, 3)
            shape = [Sphere(rng.uniform(0.02, 0.12)), Box(*rng.uniform(0.03, 0.25, 3)),
                     Capsule(rng.uniform(0.02, 0.08), rng.uniform(0.05, 0.3))][k % 3]
            obstacles.append(Obstacle(f"o{k}", shape, Pose(centre, quaternion_exp(rng.normal(size=3)))))
        field = PotentialField(config, Pose(goal), obstacles)
        path = field.plan(Pose(start))
        outcomes.add(path.status)
        if path.status in (PlanStatus.START_INVALID, PlanStatus.GOAL_INVALID):
            assert len(path) == 1
            continue
        assert path.status in (PlanStatus.REACHED, PlanStatus.STAGNATION), path.failure_reason
        assert _dense_clearance(field, path) > 0.0
    assert PlanStatus.REACHED in outcomes


def test_a_goal_under_a_wide_table_is_reached_around_its_edge() -> None:
    """Pressed head-on onto a 60 cm table top, the point slides to the edge instead of settling halfway."""
    table = Obstacle("table", Box(0.6, 0.6, 0.04), Pose((0.5, 0.0, 0.4)))
    field = PotentialField(FieldConfig(), Pose((0.5, 0.0, 0.2)), [table])
    path = field.plan(Pose((0.45, 0.05, 0.6)))
    assert path.success, path.failure_reason
    assert _dense_clearance(field, path) > 0.0
    assert np.max(np.abs(path.positions[:, :2] - (0.5, 0.0)), axis=0).max() > 0.3  # went past the edge


def test_a_step_into_an_obstacle_ends_the_plan_before_it() -> None:
    """Steps too coarse for the dampers (0.2 s at up to 5 m/s toward a 1 cm wall): the plan stops before the
    step that would enter the wall, and every returned waypoint and segment stays outside it."""
    from pfield.planning.scenes import DEFAULT_PARAMS

    wall = Obstacle("wall", Box(0.01, 1.0, 1.0), Pose((0.5, 0.0, 0.0)))
    field = PotentialField(DEFAULT_PARAMS.replace(max_linear_acceleration=100.0), Pose((1.0, 0.0, 0.0)), [wall])
    path = field.plan(Pose(), dt=0.2)
    assert not path.success
    assert path.status == PlanStatus.COLLISION and "'wall'" in path.failure_reason
    assert _dense_clearance(field, path, samples=64) > 0.0
    assert field.plan(Pose(), dt=0.05).success  # the same scene with a fine step goes around


def test_a_cancelled_token_ends_the_plan_with_cancelled() -> None:
    token = CancelToken()
    token.cancel()
    field = PotentialField(FieldConfig(), Pose((1.0, 0.0, 0.0)))
    path = field.plan(Pose(), options=PlanOptions(cancel=token))
    assert path.status == PlanStatus.CANCELLED and not path.success and len(path) == 1
    assert field.plan(Pose(), options=PlanOptions(cancel=CancelToken())).status == PlanStatus.REACHED


def test_a_plan_is_cancelled_from_another_thread() -> None:
    """The compiled loop releases the GIL, so a token cancelled while it runs stops it."""
    import threading

    token = CancelToken()
    field = PotentialField(FieldConfig(stagnation_window=1e6), Pose((1.0, 0.0, 0.0)), _trap(closed=True))
    started = threading.Event()
    result: list[PlannedPath] = []

    def plan() -> None:
        started.set()
        result.append(field.plan(Pose((0.45, 0.0, 0.3)), options=PlanOptions(max_iterations=2_000_000, cancel=token)))

    worker = threading.Thread(target=plan)
    worker.start()
    started.wait()
    token.cancel()
    worker.join()
    # trapped and never stagnating: only the token (or, had it come too late, the limit) ends this plan
    assert result[0].status == PlanStatus.CANCELLED
    assert len(result[0]) < 2_000_001


def test_keyword_arguments_equal_the_options_they_build() -> None:
    field = PotentialField(FieldConfig(), Pose((0.6, 0.3, 0.3)))
    by_keywords = field.plan(Pose((0.3, 0.0, 0.5)), dt=0.02, goal_tolerance=0.005, max_iterations=5000)
    options = PlanOptions(dt=0.02, goal_tolerance=0.005, max_iterations=5000)
    by_options = field.plan(Pose((0.3, 0.0, 0.5)), options=options)
    assert by_keywords.status == by_options.status == PlanStatus.REACHED
    np.testing.assert_array_equal(by_keywords.positions, by_options.positions)
    # keywords override the options they are given with
    assert field.plan(Pose((0.3, 0.0, 0.5)), max_iterations=3, options=options).status == PlanStatus.ITERATION_LIMIT


def test_stagnation_names_the_nearest_obstacle_and_its_distance() -> None:
    walls = _trap(closed=True)
    path = PotentialField(FieldConfig(), Pose((0.9, 0.0, 0.3)), walls).plan(Pose((0.45, 0.0, 0.3)))
    assert path.status == PlanStatus.STAGNATION
    assert any(f"nearest: '{wall.id}', " in path.failure_reason for wall in walls)
    assert f"{path.clearances[-1]:.4g} m away" in path.failure_reason
