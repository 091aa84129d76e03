"""The compiled global fallback (``src/core/planning/rrt`` and ``track``): numba's draws and bits, and what a search
must be.

:mod:`pfield.planning.global_search` runs this core; it replaced numba kernels (``_rrt_kernel``, ``_track_kernel``,
issue 32) draw for draw: a seed names one search, and the random stream, every state check (so the trees, their
node order and the check count), the shortcut's draws and the tracked motion came out the same bits. Those kernels
are gone; what they computed stays here as digests (the first 16 hex digits of the sha256 of every output, per
seeded case), computed from the core's outputs after the core was checked equal to numba's kernels on exactly these
cases (``np.array_equal``, chunk by chunk): they are numba's results. Beside them, oracles that need no numba: the
random stream written out in Python integers, every state check against the link model's exact clearances, every
edge check against its interpolated states, the trees' and paths' invariants (each node within a step of its
parent, every path edge valid for a fresh checker, a shortcut a shorter subsequence), the tracking's integration.

The scenes: the Panda and a URDF robot (the UR5 of MotionBenchMaker) among random obstacles of all six kinds
around the arm, random valid start and goal configurations, the search's endpoint offsets (pairs closer than the
margin at an end); the point space among random obstacles; state checks on random configurations near contact
(every decision level of the capsule test), edges of every length.
"""

from __future__ import annotations

import functools
import itertools
import math
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from core_scenes import random_shape, robot
from digests import digest
from pfield._core import robot as bound
from pfield._core import rrt as core
from pfield.field.config import FieldConfig
from pfield.geometry import Box, Obstacle, pack_obstacles, signed_distances
from pfield.planning import _whole_body_layout as wb
from pfield.planning._whole_body_core import core_obstacles, core_robot, core_scene, pair_distances
from pfield.planning.cancel import cancel_flag
from pfield.planning.global_search import GlobalOptions, endpoint_scene, track
from pfield.planning.options import PlanOptions
from pfield.planning.status import PlanStatus
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters, make_scene, pack_robot
from pfield.robot import RobotModel
from pfield.spatial import Pose, quaternion_exp

MARGIN = 0.011  # safety_distance + extra_margin, the fallback's defaults
MASK = 2**64 - 1


_robot = robot


@functools.cache
def _arrays(name: str) -> wb.RobotArrays:
    return pack_robot(_robot(name), FieldConfig(), WholeBodyOptions())



def _shape(rng: np.random.Generator, kind: int) -> Any:
    return random_shape(rng, kind, 0.03)


def _obstacles(rng: np.random.Generator, count: int, base: np.ndarray) -> list[Obstacle]:
    """``count`` obstacles, every kind in turn, at random in a 1.4 m box around the arm's base, turned at random."""
    obstacles = []
    for k in range(count):
        centre = base + rng.uniform((-0.7, -0.7, -0.1), (0.7, 0.7, 1.0))
        orientation = Pose(orientation=quaternion_exp(rng.uniform(-2.0, 2.0, 3))).orientation
        obstacles.append(Obstacle(f"o{k}", _shape(rng, k % 6), Pose(centre, orientation)))
    return obstacles


def _box(robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    lower = np.where(np.isfinite(robot.lower_limits), robot.lower_limits, -np.pi)
    upper = np.where(np.isfinite(robot.upper_limits), robot.upper_limits, np.pi)
    return np.ascontiguousarray(lower, dtype=np.float64), np.ascontiguousarray(upper, dtype=np.float64)


def _core_checker(arrays: wb.RobotArrays, scene: wb.Scene, margin: float, resolution: float) -> Any:
    return core.Checker(core_scene(arrays, scene), margin, resolution)


class Problem:
    """One robot among random obstacles, a valid start and goal, and the search scene with their offsets."""

    def __init__(self, name: str, seed: int, count: int = 8) -> None:
        rng = np.random.default_rng(seed)
        self.robot, self.arrays = _robot(name), _arrays(name)
        self.lower, self.upper = _box(self.robot)
        base = self.robot.joint_frames(np.clip(0.0, self.lower, self.upper))[1][0]
        self.raw = make_scene(pack_obstacles(_obstacles(rng, count, base)), self.arrays)
        ends = []
        while len(ends) < 2:  # ends whose capsules keep the margin up to the endpoint band (start) or at most
            q = rng.uniform(self.lower, self.upper)  # a few mm into it (goal): the search's offsets then matter
            trial = endpoint_scene(self.raw, self.arrays, (q,), MARGIN, 0.005)
            if np.min(trial.obstacle_offsets, initial=0.0) > -0.02 and np.min(trial.self_offsets, initial=0.0) > -0.02:
                ends.append(q)
        self.start, self.goal = ends
        self.scene = endpoint_scene(self.raw, self.arrays, (self.start, self.goal), MARGIN, 0.005)
        self.rng = rng


def _digest(values: Iterator[Any]) -> str:
    """The first 16 hex digits of :func:`digests.digest`."""
    return digest(values)[:16]


# ---- the random stream ------------------------------------------------------------------------------------------

def _splitmix64(seed: int) -> int:
    """The search's seeding (Steele, Lea & Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014):
    splitmix64's first output for ``seed`` (its int64 bits), 1 if that is 0 (a xorshift state must not be)."""
    z = (seed + 0x9E3779B97F4A7C15) & MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    z ^= z >> 31
    return z or 1


def _xorshift64_star(state: int, count: int) -> tuple[list[float], int]:
    """``count`` numbers in [0, 1) of xorshift64* (Vigna, "An experimental exploration of Marsaglia's xorshift
    generators, scrambled", ACM TOMS 2016) and the state after them: the state shifted by 12, 25 and 27, the top 53
    bits of its product with 0x2545F4914F6CDD1D over 2^53."""
    draws = []
    for _ in range(count):
        state ^= state >> 12
        state ^= (state << 25) & MASK
        state ^= state >> 27
        draws.append((((state * 0x2545F4914F6CDD1D) & MASK) >> 11) / 9007199254740992.0)
    return draws, state


def test_the_random_stream_is_xorshift64_star_seeded_by_splitmix64() -> None:
    """Numba's stream was this generator, and the core's equalled it draw for draw on these seeds."""
    for seed in (0, 1, 7, 2**31, 2**63 - 1):  # int64 seeds
        state = core.seeded_state(seed)
        assert state == _splitmix64(seed)
        draws, after = core.uniforms(state, 2000)
        expected, expected_after = _xorshift64_star(state, 2000)
        assert draws.tolist() == expected and after == expected_after
        assert np.all((draws >= 0.0) & (draws < 1.0))


# ---- state and edge checks --------------------------------------------------------------------------------------

def _slack(arrays: wb.RobotArrays, scene: wb.Scene, q: np.ndarray) -> float:
    """The smallest link-model clearance at q less its offset (exact: every pair measured to the fitted level)."""
    obstacle, own = pair_distances(q, arrays, scene)
    return float(min(np.min(obstacle - scene.obstacle_offsets, initial=math.inf),
                     np.min(own - scene.self_offsets, initial=math.inf)))


def _interpolated(a: np.ndarray, b: np.ndarray, resolution: float) -> list[np.ndarray]:
    """The states an edge check visits (a excluded), no coordinate moving more than ``resolution`` between two."""
    steps = max(1, math.ceil(float(np.max(np.abs(b - a))) / resolution))
    return [a + (i / steps) * (b - a) for i in range(1, steps + 1)]


class Check:
    """One state check (``b`` None) or edge check of a checker, its verdict and the states checked after it."""

    def __init__(self, checker: Any, problem: Problem, margin: float, a: np.ndarray, b: np.ndarray | None) -> None:
        self.problem, self.margin, self.a, self.b = problem, margin, a, b
        self.before = checker.states_checked
        self.verdict = bool(checker.state_valid(a) if b is None else checker.edge_valid(a, b))
        self.after = checker.states_checked


def _checks(name: str, seed: int) -> Iterator[Check]:
    """150 random states and 30 random edges (from the start or anywhere, of every length) of one problem, at
    three margins."""
    problem = Problem(name, 500 + seed, count=12)
    for margin in (0.0, MARGIN, 0.05):
        ours = _core_checker(problem.arrays, problem.scene, margin, 0.02)
        rng = np.random.default_rng(seed)
        for _ in range(150):
            yield Check(ours, problem, margin, rng.uniform(problem.lower, problem.upper), None)
        for _ in range(30):
            a = problem.start if rng.uniform() < 0.5 else rng.uniform(problem.lower, problem.upper)
            yield Check(ours, problem, margin, a, a + rng.normal(scale=rng.choice([0.01, 0.1, 1.0]), size=len(a)))


def _check_digest(name: str) -> str:
    return _digest(value for seed in range(6) for check in _checks(name, seed)
                   for value in (np.bool_(check.verdict), np.int64(check.after)))


def _overlaps(name: str) -> tuple[Problem, np.ndarray, np.ndarray]:
    """The tracking's overlap test (the capsule test at margin 0 on the raw scene) on 300 random configurations."""
    problem = Problem(name, 600, count=12)
    qs = np.random.default_rng(1).uniform(problem.lower, problem.upper, (300, len(problem.start)))
    return problem, qs, core.overlapping_waypoints(core_scene(problem.arrays, problem.raw), qs)


# numba's state_valid and edge_valid (pfield.planning._rrt_kernel) on _checks' cases, every verdict and the count of
# states checked after it, digested (_check_digest) per robot after the core was checked equal to them on each;
# numba's overlapping_waypoints (pfield.planning._track_kernel) on _overlaps' configurations
CHECK_DIGESTS = {"panda": "b1fd3ccb4cf2aa5c", "ur5": "bc5da7989e5339f1"}
OVERLAP_DIGESTS = {"panda": "58e45b0f6cccd1d8", "ur5": "360a574222a83a77"}


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_state_and_edge_checks_are_numbas_and_the_link_models(name: str) -> None:
    """Random configurations, many near contact, decided as the link model's exact clearances decide them (at every
    level of the capsule test); edges valid exactly when their interpolated states are (a valid one checks each)."""
    decided = {True: 0, False: 0}
    for seed in range(6):
        for check in _checks(name, seed):
            problem = check.problem
            if check.b is None:
                slack = _slack(problem.arrays, problem.scene, check.a) - check.margin
                assert check.verdict == (slack >= 0.0) or abs(slack) < 1e-12, (seed, check.margin, slack)
                assert check.after == check.before + 1
                decided[check.verdict] += 1
                continue
            states = _interpolated(check.a, check.b, 0.02)
            fresh = _core_checker(problem.arrays, problem.scene, check.margin, 0.02)
            assert check.verdict == all(fresh.state_valid(q) for q in states)
            assert check.before < check.after <= check.before + len(states)
            assert not check.verdict or check.after == check.before + len(states)
    assert min(decided.values()) > 200, decided  # the scenes block and clear configurations alike
    assert _check_digest(name) == CHECK_DIGESTS[name]
    problem, qs, overlapping = _overlaps(name)
    assert overlapping.tolist() == [_slack(problem.arrays, problem.raw, q) < 0.0 for q in qs]
    assert 0 < np.count_nonzero(overlapping) < len(qs)
    assert _digest(iter([overlapping])) == OVERLAP_DIGESTS[name]


# ---- searches and shortcuts -------------------------------------------------------------------------------------

class Search:
    """One search in chunks of 2000 state checks (at most ``chunks``), then 50 shortcut attempts if it found a path;
    ``record`` holds every output: per chunk the status, path, count of states checked, tree sizes, the tree to
    extend next and the random state; then both trees; then the shortcut, the random state and the count."""

    def __init__(self, checker: Any, start: np.ndarray, goals: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                 step: float, capacity: int, seed: int, chunks: int) -> None:
        self.checker, self.step, self.lower, self.upper = checker, step, lower, upper
        trees = self.trees = core.Trees(start, goals, capacity, seed)
        assert trees.random == core.seeded_state(seed) and trees.counts == (1, len(goals))
        record: list[Any] = []
        status, path = core.SearchStatus.SEARCHING, np.empty((0, len(start)))
        for _ in range(chunks):
            status, path = checker.connect(trees, lower, upper, step, 2000)
            record += [np.int64(status.value), path, np.int64(checker.states_checked), np.array(trees.counts),
                       np.int64(trees.next), np.uint64(trees.random)]
            if status != core.SearchStatus.SEARCHING:
                break
        record += [value for t in (0, 1) for value in (trees.nodes(t), trees.parents(t))]
        self.status, self.path, self.short = status, path, None
        if status == core.SearchStatus.FOUND:
            self.short = checker.shortcut(path, 50, trees)
            record += [self.short, np.uint64(trees.random), np.int64(checker.states_checked)]
        self.record = record

    def check(self, fresh: Any) -> None:
        """The trees' and paths' invariants; ``fresh`` a new checker of the same scene."""
        for t in (0, 1):
            nodes, parents = self.trees.nodes(t), self.trees.parents(t)
            roots = parents < 0
            assert np.all(parents[~roots] < np.flatnonzero(~roots)) and np.all(parents[roots] == -1)
            steps = np.linalg.norm(nodes[~roots] - nodes[parents[~roots]], axis=1)
            assert np.all(steps <= self.step * (1 + 1e-12))
            assert np.all(nodes >= self.lower - 1e-12) and np.all(nodes <= self.upper + 1e-12)
        if self.status != core.SearchStatus.FOUND:
            return
        path, short = self.path, self.short
        assert short is not None
        assert np.array_equal(path[0], self.trees.nodes(0)[0]) and np.array_equal(short[0], path[0])
        assert np.array_equal(short[-1], path[-1])
        assert any(np.array_equal(path[-1], goal) for goal in self.trees.nodes(1)[self.trees.parents(1) < 0])
        assert np.all(np.linalg.norm(np.diff(path, axis=0), axis=1) <= self.step * (1 + 1e-12))
        rows = [next(k for k, row in enumerate(path) if np.array_equal(row, vertex)) for vertex in short]
        assert rows == sorted(rows) and len(short) <= len(path)  # a subsequence of the path's vertices
        length = float(np.sum(np.linalg.norm(np.diff(short, axis=0), axis=1)))
        assert length <= float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))) + 1e-12
        for a, b in itertools.pairwise(short):
            assert fresh.edge_valid(a, b)
        for a, b in itertools.pairwise(path):
            assert fresh.edge_valid(a, b)


def _joint_searches(name: str) -> Iterator[tuple[Problem, Search]]:
    """Five searches among 24 obstacles: hundreds to thousands of nodes over several chunks."""
    for seed in range(5):
        problem = Problem(name, 700 + seed, count=24)
        ours = _core_checker(problem.arrays, problem.scene, MARGIN, 0.02)
        yield problem, Search(ours, problem.start, np.array([problem.goal]), problem.lower, problem.upper, 0.5, 4000,
                              seed, 20)


# numba's rrt_connect and shortcut (pfield.planning._rrt_kernel) on _joint_searches' cases, Search.record digested
# per seed after the core was checked equal to them chunk by chunk
SEARCH_DIGESTS = {
    "panda": {0: "8eb062fa51f7e3e1", 1: "2fe320072b52f1e5", 2: "e179d4558aeb1a61", 3: "5f0768f59f0c90cd",
              4: "0be584e7895ff936"},
    "ur5": {0: "7720703b6359b28a", 1: "65d94b0e9495f41c", 2: "96e698b90a62b6c4", 3: "a3244766d0e9727e",
            4: "fad0855f1ac996a0"},
}


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_searches_and_shortcuts_are_numbas(name: str) -> None:
    found, digests = 0, {}
    for seed, (problem, search) in enumerate(_joint_searches(name)):
        search.check(_core_checker(problem.arrays, problem.scene, MARGIN, 0.02))
        found += search.status == core.SearchStatus.FOUND
        digests[seed] = _digest(iter(search.record))
    assert found >= 3, found
    assert digests == SEARCH_DIGESTS[name]


def _several_goals() -> Iterator[tuple[Problem, Search]]:
    """Several goal roots (those of five candidates that are valid); trees that fill up (EXHAUSTED)."""
    problem = Problem("panda", 800, count=14)
    rng = np.random.default_rng(3)
    candidates = [problem.goal, *(rng.uniform(problem.lower, problem.upper, (4, len(problem.goal))))]
    ours = _core_checker(problem.arrays, problem.scene, MARGIN, 0.02)
    goals = np.array([g for g in candidates if ours.state_valid(g)])
    for step, capacity, seed in ((0.3, 40, 11), (1.0, 4000, 12), (0.5, 400, 13)):
        yield problem, Search(ours, problem.start, goals, problem.lower, problem.upper, step, capacity, seed, 40)


# numba's searches on _several_goals' cases (Search.record), digested after the core was checked equal to them
SEVERAL_GOALS_DIGEST = "5cac0f8544fedef9"


def test_a_search_with_several_goals_and_small_trees_is_numbas() -> None:
    statuses, record = set(), []
    for problem, search in _several_goals():
        assert np.count_nonzero(search.trees.parents(1) < 0) >= 2  # several goal roots
        search.check(_core_checker(problem.arrays, problem.scene, MARGIN, 0.02))
        statuses.add(search.status)
        record += search.record
    assert core.SearchStatus.EXHAUSTED in statuses, statuses  # a tree filled up
    assert _digest(iter(record)) == SEVERAL_GOALS_DIGEST


CUP = [Obstacle("bottom", Box(0.05, 0.7, 0.7), Pose((0.3, 0.0, 0.0))),
       Obstacle("left", Box(0.55, 0.05, 0.7), Pose((0.05, 0.35, 0.0))),
       Obstacle("right", Box(0.55, 0.05, 0.7), Pose((0.05, -0.35, 0.0))),
       Obstacle("top", Box(0.55, 0.7, 0.05), Pose((0.05, 0.0, 0.35))),
       Obstacle("floor", Box(0.55, 0.7, 0.05), Pose((0.05, 0.0, -0.35)))]
"""A box "cup" open toward -x around the start, the goal behind its bottom: the trees must leave the cup."""


def _point_searches() -> Iterator[tuple[wb.Scene, Search]]:
    """Eight searches among 10 random obstacles, four out of the cup."""
    for seed in range(8):
        rng = np.random.default_rng(900 + seed)
        scene = make_scene(pack_obstacles(_obstacles(rng, 10, np.zeros(3))))
        points: list[np.ndarray] = []
        checker = core.Checker(core_obstacles(scene), 0.02, 0.005)
        while len(points) < 2:
            p = rng.uniform(-0.8, 0.8, 3) + np.array([0.0, 0.0, 0.4])
            if checker.state_valid(p):
                points.append(p)
        lower, upper = np.full(3, -1.0), np.full(3, 1.5)
        ours = core.Checker(core_obstacles(scene), 0.02, 0.005)
        yield scene, Search(ours, points[0], points[1][None], lower, upper, 0.1, 3000, seed, 40)
    scene = make_scene(pack_obstacles(CUP))
    for seed in range(4):
        ours = core.Checker(core_obstacles(scene), 0.02, 0.005)
        yield scene, Search(ours, np.zeros(3), np.array([[0.8, 0.0, 0.0]]), np.full(3, -1.5), np.full(3, 1.8), 0.1,
                            5000, seed, 40)


# numba's point-space searches (pfield.planning._rrt_kernel, POINT_SPACE) on _point_searches' cases, Search.record
# digested per case after the core was checked equal to them chunk by chunk
POINT_DIGESTS = {0: "5d6c09f3e47ee9bf", 1: "4e5ba54bf26f6545", 2: "e562df8906086b1f", 3: "31e21ecff0b9c6d0",
                 4: "90ff87500a7e93b8", 5: "271f79837a77f018", 6: "56ae478daea118d2", 7: "5ca07dbcd2535553",
                 8: "f2fa98078895ee15", 9: "9544ced103fd20cb", 10: "59dff101a2aba478", 11: "7657cc02b3a863ed"}


def test_the_point_searches_are_numbas() -> None:
    """A point state is valid when its signed distance to every obstacle is at least the margin."""
    found, digests = 0, {}
    for k, (scene, search) in enumerate(_point_searches()):
        fresh = core.Checker(core_obstacles(scene), 0.02, 0.005)
        search.check(fresh)
        nodes = search.trees.nodes(0)
        assert np.array_equal([fresh.state_valid(p) for p in nodes],
                              signed_distances(scene.packed, nodes)[0].min(axis=1) >= 0.02)
        found += search.status == core.SearchStatus.FOUND
        if k >= 8:  # out of the cup
            assert search.status == core.SearchStatus.FOUND and search.path is not None and len(search.path) > 10
        digests[k] = _digest(iter(search.record))
    assert found >= 5 + 4, found
    assert digests == POINT_DIGESTS


# ---- tracking ---------------------------------------------------------------------------------------------------

def _tracked(name: str) -> Iterator[tuple[Problem, np.ndarray, np.ndarray, tuple[Any, ...]]]:
    """(problem, path, params, outputs) of the tracking of a searched path (a straight line when none was found)
    for 3000 and 40 steps, and cancelled at once."""
    config = FieldConfig()
    params = kernel_parameters(config, PlanOptions(dt=0.02).resolved(config), WholeBodyOptions())
    options = GlobalOptions()
    for seed in range(4):
        problem = Problem(name, 1000 + seed)
        ours = _core_checker(problem.arrays, problem.scene, MARGIN, 0.02)
        trees = core.Trees(problem.start, problem.goal[None], 4000, seed)
        status = core.SearchStatus.SEARCHING
        for _ in range(40):
            status, path = ours.connect(trees, problem.lower, problem.upper, 1.0, 2000)
            if status != core.SearchStatus.SEARCHING:
                break
        if status != core.SearchStatus.FOUND:
            path = np.array([problem.start, problem.goal])  # a straight line: the dampers hold it off
        path = ours.shortcut(path, 50, trees)
        goal = problem.robot.forward_kinematics(path[-1])
        for max_iterations, cancelled in ((3000, False), (40, False), (3000, True)):
            flag = cancel_flag(None)
            flag[0] = cancelled
            yield problem, path, params, track(problem.robot, problem.arrays, problem.scene, path, goal, params,
                                               max_iterations, options, flag)


def _track_digest(outputs: tuple[Any, ...]) -> str:
    return _digest(np.int64(value) if k < 2 else value for k, value in enumerate(outputs))


def _check_track(robot: RobotModel, start: np.ndarray, dt: float, outputs: tuple[Any, ...]) -> None:
    """Each waypoint is the last plus its q̇ dt clipped into the limits, from the start; poses are the kinematics'."""
    _, count, qs, qds, positions = outputs[:5]
    assert len(qs) == count >= 1 and np.array_equal(qs[0], start)
    assert np.array_equal(qs[1:], np.minimum(np.maximum(qs[:-1] + qds[:-1] * dt, robot.lower_limits),
                                             robot.upper_limits))
    for k in range(0, count, 100):
        np.testing.assert_allclose(positions[k], robot.forward_kinematics(qs[k]).position, rtol=0, atol=1e-12)


# numba's track_path (pfield.planning._track_kernel) on _tracked's cases, digested in order after the core's tracking
# was checked equal to it bit for bit, output for output
TRACK_DIGESTS = {
    "panda": ["48fff81c640cecb1", "ddd4bf651bfac21b", "4ce78cc99c4204f9", "4ec9ad28b1c4289b", "01b1b1501c45e74e",
              "8f599ab9e4f8c8a1", "9b5c0e23317b5b54", "1967b9e4378d5aed", "8a1d0d03113667e3", "b0fa35d8674fc3df",
              "65d930d1e52c651c", "4b0aa0c4c28420cd"],
    "ur5": ["d752744dbff35091", "1739681f82a6e775", "3e669649bb08c455", "8f62823842f4a643", "01435a0945d111e9",
            "c0bef4e4f942371f", "cd29b22d79192605", "3ae0d4167da3ed47", "7c1c126a52add154", "50f4117b565495d1",
            "3f213230b686d869", "b30bbeee9b4dae08"],
}


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_tracked_paths_are_numbas(name: str) -> None:
    statuses, digests = set(), []
    for problem, path, params, outputs in _tracked(name):
        _check_track(problem.robot, path[0], params[wb.DT], outputs)
        statuses.add(PlanStatus(outputs[0]))
        digests.append(_track_digest(outputs))
    assert {PlanStatus.REACHED, PlanStatus.ITERATION_LIMIT, PlanStatus.CANCELLED} <= statuses, statuses
    assert digests == TRACK_DIGESTS[name]


def _lagging() -> tuple[RobotModel, np.ndarray, np.ndarray, tuple[Any, ...]]:
    """test_global_search's lagging joint (the pull capped at the braking speed, a joint-limited acceleration): the
    xArm7 1.5 rad behind its target on the base joint, toward an unreachable pose."""
    xarm = RobotModel.builtin("xarm7")
    start = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
    config = FieldConfig(max_angular_acceleration=1.0)
    arrays = pack_robot(xarm, config, WholeBodyOptions())
    scene = make_scene(pack_obstacles([]), arrays, start, config.safety_distance)
    lagging = start.copy()
    lagging[0] += 1.5
    unreachable = Pose((3.0, 0.0, 0.0))
    params = kernel_parameters(config, PlanOptions(dt=0.01).resolved(config), WholeBodyOptions())
    options = GlobalOptions()
    n, total = len(start), 1501
    outputs = (np.empty((total, n)), np.empty((total, n)), np.empty((total, 3)), np.empty((total, 4)),
               np.empty((total, 6)), np.empty(total))
    result = core.track_path(core_scene(arrays, scene), lagging, np.stack([start, start]),
                             np.array(unreachable.position), np.array(unreachable.orientation), params, 1500,
                             options.tracking_gain, options.tracking_lead, np.zeros(1, dtype=np.uint8), *outputs)
    count = result.count
    return xarm, lagging, params, (result.status, count, *(out[:count] for out in outputs))


# numba's track_path on _lagging's case (status, count, then every output), digested after the core's was checked
# equal to it step for step
LAGGING_DIGEST = "d6dffa53dd8a98ea"


def test_tracking_a_lagging_joint_is_numbas() -> None:
    xarm, lagging, params, outputs = _lagging()
    _check_track(xarm, lagging, params[wb.DT], outputs)
    assert PlanStatus(outputs[0]) in (PlanStatus.STAGNATION, PlanStatus.ITERATION_LIMIT)
    assert _track_digest(outputs) == LAGGING_DIGEST


def test_a_tracking_held_still_by_the_dampers_ends_in_stagnation_after_the_window() -> None:
    """The Panda's base turning 1.5 rad along a straight path through a wall: the dampers stop the arm at the wall
    and the target waits for it. The tracking ends STAGNATION once neither the target nor the arm moved (by the
    stagnation progress) for the field's stagnation window, not at the iteration limit."""
    panda = RobotModel.builtin("panda")
    start = np.array([0.0, -0.4, 0.0, -2.0, 0.0, 1.6, 0.8])
    goal_q = start.copy()
    goal_q[0] = 1.5
    config = FieldConfig()
    wall = Obstacle("wall", Box(0.6, 0.05, 1.6), Pose((0.45, 0.3, 0.5)))
    arrays = pack_robot(panda, config, WholeBodyOptions())
    scene = make_scene(pack_obstacles([wall]), arrays, start, config.safety_distance)
    params = kernel_parameters(config, PlanOptions(dt=0.02).resolved(config), WholeBodyOptions())
    window, progress = int(params[wb.STAG_STEPS]), params[wb.STAG_PROGRESS]
    loop = track(panda, arrays, scene, np.array([start, goal_q]), panda.forward_kinematics(goal_q), params, 20000,
                 GlobalOptions())
    status, count, qs = loop[:3]
    _check_track(panda, start, params[wb.DT], loop)
    assert PlanStatus(status) == PlanStatus.STAGNATION and count < 20000  # not the iteration limit
    assert 0.1 < qs[-1][0] < 1.0  # held at the wall, short of the goal's 1.5 rad
    assert np.max(np.abs(qs[-window - 1:] - qs[-window - 1])) < progress  # still for the whole window
    assert loop[7][-1] >= config.safety_distance - 1e-6  # and kept its clearance there


def test_the_tracking_releases_the_gil_and_reads_the_cancel_flag() -> None:
    """A tracking that could run for seconds (an unreachable goal pose, no settling) ends CANCELLED soon after another
    thread sets the flag: it ran without the GIL and read the flag every step."""
    problem = Problem("panda", 1100)
    config = FieldConfig()
    params = kernel_parameters(config, PlanOptions(dt=0.02).resolved(config), WholeBodyOptions())
    path = np.array([problem.start, problem.start])
    flag = cancel_flag(None)
    ticks = []

    def cancel_soon() -> None:
        for _ in range(5):
            ticks.append(time.perf_counter())  # runs while the tracking holds no GIL
            time.sleep(0.01)
        flag[0] = 1

    thread = threading.Thread(target=cancel_soon)
    begin = time.perf_counter()
    thread.start()
    loop = track(problem.robot, problem.arrays, problem.scene, path, Pose((5.0, 0.0, 0.0)), params, 10**7,
                 GlobalOptions(), flag)
    thread.join()
    assert loop[0] == PlanStatus.CANCELLED and len(ticks) == 5
    assert time.perf_counter() - begin < 5.0


def test_a_search_reads_the_cancel_flag_every_iteration() -> None:
    problem = Problem("panda", 1200)
    ours = _core_checker(problem.arrays, problem.scene, MARGIN, 0.02)
    trees = core.Trees(problem.start, problem.goal[None], 4000, 0)
    status, path = ours.connect(trees, problem.lower, problem.upper, 1.0, 10**9, np.ones(1, dtype=np.uint8))
    assert status == core.SearchStatus.SEARCHING and path.shape == (0, len(problem.start))
    assert ours.states_checked == 0 and trees.counts == (1, 1)


def test_the_bindings_refuse_mismatched_inputs() -> None:
    problem = Problem("panda", 1300, count=3)
    ours = _core_checker(problem.arrays, problem.scene, MARGIN, 0.02)
    with pytest.raises(ValueError, match="dimension"):
        ours.state_valid(np.zeros(3))
    with pytest.raises(ValueError, match="capacity"):
        core.Trees(problem.start, np.array([problem.goal] * 3), 2, 0)
    trees = core.Trees(np.zeros(3), np.ones((1, 3)), 10, 0)
    with pytest.raises(ValueError, match="another state space"):
        ours.connect(trees, problem.lower, problem.upper, 1.0, 10)
    with pytest.raises(ValueError, match="obstacle_offsets"):
        bound.Scene(core_robot(_arrays("panda")), core_obstacles(problem.scene), np.zeros((1, 1)),
                    problem.scene.self_offsets)
