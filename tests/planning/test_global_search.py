"""The compiled global search: valid, deterministic paths; invalid ends refused at once; options validated."""

from __future__ import annotations

import itertools
import threading
import time
from typing import Any

import numpy as np
import pytest

from pfield._core.robot_distance import fitted_self_clearances_at
from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.geometry import Box, Obstacle, Sphere, pack_obstacles, signed_distances
from pfield.planning import global_search
from pfield.planning._whole_body_core import core_robot
from pfield.planning.global_search import (
    GlobalOptions,
    goal_configurations,
    joint_space_search,
    orientations_along,
    point_space_search,
)
from pfield.planning.options import PlanOptions
from pfield.planning.status import PlanStatus
from pfield.planning.whole_body import WholeBodyOptions, make_scene, pack_robot
from pfield.robot import RobotModel
from pfield.robot.collision import CollisionChecker, capsule_clearances
from pfield.spatial import Pose

WALL = [Obstacle("wall", Box(0.05, 0.6, 0.6), Pose((0.5, 0.0, 0.0)))]
Q_START = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])


@pytest.fixture(scope="module")
def xarm() -> RobotModel:
    return RobotModel.builtin("xarm7")


def _interpolated(path: np.ndarray, resolution: float) -> np.ndarray:
    samples = [path[0]]
    for a, b in itertools.pairwise(path):
        steps = max(1, int(np.ceil(np.max(np.abs(b - a)) / resolution)))
        samples.extend(a + (b - a) * k / steps for k in range(1, steps + 1))
    return np.array(samples)


def test_a_point_path_around_a_wall_keeps_the_margin_on_every_edge() -> None:
    packed = pack_obstacles(WALL)
    result = point_space_search(make_scene(packed), np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.02, GlobalOptions())
    assert result.found, result.reason
    np.testing.assert_array_equal(result.path[0], np.zeros(3))
    np.testing.assert_array_equal(result.path[-1], [1.0, 0.0, 0.0])
    distances, _ = signed_distances(packed, _interpolated(result.path, 0.001))
    assert np.min(distances) >= 0.02 - 1e-9
    assert result.states_checked > 0


def test_the_same_seed_gives_the_same_path_and_another_seed_may_not() -> None:
    scene = make_scene(pack_obstacles(WALL))
    runs = [point_space_search(scene, np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.02, GlobalOptions(seed=seed))
            for seed in (7, 7, 8)]
    np.testing.assert_array_equal(runs[0].path, runs[1].path)
    assert runs[0].states_checked == runs[1].states_checked
    assert runs[2].found


@pytest.mark.parametrize(("start", "goal", "status"), [
    ((0.5, 0.0, 0.0), (1.0, 0.0, 0.0), PlanStatus.START_INVALID),
    ((0.0, 0.0, 0.0), (0.51, 0.0, 0.1), PlanStatus.GOAL_INVALID),
])
def test_an_end_inside_an_obstacle_is_refused_before_searching(start: Any, goal: Any, status: PlanStatus) -> None:
    result = point_space_search(make_scene(pack_obstacles(WALL)), np.array(start, dtype=float),
                                np.array(goal, dtype=float), 0.02, GlobalOptions())
    assert not result.found and result.status == status
    assert result.states_checked <= 2


def _enclosure() -> list[Obstacle]:
    """Six walls around (1, 0, 0): a goal there cannot be reached from outside."""
    return [Obstacle(f"side{i}", Box(*size), Pose(centre)) for i, (size, centre) in enumerate([
        ((0.05, 0.5, 0.5), (1.25, 0, 0)), ((0.05, 0.5, 0.5), (0.75, 0, 0)), ((0.5, 0.05, 0.5), (1.0, 0.25, 0)),
        ((0.5, 0.05, 0.5), (1.0, -0.25, 0)), ((0.5, 0.5, 0.05), (1.0, 0, 0.25)), ((0.5, 0.5, 0.05), (1.0, 0, -0.25))])]


def test_an_enclosed_goal_ends_at_the_time_limit_with_a_reason() -> None:
    box = _enclosure()
    result = point_space_search(make_scene(pack_obstacles(box)), np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.01,
                                GlobalOptions(time_limit=0.2, capacity=500))
    assert not result.found and result.status == PlanStatus.GLOBAL_TIME_LIMIT, result.reason
    cancelled = point_space_search(make_scene(pack_obstacles(box)), np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.01,
                                   GlobalOptions(time_limit=60.0), np.ones(1, dtype=np.uint8))
    assert not cancelled.found and cancelled.status == PlanStatus.CANCELLED  # stopped after one chunk


def test_a_full_tree_starts_the_search_again_until_the_time_limit() -> None:
    """Trees of 50 nodes fill at once around an enclosed goal: each full tree starts the search again with fresh
    trees (a narrow passage may need another seed, not a bigger tree), so it ends at the time limit, not at the first
    full tree."""
    box = _enclosure()
    result = point_space_search(make_scene(pack_obstacles(box)), np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.01,
                                GlobalOptions(time_limit=0.3, capacity=50))
    assert not result.found and result.status == PlanStatus.GLOBAL_TIME_LIMIT, result.reason
    assert result.seconds >= 0.3
    assert result.states_checked > 20 * 50  # many trees of 50 nodes, not one


def _holed_enclosure(gap: float) -> list[Obstacle]:
    """:func:`_enclosure` with a square hole of side ``gap`` in its wall at x = 0.75, on the x axis."""
    side = (0.5 - gap) / 2
    walls = [((0.05, 0.5, 0.5), (1.25, 0, 0)), ((0.5, 0.05, 0.5), (1.0, 0.25, 0)), ((0.5, 0.05, 0.5), (1.0, -0.25, 0)),
             ((0.5, 0.5, 0.05), (1.0, 0, 0.25)), ((0.5, 0.5, 0.05), (1.0, 0, -0.25)),
             ((0.05, side, 0.5), (0.75, (gap + side) / 2, 0)), ((0.05, side, 0.5), (0.75, -(gap + side) / 2, 0)),
             ((0.05, gap, side), (0.75, 0, (gap + side) / 2)), ((0.05, gap, side), (0.75, 0, -(gap + side) / 2))]
    return [Obstacle(f"wall{i}", Box(*size), Pose(centre)) for i, (size, centre) in enumerate(walls)]


# Into the holed enclosure (3.5 cm hole, 1 cm margin): RRT-Connect's checks to a path are heavy-tailed there. Seed 1
# alone needs about 1.2 million (a restart's fresh trees find it), the race's second seed (1 + _LANE_SEED) about 500;
# seed 3 alone about 22 000, its second seed about 1.9 million. Both are past RACE_AFTER, so both races run.
_HOLE = ((make_scene(pack_obstacles(_holed_enclosure(0.035))), np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.01))


def _hole_search(seed: int, threads: int = 2, cancel: Any = None) -> Any:
    return point_space_search(*_HOLE, GlobalOptions(seed=seed, search_threads=threads, time_limit=30.0), cancel)


@pytest.mark.parametrize(("seed", "winner"), [(1, 1), (3, 0)])
def test_a_long_search_races_another_seed_and_keeps_the_path_found_with_fewer_checks(seed: int, winner: int) -> None:
    """The race's second lane is the search seeded ``seed + _LANE_SEED`` started after RACE_AFTER checks of the
    first: its path (and its shortening, which draws from its own trees' stream) is that search's own."""
    raced = _hole_search(seed)
    alone = [_hole_search(seed, threads=1), _hole_search(seed + global_search._LANE_SEED, threads=1)]
    assert raced.found and all(result.found for result in alone)
    np.testing.assert_array_equal(raced.path, alone[winner].path)
    if winner == 1:  # the race checked fewer states than the first seed alone
        assert raced.states_checked < alone[0].states_checked
    assert raced.states_checked > global_search.RACE_AFTER  # both lanes' checks are counted


def test_the_race_keeps_the_same_path_whatever_the_threads_timing(monkeypatch: pytest.MonkeyPatch) -> None:
    """The winner is the lowest count on one clock, not the first to arrive: a second lane that starts 50 ms late, or
    a first lane that sleeps 1 ms after every chunk (several times slower), changes the time, never the path."""
    expected = {seed: _hole_search(seed).path for seed in (1, 3)}
    run_lane = global_search._run_lane

    def late_second_lane(lane: Any, *args: Any, **kwargs: Any) -> Any:
        if lane.index == 1:
            time.sleep(0.05)
        return run_lane(lane, *args, **kwargs)

    monkeypatch.setattr(global_search, "_run_lane", late_second_lane)
    for seed, path in expected.items():
        np.testing.assert_array_equal(_hole_search(seed).path, path)
    monkeypatch.undo()
    connect = global_search._connect

    def slow_first_lane(*args: Any) -> Any:
        *head, after_chunk = args  # _run_lane's call; only the first lane's chunks call back
        if len(args) != 12 or after_chunk is None:
            return connect(*args)

        def slowly() -> None:
            time.sleep(0.001)
            after_chunk()

        return connect(*head, slowly)

    monkeypatch.setattr(global_search, "_connect", slow_first_lane)
    for seed, path in expected.items():
        np.testing.assert_array_equal(_hole_search(seed).path, path)


class _Counted:
    def __init__(self, states_checked: int) -> None:
        self.states_checked = states_checked


def test_the_race_keeps_the_path_found_at_the_lowest_count_not_the_first_to_arrive() -> None:
    """_Race's rule on its own: lane 1 joined at count 10 000; its path at 10 000 + 500 arrives first, lane 0's at
    10 400 later and wins; a tie goes to the lower lane; each lane's bound is where it can no longer win."""
    race = global_search._Race()
    first, second = race.add(_Counted(0), 0, 1), race.add(_Counted(0), 10_000, 2)
    path = np.zeros((2, 3))
    second.checker.states_checked = 500
    race.offer(second, path + 1.0, None)  # type: ignore[arg-type]
    assert race.winner() is second
    assert int(first.bound[0]) == 10_501  # lane 0 may still tie at 10 500, and a tie is lane 0's
    first.checker.states_checked = 10_400
    race.offer(first, path, None)  # type: ignore[arg-type]
    assert race.winner() is first and int(second.bound[0]) == 400
    tie = global_search._Race()
    low, high = tie.add(_Counted(0), 0, 1), tie.add(_Counted(0), 10_000, 2)
    high.checker.states_checked, low.checker.states_checked = 500, 10_500
    tie.offer(high, path, None)  # type: ignore[arg-type]
    tie.offer(low, path, None)  # type: ignore[arg-type]
    assert tie.winner() is low
    tie.stop()
    assert int(tie.add(_Counted(0), 0, 3).bound[0]) == -1  # a lane added after a stop stops at once


def test_a_short_search_starts_no_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    def refused(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a search that ends before RACE_AFTER checks started a thread")

    monkeypatch.setattr(threading.Thread, "start", refused)
    scene = make_scene(pack_obstacles(WALL))
    raced = point_space_search(scene, np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.02, GlobalOptions(seed=7))
    alone = point_space_search(scene, np.zeros(3), np.array([1.0, 0.0, 0.0]), 0.02,
                               GlobalOptions(seed=7, search_threads=1))
    assert raced.states_checked < global_search.RACE_AFTER
    np.testing.assert_array_equal(raced.path, alone.path)


def test_an_error_in_a_racing_lane_reaches_the_caller_and_stops_the_race(monkeypatch: pytest.MonkeyPatch) -> None:
    run_lane = global_search._run_lane

    def failing(lane: Any, *args: Any, **kwargs: Any) -> Any:
        if lane.index == 1:
            raise RuntimeError("lane 1 failed")
        return run_lane(lane, *args, **kwargs)

    races = []
    join = global_search._Race.join

    def kept(race: Any) -> None:
        races.append(race)
        join(race)

    monkeypatch.setattr(global_search, "_run_lane", failing)
    monkeypatch.setattr(global_search._Race, "join", kept)
    with pytest.raises(RuntimeError, match="lane 1 failed"):
        _hole_search(1)
    # seed 1's first lane alone finds its path after about 1.2 million checks: the error stopped it long before
    assert races[0].lanes[0].checker.states_checked < 1_000_000


def test_a_cancelled_race_stops_every_lane(monkeypatch: pytest.MonkeyPatch) -> None:
    cancel = np.zeros(1, dtype=np.uint8)
    start = global_search._Race.start

    def start_then_cancel(race: Any, lane: Any, run: Any) -> None:
        start(race, lane, run)
        cancel[0] = 1  # as a CancelToken would, while both lanes run

    monkeypatch.setattr(global_search._Race, "start", start_then_cancel)
    result = _hole_search(2, cancel=cancel)  # seed 2: about 200 000 checks alone, 1.9 million its second lane
    assert not result.found and result.status == PlanStatus.CANCELLED


def test_orientations_follow_the_geodesic_in_proportion_to_the_distance() -> None:
    start, goal = Pose((0, 0, 0)), Pose((2, 0, 0), (0.0, 0.0, 1.0, 0.0))  # 180° about z
    poses = orientations_along(np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]]), start, goal)
    assert poses[1].rotation_distance(start) == pytest.approx(np.pi / 2)
    assert poses[-1].rotation_distance(goal) == 0.0


def test_a_joint_path_keeps_the_capsule_margin_and_is_clear_under_the_exact_check(xarm: RobotModel) -> None:
    obstacles = [Obstacle("ball", Sphere(0.1), Pose((0.35, 0.0, 0.35)))]
    arrays = pack_robot(xarm, FieldConfig(), WholeBodyOptions())
    scene = make_scene(pack_obstacles(obstacles), arrays, Q_START, 0.01)
    goal = np.array([1.2, 0.4, -0.3, 0.8, 0.2, -1.2, 0.3])
    result, _ = joint_space_search(xarm, arrays, scene, Q_START, [goal], 0.02, GlobalOptions(seed=3))
    assert result.found, result.reason
    np.testing.assert_array_equal(result.path[0], Q_START)
    np.testing.assert_array_equal(result.path[-1], goal)
    checker = CollisionChecker(xarm, obstacles)
    # every pair keeps the margin, or goes at most endpoint_band deeper than at the start or the goal; the self
    # pairs on the fitted primitives, the search's model of them
    ends = [capsule_clearances(xarm, q, obstacles) for q in (Q_START, goal)]
    own_ends = [fitted_self_clearances_at(core_robot(arrays), q) for q in (Q_START, goal)]
    band = GlobalOptions().endpoint_band
    floor_obstacle = np.minimum(0.02, np.minimum(ends[0].obstacle, ends[1].obstacle) - band)
    floor_own = np.minimum(0.02, np.minimum(own_ends[0], own_ends[1]) - band)
    for q in _interpolated(result.path, 0.01):
        clearances = capsule_clearances(xarm, q, obstacles)
        assert np.all(clearances.obstacle >= floor_obstacle - 1e-9)
        assert np.all(fitted_self_clearances_at(core_robot(arrays), q) >= floor_own - 1e-9)
        assert not checker.check(q).in_collision


def test_goal_configurations_reach_the_pose_and_refuse_a_goal_inside_an_obstacle(xarm: RobotModel) -> None:
    arrays = pack_robot(xarm, FieldConfig(), WholeBodyOptions())
    target = xarm.forward_kinematics(np.array([0.3, 0.2, 0.0, 0.9, 0.0, -0.6, 0.0]))
    far_ball = [Obstacle("ball", Sphere(0.08), Pose((-0.4, -0.3, 0.3)))]
    scene = make_scene(pack_obstacles(far_ball), arrays)
    found, why = goal_configurations(xarm, target, [Q_START], arrays, scene, 0.01, far_ball, GlobalOptions())
    assert found and why == ""
    for q in found:
        assert xarm.forward_kinematics(q).translation_distance(target) < 1e-3
    ball = [Obstacle("ball", Sphere(0.08), Pose(target.position))]
    scene = make_scene(pack_obstacles(ball), arrays)
    inside, why = goal_configurations(xarm, target, [Q_START], arrays, scene, 0.01, ball, GlobalOptions())
    assert inside == [] and why.startswith("goal invalid: every inverse-kinematics solution")
    far, why = goal_configurations(xarm, Pose((3.0, 0.0, 0.0)), [Q_START], arrays, scene, 0.01, ball,
                                   GlobalOptions(ik_restarts=2))
    assert far == [] and why.startswith("goal invalid: no inverse-kinematics solution")


def test_a_given_goal_configuration_is_the_only_one_and_is_refused_when_it_collides(xarm: RobotModel) -> None:
    arrays = pack_robot(xarm, FieldConfig(), WholeBodyOptions())
    given = np.array([0.3, 0.2, 0.0, 0.9, 0.0, -0.6, 0.0])
    target = xarm.forward_kinematics(given)
    far_ball = [Obstacle("ball", Sphere(0.08), Pose((-0.4, -0.3, 0.3)))]
    scene = make_scene(pack_obstacles(far_ball), arrays)
    found, why = goal_configurations(xarm, target, [Q_START], arrays, scene, 0.01, far_ball, GlobalOptions(),
                                     given=given)
    assert len(found) == 1 and why == ""
    np.testing.assert_array_equal(found[0], given)  # no IK: exactly the caller's joints
    # a ball around the elbow of the given configuration: other IK solutions might clear it, this one cannot
    elbow = xarm.joint_frames(given)[1][3]
    ball = [Obstacle("ball", Sphere(0.06), Pose(tuple(elbow)))]
    assert CollisionChecker(xarm, ball).check(given).in_collision
    scene = make_scene(pack_obstacles(ball), arrays)
    found, why = goal_configurations(xarm, target, [Q_START], arrays, scene, 0.01, ball, GlobalOptions(),
                                     given=given)
    assert found == [] and why == "goal invalid: the given goal configuration collides (exact mesh check)"


def test_a_given_goal_configuration_on_a_joint_limit_is_kept_as_given(xarm: RobotModel) -> None:
    arrays = pack_robot(xarm, FieldConfig(), WholeBodyOptions())
    given = np.array([0.3, 0.2, 0.0, 0.9, 0.0, -0.6, 0.0])
    given[3] = xarm.upper_limits[3]  # the elbow on its upper limit
    scene = make_scene(pack_obstacles([]), arrays)
    found, _ = goal_configurations(xarm, xarm.forward_kinematics(given), [Q_START], arrays, scene, 0.01, [],
                                   GlobalOptions(), 0.02, given=given)
    np.testing.assert_array_equal(found[0], given)


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"time_limit": 0.0}, "time_limit"), ({"joint_step": -1.0}, "joint_step"), ({"capacity": 1}, "capacity"),
    ({"seed": True}, "seed"), ({"extra_margin": float("nan")}, "extra_margin"),
    ({"goal_configurations": 0}, "goal_configurations"), ({"search_threads": 0}, "search_threads"),
    ({"search_threads": True}, "search_threads"), ({"search_threads": 1.5}, "search_threads"),
])
def test_bad_options_are_refused_naming_the_field(kwargs: dict[str, Any], field: str) -> None:
    with pytest.raises(InvalidInput) as info:
        GlobalOptions(**kwargs)
    assert info.value.field == field


@pytest.mark.parametrize(("fallback", "limit", "field"), [
    ("yes", None, "global_fallback"), (1, None, "global_fallback"), (True, -1.0, "global_time_limit"),
    (True, float("inf"), "global_time_limit"),
])
def test_bad_planner_arguments_are_refused(fallback: Any, limit: Any, field: str) -> None:
    with pytest.raises(InvalidInput) as info:
        PlanOptions.build(None, global_fallback=fallback, global_time_limit=limit)
    assert info.value.field == field


def test_goal_configurations_inside_the_joint_margin_come_first(xarm: RobotModel) -> None:
    """A goal configuration on a joint limit cannot be tracked (the joint-limit dampers stop short of it), so
    those keeping ``joint_margin`` from every limit lead the list."""
    arrays = pack_robot(xarm, FieldConfig(), WholeBodyOptions())
    target = xarm.forward_kinematics(np.array([0.3, 0.2, 0.0, 0.9, 0.0, -0.6, 0.0]))
    scene = make_scene(pack_obstacles([]), arrays)
    margin = 0.5
    found, _ = goal_configurations(xarm, target, [Q_START], arrays, scene, 0.01, [], GlobalOptions(), margin)
    inside = [bool(np.all(q >= xarm.lower_limits + margin) and np.all(q <= xarm.upper_limits - margin))
              for q in found]
    assert inside[0] and inside == sorted(inside, reverse=True), inside


def test_tracking_a_lagging_joint_does_not_overshoot_its_target(xarm: RobotModel) -> None:
    """The tracking's pull on a joint that lags its target is capped at the speed it can brake from
    (√(2·a·e)): under the acceleration limit a stronger pull overshoots into a limit cycle."""
    from pfield._core import rrt as core
    from pfield.planning._whole_body_core import core_scene
    from pfield.planning.whole_body import kernel_parameters

    config = FieldConfig(max_angular_acceleration=1.0)  # rad/s²: joints take a while to brake
    arrays = pack_robot(xarm, config, WholeBodyOptions())
    scene = make_scene(pack_obstacles([]), arrays, Q_START, config.safety_distance)
    target = Q_START.copy()
    start = Q_START.copy()
    start[0] += 1.5  # 1.5 rad behind on the base joint
    unreachable = Pose((3.0, 0.0, 0.0))  # the run never ends early: the whole motion toward the target shows
    params = kernel_parameters(config, PlanOptions(dt=0.01).resolved(config), WholeBodyOptions())
    options = GlobalOptions()
    qs = np.empty((1501, 7))  # the tracking from a start off its path's first waypoint: the core's own entry
    outputs = (qs, np.empty((1501, 7)), np.empty((1501, 3)), np.empty((1501, 4)), np.empty((1501, 6)), np.empty(1501))
    result = core.track_path(core_scene(arrays, scene), start, np.stack([target, target]),
                             np.array(unreachable.position), np.array(unreachable.orientation), params, 1500,
                             options.tracking_gain, options.tracking_lead, np.zeros(1, dtype=np.uint8), *outputs)
    loop = (result.status, result.count, qs[:result.count])
    assert PlanStatus(loop[0]) in (PlanStatus.STAGNATION, PlanStatus.ITERATION_LIMIT)
    joint = loop[2][:, 0]
    assert abs(joint[-1] - target[0]) < 0.01  # it got there
    assert np.min(joint) >= target[0] - 0.02, f"overshoot {target[0] - np.min(joint):.3f} rad"
