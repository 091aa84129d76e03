"""The global search's model of the self pairs (issue 34): the fitted primitives instead of the covering capsules,
its goal band and its sampling window.

* ``robot_distance.fitted_self_clearances_at`` is the minimum over the primitive pairs of two links (oracle: every
  pair by the core's segment-segment distance, less both radii);
* the joint-space checker of a ``fitted_self`` scene gives each state the verdict of those distances and the
  link-obstacle distances against margin + offsets; without the flag, that of the covering capsules (as before);
* on the UR5, configurations exist that the covering capsules refuse and the fitted primitives and the exact
  meshes clear (why the flag exists);
* ``endpoint_scene``'s goal band, ``sampling_window``'s interval.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from core_scenes import robot
from pfield._core import robot_distance as distance
from pfield._core import rrt as core
from pfield.field.config import FieldConfig
from pfield.geometry import Box, Obstacle, pack_obstacles
from pfield.planning._whole_body_core import core_robot, core_scene, pair_distances
from pfield.planning.global_search import endpoint_scene, sampling_window
from pfield.planning.whole_body import WholeBodyOptions, make_scene, pack_robot
from pfield.robot.collision import CollisionChecker
from pfield.spatial import Pose

MARGIN = 0.003


def _configurations(name: str, count: int, seed: int) -> np.ndarray:
    model = robot(name)
    rng = np.random.default_rng(seed)
    return rng.uniform(model.lower_limits, model.upper_limits, (count, model.n_joints))


def _oracle(name: str, q: np.ndarray) -> np.ndarray:
    """Every self pair's minimum over its primitive pairs, one segment-segment distance each."""
    model = robot(name)
    g = model.geometry
    arrays = pack_robot(model, FieldConfig(), WholeBodyOptions())
    rotations, origins = (np.ascontiguousarray(v) for v in model.joint_frames(q))
    world = distance.world_segments(core_robot(arrays), rotations, origins)
    out = []
    for l1, l2 in g.self_pairs:
        best = math.inf
        for i in range(g.link_start[l1], g.link_start[l1 + 1]):
            for j in range(g.link_start[l2], g.link_start[l2 + 1]):
                d = distance.segment_segment_distance(world.prim_a[i], world.prim_b[i], world.prim_a[j],
                                                      world.prim_b[j]) - g.prim_r[i] - g.prim_r[j]
                best = min(best, d)
        out.append(best)
    return np.array(out)


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_fitted_self_clearances_are_the_minimum_over_the_primitive_pairs(name: str) -> None:
    arrays = pack_robot(robot(name), FieldConfig(), WholeBodyOptions())
    for q in _configurations(name, 6, 1):
        got = np.asarray(distance.fitted_self_clearances_at(core_robot(arrays), q))
        np.testing.assert_allclose(got, _oracle(name, q), rtol=0.0, atol=1e-12)


def test_fitted_self_clearances_refuse_a_wrong_configuration() -> None:
    arrays = pack_robot(robot("panda"), FieldConfig(), WholeBodyOptions())
    with pytest.raises(ValueError, match="q: expected one value per joint"):
        distance.fitted_self_clearances_at(core_robot(arrays), np.zeros(3))


@pytest.mark.parametrize("name", ["panda", "ur5"])
@pytest.mark.parametrize("fitted", [False, True])
def test_the_state_check_is_the_verdict_of_its_self_model(name: str, fitted: bool) -> None:
    """A state is valid exactly when every link-obstacle pair and every self pair (fitted primitives with the
    flag, covering capsules without) keeps the margin plus its offset; offsets from a random start."""
    model = robot(name)
    arrays = pack_robot(model, FieldConfig(), WholeBodyOptions())
    obstacles = [Obstacle("table", Box(0.6, 0.6, 0.04), Pose((0.45, 0.0, 0.25))),
                 Obstacle("post", Box(0.05, 0.05, 0.5), Pose((0.0, 0.45, 0.3)))]
    qs = _configurations(name, 300, 2)
    scene = make_scene(pack_obstacles(obstacles), arrays, qs[0], 0.002)._replace(fitted_self=fitted)
    checker = core.Checker(core_scene(arrays, scene), MARGIN, 0.02)
    verdicts = set()
    for q in qs:
        obstacle, own = pair_distances(q, arrays, scene)
        expected = bool(np.all(obstacle - scene.obstacle_offsets >= MARGIN) and np.all(own - scene.self_offsets
                                                                                        >= MARGIN))
        assert checker.state_valid(q) == expected
        verdicts.add(expected)
    assert verdicts == {True, False}  # both verdicts were exercised


def test_the_fitted_primitives_clear_ur5_configurations_the_covering_capsules_refuse() -> None:
    """Why the search checks self pairs on the fitted primitives: UR5 configurations whose covering capsules overlap
    (forearm and wrist) while the fitted primitives keep the margin and the exact meshes are clear."""
    model = robot("ur5")
    arrays = pack_robot(model, FieldConfig(), WholeBodyOptions())
    scene = make_scene(None, arrays)
    exact = CollisionChecker(model, [])
    found = 0
    for q in _configurations("ur5", 400, 3):
        covering = pair_distances(q, arrays, scene)[1]
        fitted = pair_distances(q, arrays, scene._replace(fitted_self=True))[1]
        if covering.min() < 0.0 <= MARGIN <= fitted.min() and not exact.check(q).in_collision:
            found += 1
    assert found >= 5


def test_the_goal_band_lets_a_close_goal_pair_go_that_much_deeper() -> None:
    model = robot("panda")
    arrays = pack_robot(model, FieldConfig(), WholeBodyOptions())
    start, goal = np.zeros(model.n_joints), np.array([0.0, 0.6, 0.0, -1.6, 0.0, 2.2, 0.8])
    tip = model.forward_kinematics(goal).position
    obstacles = [Obstacle("block", Box(0.1, 0.1, 0.1), Pose(tip + np.array([0.0, 0.0, -0.07])))]  # 3.5 mm deep
    scene = make_scene(pack_obstacles(obstacles), arrays)
    at_goal = pair_distances(goal, arrays, scene)[0]
    at_start = pair_distances(start, arrays, scene)[0]
    close = (at_goal < MARGIN) & (at_start >= MARGIN)
    assert close.any()
    for band in (0.0, 0.005):
        offsets = endpoint_scene(scene, arrays, (start, goal), MARGIN, 0.005, band).obstacle_offsets
        np.testing.assert_allclose(offsets[close], at_goal[close] - MARGIN - band, rtol=0.0, atol=2e-9)
        assert np.all(offsets[~close & (at_start >= MARGIN)] == 0.0)


def test_the_sampling_window_is_a_turn_over_the_ends_within_the_limits() -> None:
    model = robot("ur5")  # six revolute joints within ±π
    box = (model.lower_limits.copy(), model.upper_limits.copy())
    start = np.array([1.57, -1.57, 0.0, -1.57, -1.57, 3.14])
    goal = np.array([-0.33, -0.48, 1.19, -2.27, -1.57, -0.14])
    lower, upper = sampling_window(model, box, start, [goal], 1.0)
    low, high = np.minimum(start, goal), np.maximum(start, goal)
    pad = np.maximum(0.0, (2 * math.pi - (high - low)) / 2) + 0.5
    np.testing.assert_allclose(lower, np.maximum(box[0], low - pad), rtol=0.0, atol=0.0)
    np.testing.assert_allclose(upper, np.minimum(box[1], high + pad), rtol=0.0, atol=0.0)
    assert np.all(lower <= low) and np.all(upper >= high)  # the ends are inside
    assert lower[1] == box[0][1] and upper[1] == pytest.approx(-0.48 + (2 * math.pi - 1.09) / 2 + 0.5)
    # the Panda's joints turn less than a turn: within π + 0.5 rad of equal ends, all but the far side of joint 6
    panda = robot("panda")
    full = (panda.lower_limits.copy(), panda.upper_limits.copy())
    middle = (full[0] + full[1]) / 2
    lower, upper = sampling_window(panda, full, middle, [middle], 1.0)
    np.testing.assert_array_equal(lower, np.maximum(full[0], middle - math.pi - 0.5))
    np.testing.assert_array_equal(upper, np.minimum(full[1], middle + math.pi + 0.5))
    np.testing.assert_array_equal((lower, upper), full)  # every Panda joint's range is within a turn and a step
