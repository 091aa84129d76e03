"""The planners' global fallback: it runs only when the field stops short, and then gets there safely."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.field.field import PotentialField
from pfield.geometry import Box, Obstacle, Sphere, signed_distances
from pfield.node._base import Bus
from pfield.node.manager import ManagerNode
from pfield.planning.certify import certify_path
from pfield.planning.options import PlanOptions
from pfield.planning.result import PlannedPath
from pfield.planning.scenes import SEED_GOAL, SEED_START, seed_obstacles
from pfield.planning.status import PlanStatus
from pfield.planning.whole_body import JOINT_GOAL_TOLERANCE, WholeBodyOptions
from pfield.robot import RobotModel
from pfield.robot.collision import CollisionChecker
from pfield.robot.ik import solve_ik
from pfield.spatial import Pose

SEED_Q0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
# a box "cup" open toward −x around the start; the goal lies behind its bottom
CUP = [Obstacle("bottom", Box(0.05, 0.7, 0.7), Pose((0.3, 0.0, 0.0))),
       Obstacle("left", Box(0.55, 0.05, 0.7), Pose((0.05, 0.35, 0.0))),
       Obstacle("right", Box(0.55, 0.05, 0.7), Pose((0.05, -0.35, 0.0))),
       Obstacle("top", Box(0.55, 0.7, 0.05), Pose((0.05, 0.0, 0.35))),
       Obstacle("floor", Box(0.55, 0.7, 0.05), Pose((0.05, 0.0, -0.35)))]
CUP_GOAL = Pose((0.8, 0.0, 0.0))


@pytest.fixture(scope="module")
def xarm() -> RobotModel:
    return RobotModel.builtin("xarm7")


def _same(a: PlannedPath, b: PlannedPath) -> None:
    assert (a.success, a.status, a.failure_reason, a.planner) == (b.success, b.status, b.failure_reason, b.planner)
    for name in ("times", "positions", "orientations", "twists", "clearances", "joint_positions", "joint_velocities"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_a_task_space_u_trap_stagnates_alone_and_is_solved_through_the_fallback() -> None:
    field = PotentialField(FieldConfig(), CUP_GOAL, CUP)
    alone = field.plan(Pose((0.0, 0.0, 0.0)), dt=0.02, goal_tolerance=0.01, max_iterations=20000,
                       global_fallback=False)
    assert not alone.success and alone.status == PlanStatus.STAGNATION
    assert alone.planner == "field"
    path = field.plan(Pose((0.0, 0.0, 0.0)), dt=0.02, goal_tolerance=0.01, max_iterations=20000)
    assert path.success, path.failure_reason
    assert path.planner == "field+global"
    np.testing.assert_allclose(path.times, np.arange(len(path)) * 0.02)
    np.testing.assert_array_equal(path.positions[0], (0.0, 0.0, 0.0))
    assert np.linalg.norm(path.positions[-1] - CUP_GOAL.position) <= 0.01
    # every waypoint and every segment between waypoints (sampled every 1 mm) stays outside the cup
    assert path.min_clearance > 0.0
    samples = np.vstack([a + (b - a) * t for a, b in itertools.pairwise(path.positions)
                         for t in np.linspace(0.0, 1.0, 5)])
    distances, _ = signed_distances(field.arrays.packed, samples)
    assert np.min(distances) > 0.0


def test_where_the_field_reaches_the_goal_the_fallback_does_not_run(xarm: RobotModel, tmp_path: Path) -> None:
    obstacles = seed_obstacles(tmp_path)
    field = PotentialField(FieldConfig(), SEED_GOAL, obstacles)
    task_on, task_off = (field.plan(SEED_START, dt=0.01, goal_tolerance=0.01, global_fallback=flag)
                         for flag in (True, False))
    assert task_on.success and task_on.planner == "field"
    _same(task_on, task_off)
    body_on, body_off = (field.plan_whole_body(xarm, SEED_Q0, 0.02, 0.01, 25000, global_fallback=flag)
                         for flag in (True, False))
    assert body_on.success and body_on.planner == "field"
    _same(body_on, body_off)


def _wall_scene() -> tuple[list[Obstacle], Pose, np.ndarray]:
    """xarm7 from the seed start (tool forward) to a tool-down goal behind a 40 cm wall: the field pushes the
    hand into the wall and stagnates; the arm has to lift the hand over the wall."""
    return ([Obstacle("wall", Box(0.04, 0.8, 0.4), Pose((0.4, 0.0, 0.2)))],
            Pose((0.55, 0.0, 0.36), (1.0, 0.0, 0.0, 0.0)), SEED_Q0)


def test_a_whole_body_plan_that_stagnates_is_solved_through_the_fallback_without_contact(xarm: RobotModel) -> None:
    obstacles, goal, start = _wall_scene()
    config = FieldConfig(max_linear_velocity=0.25, max_angular_velocity=1.0, safety_distance=0.005,
                         influence_distance=0.05)
    field = PotentialField(config, goal, obstacles)
    alone = field.plan_whole_body(xarm, start, 0.02, 0.01, 10000, global_fallback=False)
    path = field.plan_whole_body(xarm, start, 0.02, 0.01, 10000)
    if alone.success:  # the scene must trap the field for this test to mean anything
        pytest.fail("the field alone reached the goal: the scene does not exercise the fallback")
    assert path.success, path.failure_reason
    assert path.planner == "field+global"
    assert path.joint_positions is not None
    np.testing.assert_allclose(path.joint_positions[0], start)
    assert path.final_pose.translation_distance(goal) <= 0.01
    assert path.final_pose.rotation_distance(goal) <= config.rotation_tolerance
    checker = CollisionChecker(xarm, obstacles)
    for a, b in itertools.pairwise(path.joint_positions):
        steps = max(1, int(np.ceil(np.max(np.abs(b - a)) / 0.01)))
        for t in np.linspace(0.0, 1.0, steps + 1)[1:]:
            assert not checker.check(a + (b - a) * t).in_collision
    assert path.trajectory is not None and np.all(np.diff(path.trajectory.times) > 0.0)


def test_a_goal_inside_an_obstacle_is_reported_as_goal_invalid_without_a_search(xarm: RobotModel) -> None:
    goal = Pose((0.45, 0.25, 0.3), (0.707, 0.0, 0.707, 0.0))
    blocker = [Obstacle("block", Sphere(0.12), Pose((0.45, 0.25, 0.3)))]
    path = PotentialField(FieldConfig(), goal, blocker).plan_whole_body(xarm, SEED_Q0, 0.02, 0.01, 2000)
    assert not path.success and path.planner == "field"
    assert path.status == PlanStatus.GOAL_INVALID


def test_a_goal_beyond_the_reach_ends_as_goal_invalid_when_the_field_stagnates(xarm: RobotModel) -> None:
    far = Pose((1.5, 0.0, 0.4), (1.0, 0.0, 0.0, 0.0))  # beyond the arm's reach (~0.7 m): no IK solution
    field = PotentialField(FieldConfig(stagnation_window=1.0), far)
    alone = field.plan_whole_body(xarm, SEED_Q0, 0.01, 0.01, 30000, global_fallback=False)
    path = field.plan_whole_body(xarm, SEED_Q0, 0.01, 0.01, 30000)
    assert (alone.status, path.status, path.planner) == (PlanStatus.STAGNATION, PlanStatus.GOAL_INVALID, "field")
    np.testing.assert_array_equal(path.joint_positions, alone.joint_positions)  # the field's motion is kept
    # the root cause first (issue 33): the goal cannot be reached, then what the field did
    assert path.failure_reason.startswith("goal invalid: no inverse-kinematics solution"), path.failure_reason
    assert "stagnation" in path.failure_reason


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"global_fallback": "yes"}, "global_fallback"), ({"global_time_limit": 0.0}, "global_time_limit"),
    ({"global_time_limit": float("nan")}, "global_time_limit"),
])
def test_bad_fallback_arguments_are_refused_by_both_planners(xarm: RobotModel, kwargs: dict[str, Any],
                                                             field: str) -> None:
    planner = PotentialField(FieldConfig(), CUP_GOAL, CUP)
    with pytest.raises(InvalidInput) as info:
        planner.plan(Pose((0.0, 0.0, 0.0)), **kwargs)
    assert info.value.field == field
    with pytest.raises(InvalidInput) as info:
        planner.plan_whole_body(xarm, SEED_Q0, **kwargs)
    assert info.value.field == field


def test_the_node_parameters_switch_the_fallback(xarm: RobotModel) -> None:
    node = ManagerNode(Bus(), xarm)
    assert node.get_parameters()["global_fallback"] is True
    assert node.get_parameters()["global_time_limit"] == 2.0
    after = node.set_parameters({"global_fallback": False, "global_time_limit": 0.5})
    assert (after["global_fallback"], after["global_time_limit"]) == (False, 0.5)
    for bad in ({"global_fallback": "no"}, {"global_time_limit": -1.0}):
        with pytest.raises(InvalidInput):
            node.set_parameters(bad)
        assert node.get_parameters() == after


def test_planned_path_refuses_an_unknown_planner() -> None:
    with pytest.raises(InvalidInput) as info:
        PlannedPath(True, "", np.zeros(1), np.zeros((1, 3)), np.array([[0, 0, 0, 1.0]]), np.zeros((1, 6)),
                    np.zeros(1), planner="rrt")
    assert info.value.field == "planner"


def test_the_readme_whole_body_service_call_succeeds_as_written(xarm: RobotModel) -> None:
    from pfield.interfaces import message_from_yaml
    from pfield.interfaces import potential_fields_interfaces as pfi

    node = ManagerNode(Bus(), xarm)
    node.on_obstacles(message_from_yaml(pfi.ObstacleArray, "{header: {frame_id: 'world'}, obstacles: [{frame_id: "
                                        "'ball', type: 'Sphere', group: 'Static', pose: {position: {x: 0.4, y: 0.0, "
                                        "z: 0.1}, orientation: {w: 1.0}}, radius: 0.1}]}"))
    request = message_from_yaml(pfi.PlanPath_Request, "{goal: {position: {x: 0.5, y: 0.2, z: 0.4}}, "
                                "starting_joint_angles: [0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0], delta_time: 0.02, "
                                "goal_tolerance: 0.01, planning_method: 'whole_body'}")
    response = node.plan_path(request)
    assert response.success, response.error_message
    end = response.end_effector_path.poses[-1].pose.position
    assert np.linalg.norm(np.array([end.x, end.y, end.z]) - (0.5, 0.2, 0.4)) <= 0.01
    points = response.joint_trajectory.points
    assert all(len(p.accelerations) == 7 for p in points)


def _wall_field() -> tuple[PotentialField, Pose, np.ndarray]:
    obstacles, goal, start = _wall_scene()
    config = FieldConfig(max_linear_velocity=0.25, max_angular_velocity=1.0, safety_distance=0.005,
                         influence_distance=0.05)
    return PotentialField(config, goal, obstacles), goal, start


def test_a_given_goal_configuration_is_where_the_fallback_goes(xarm: RobotModel) -> None:
    field, goal, start = _wall_field()
    solved = field.plan_whole_body(xarm, start, 0.02, 0.01, 10000)
    assert solved.success and solved.planner == "field+global" and solved.joint_positions is not None
    # another configuration of the (redundant) arm at the same pose: IK from a seed with the elbow turned
    other = solve_ik(xarm, goal, np.clip(solved.joint_positions[-1] + np.array([0.0, 0.0, 1.5, 0.0, -1.5, 0.0, 0.0]),
                                         xarm.lower_limits, xarm.upper_limits))
    assert other.success
    assert np.max(np.abs(other.q - solved.joint_positions[-1])) > 0.3  # a different configuration indeed
    path = field.plan_whole_body(xarm, start, 0.02, 0.01, 10000, goal_configuration=other.q)
    assert path.success and path.planner == "field+global", path.failure_reason
    assert path.joint_positions is not None
    assert path.final_pose.translation_distance(goal) <= 0.01
    # the tracking ends where the search went: at the given configuration, not the other one
    assert np.max(np.abs(path.joint_positions[-1] - other.q)) < 0.1
    checker = CollisionChecker(xarm, list(field.obstacles))
    assert not any(checker.check(q).in_collision for q in path.joint_positions[::5])


def test_a_goal_configuration_where_the_field_ends_anyway_changes_nothing_without_the_posture_term(
        xarm: RobotModel, tmp_path: Path) -> None:
    """With posture_gain 0 a joint goal only checks the end: the field's own plan, bit for bit. With the default
    gain the steps are drawn toward it from the start: another motion, which the field alone still ends at that
    configuration."""
    field = PotentialField(FieldConfig(), SEED_GOAL, seed_obstacles(tmp_path))
    alone = field.plan_whole_body(xarm, SEED_Q0, 0.02, 0.01, 25000)
    assert alone.success and alone.planner == "field" and alone.joint_positions is not None
    end = alone.joint_positions[-1]
    given = field.plan_whole_body(xarm, SEED_Q0, 0.02, 0.01, 25000, goal_configuration=end,
                                  whole_body_options=WholeBodyOptions(posture_gain=0.0))
    _same(alone, given)
    drawn = field.plan_whole_body(xarm, SEED_Q0, 0.02, 0.01, 25000, goal_configuration=end)
    assert drawn.success and drawn.planner == "field" and drawn.joint_positions is not None
    assert np.max(np.abs(drawn.joint_positions[-1] - end)) <= JOINT_GOAL_TOLERANCE
    n = min(len(drawn.joint_positions), len(alone.joint_positions))
    assert np.max(np.abs(drawn.joint_positions[:n] - alone.joint_positions[:n])) > 1e-3  # the term acted


def test_the_search_seed_is_a_plan_option_same_seed_same_plan_another_seed_another_path(xarm: RobotModel) -> None:
    """PlanOptions.global_seed reaches the fallback's search: seed 0 is the default plan bit for bit, another seed
    searches other samples (a retry, or a benchmark over seeds) and is as safe."""
    field, _, start = _wall_field()
    default = field.plan_whole_body(xarm, start, 0.02, 0.01, 10000)
    assert default.success and default.planner == "field+global"
    _same(default, field.plan_whole_body(xarm, start, options=PlanOptions(dt=0.02, goal_tolerance=0.01,
                                                                         max_iterations=10000, global_seed=0)))
    options = PlanOptions(dt=0.02, goal_tolerance=0.01, max_iterations=10000, global_seed=1)
    other = field.plan_whole_body(xarm, start, options=options)
    assert other.success and other.planner == "field+global", other.failure_reason
    assert other.joint_positions is not None and default.joint_positions is not None
    assert len(other.joint_positions) != len(default.joint_positions) or \
        np.max(np.abs(other.joint_positions - default.joint_positions)) > 1e-3
    _same(other, field.plan_whole_body(xarm, start, options=options))
    assert certify_path(xarm, list(field.obstacles), other.joint_positions).clear
    cup = PotentialField(FieldConfig(), CUP_GOAL, CUP)
    task = [cup.plan(Pose((0.0, 0.0, 0.0)), options=PlanOptions(dt=0.02, goal_tolerance=0.01, max_iterations=20000,
                                                                global_seed=seed)) for seed in (0, 1)]
    assert all(path.success and path.planner == "field+global" for path in task)
    assert len(task[0]) != len(task[1]) or np.max(np.abs(task[0].positions - task[1].positions)) > 1e-3


@pytest.mark.parametrize(("shift", "name", "why"), [
    (np.array([0.3, 0, 0, 0, 0, 0, 0]), "goal_configuration", "from the goal pose"),
    (np.array([0, 0, 0, 0, 0, 0, 50.0]), "goal_configuration[6]", ""),
])
def test_a_goal_configuration_off_the_goal_or_the_limits_is_refused(xarm: RobotModel, shift: np.ndarray, name: str,
                                                                   why: str) -> None:
    field, goal, start = _wall_field()
    at_goal = solve_ik(xarm, goal, start)
    assert at_goal.success
    with pytest.raises(InvalidInput) as info:
        field.plan_whole_body(xarm, start, 0.02, 0.01, 100, goal_configuration=at_goal.q + shift)
    assert info.value.field == name and why in str(info.value)


def test_a_joint_goal_is_reached_in_its_own_configuration_not_another_at_its_pose() -> None:
    """A MoveIt joint goal (goal_configuration): attracted by its pose alone, the field reaches it in another
    configuration of the redundant arm (0.61 rad away here; the Panda's MotionBenchMaker bookshelf plans 5.4 rad,
    the UR5's flipped wrists 2.7-4.1 rad), which is not the goal. The posture term (WholeBodyOptions.posture_gain)
    draws the arm's free motion toward the configuration asked for, and the field reaches it alone; without the
    term, beyond JOINT_GOAL_TOLERANCE the global fallback searches to it."""
    panda = RobotModel.builtin("panda")
    ready = panda.named_configuration("ready")
    goal = panda.forward_kinematics(ready)
    other = solve_ik(panda, goal, ready + np.array([1.0, 0.3, -1.2, 0.2, 1.0, 0.3, 0.5]))
    assert other.success and np.max(np.abs(other.q - ready)) > 0.5  # another posture at the same pose
    start = other.q + np.array([0.0, -0.15, 0.0, -0.2, 0.0, 0.1, 0.0])
    field = PotentialField(FieldConfig(), goal)
    by_pose = field.plan_whole_body(panda, start, dt=0.02)
    assert by_pose.success and by_pose.planner == "field"
    assert np.max(np.abs(by_pose.joint_positions[-1] - ready)) > JOINT_GOAL_TOLERANCE  # the pose, its own posture
    drawn = field.plan_whole_body(panda, start, dt=0.02, goal_configuration=ready)
    assert drawn.success and drawn.planner == "field", drawn.failure_reason
    assert np.max(np.abs(drawn.joint_positions[-1] - ready)) <= JOINT_GOAL_TOLERANCE
    assert certify_path(panda, [], drawn.joint_positions).clear
    free = WholeBodyOptions(posture_gain=0.0)
    asked = field.plan_whole_body(panda, start, dt=0.02, goal_configuration=ready, whole_body_options=free)
    assert asked.success and asked.planner == "field+global", asked.failure_reason
    assert np.max(np.abs(asked.joint_positions[-1] - ready)) <= JOINT_GOAL_TOLERANCE
    alone = field.plan_whole_body(panda, start, dt=0.02, goal_configuration=ready, whole_body_options=free,
                                  global_fallback=False)
    assert not alone.success and "another configuration than the joint goal" in alone.failure_reason
    # what the failed plan returns is the field's motion, certified clear on the meshes (a contact would cut it
    # short, COLLISION, as for a motion that reaches its goal): here the whole motion
    assert alone.status == PlanStatus.STAGNATION and alone.planner == "field"
    np.testing.assert_array_equal(alone.joint_positions, by_pose.joint_positions)
    assert certify_path(panda, [], alone.joint_positions).clear
