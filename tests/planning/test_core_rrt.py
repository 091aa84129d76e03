"""The compiled global fallback (search, shortcutting, tracking) gives numba's bits, draw for draw.

Until every numba caller has moved, pfield carries two global fallbacks: the numba kernels
(:mod:`pfield.planning._rrt_kernel`, :mod:`pfield.planning._track_kernel`) and the core's port
(``src/core/planning/rrt`` and ``track``), which :mod:`pfield.planning.global_search` now runs. A seed names one
search: the random stream, every state check (so the trees, their node order and the check count), the shortcut's
draws and the tracked motion must come out the same, held equal bit for bit with ``np.array_equal``.

The scenes: the Panda and a URDF robot (the UR5 of MotionBenchMaker) among random obstacles of all six kinds
around the arm, random valid start and goal configurations, the search's endpoint offsets (pairs closer than the
margin at an end); the point space among random obstacles; state checks on random configurations near contact
(every decision level of the capsule test), edges of every length.
"""

from __future__ import annotations

import functools
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from pfield._core import rrt as core
from pfield.field.config import FieldConfig
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, Sphere, pack_obstacles
from pfield.planning import _whole_body_layout as wb
from pfield.planning.cancel import cancel_flag
from pfield.planning.global_search import GlobalOptions, endpoint_scene, track
from pfield.planning.options import PlanOptions
from pfield.planning.status import PlanStatus
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters, make_scene, pack_robot
from pfield.robot import RobotModel
from pfield.spatial import Pose, quaternion_exp

UR5 = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "mbm" / "ur5"
MARGIN = 0.011  # safety_distance + extra_margin, the fallback's defaults


@functools.cache
def _robot(name: str) -> RobotModel:
    if name == "panda":
        return RobotModel.builtin("panda")
    if not (UR5 / "ur5.urdf").exists():
        pytest.skip("the UR5 of ../shared/benchmarks/mbm is not here")
    return RobotModel.from_urdf(UR5 / "ur5.urdf", "ee_link", {"meshes": UR5 / "meshes"}, srdf=UR5 / "ur5.srdf")


@functools.cache
def _arrays(name: str) -> wb.RobotArrays:
    return pack_robot(_robot(name), FieldConfig(), WholeBodyOptions())


@functools.cache
def _meshes() -> tuple[Mesh, ...]:
    torus = trimesh.creation.torus(major_radius=0.08, minor_radius=0.03, major_sections=16, minor_sections=8)
    ball = trimesh.creation.icosphere(subdivisions=1, radius=0.06)
    return (Mesh.from_arrays(torus.vertices, torus.faces, name="torus"),
            Mesh.from_arrays(ball.vertices, ball.faces[: len(ball.faces) // 2], name="open-cap"))


def _shape(rng: np.random.Generator, kind: int) -> Any:
    size = rng.uniform(0.03, 0.12, 3)
    return (Sphere(size[0]), Box(*(2.0 * size)), Capsule(size[0], 2.0 * size[1]), Cylinder(size[0], 2.0 * size[1]),
            Ellipsoid(*size), _meshes()[int(rng.integers(2))])[kind]


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


def _numba_checker(arrays: wb.RobotArrays, scene: wb.Scene, margin: float, resolution: float) -> Any:
    """The numba search's joint-space checker, as global_search built it before the port."""
    from pfield.planning import _rrt_kernel as rrt

    n, caps, obstacles, pairs = len(arrays.parents), len(arrays.cap_joint), len(scene.bounds), len(arrays.self_pairs)
    ws = wb.make_workspace(n, caps, obstacles, pairs, len(arrays.prim_r))
    return rrt.Checker(rrt.JOINT_SPACE, arrays, scene, ws, np.empty((caps, obstacles)), np.empty(pairs),
                       float(margin), float(resolution), np.zeros(1, dtype=np.int64))


def _numba_point_checker(scene: wb.Scene, margin: float, resolution: float) -> Any:
    from pfield.planning import _rrt_kernel as rrt

    f, i = np.zeros, np.zeros
    robot = wb.RobotArrays(i(0, np.int64), f((0, 3, 3)), f((0, 3)), f((0, 3)), i(0, np.int64), i((0, 0), np.int64),
                           -1, np.eye(3), f(3), i(0, np.int64), f((0, 3)), f((0, 3)), f(0), i((0, 2), np.int64),
                           f(0), f(0), f(0), f(0), i(1, np.int64), i(0, np.int64), f((0, 3)), f((0, 3)), f(0), f(0))
    ws = wb.make_workspace(3, 0, len(scene.bounds), 0, 0)
    return rrt.Checker(rrt.POINT_SPACE, robot, scene, ws, np.empty((0, len(scene.bounds))), np.empty(0),
                       float(margin), float(resolution), np.zeros(1, dtype=np.int64))


def _core_checker(arrays: wb.RobotArrays, scene: wb.Scene, margin: float, resolution: float) -> Any:
    robot = core.Robot(*arrays)
    return core.Checker(robot, core.Scene(robot, *scene.packed, scene.centres, scene.bounds, scene.obstacle_offsets,
                                          scene.self_offsets), margin, resolution)


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


def _connect_both(numba_checker: Any, ours: Any, start: np.ndarray, goals: np.ndarray, lower: np.ndarray,
                  upper: np.ndarray, step: float, capacity: int, seed: int, chunks: int) -> tuple[Any, ...]:
    """Both searches in the same chunks, compared chunk by chunk; then both shortcuts."""
    from pfield.planning import _rrt_kernel as rrt

    trees = rrt.make_trees(start, goals, capacity, seed)
    mine = core.Trees(start, goals, capacity, seed)
    assert int(trees.state[1]) == mine.random == core.seeded_state(seed)
    for _ in range(chunks):
        status, path = rrt.rrt_connect(numba_checker, trees, lower, upper, step, 2000)
        our_status, our_path = ours.connect(mine, lower, upper, step, 2000)
        assert our_status.value == status and np.array_equal(our_path, path)
        assert ours.states_checked == numba_checker.counter[0]
        assert mine.counts == tuple(trees.counts) and mine.next == trees.state[0] and mine.random == trees.state[1]
        for t in (0, 1):
            count = trees.counts[t]
            assert np.array_equal(mine.nodes(t), trees.nodes[t, :count])
            assert np.array_equal(mine.parents(t), trees.parents[t, :count])
        if status != rrt.SEARCHING:
            break
    if status != rrt.FOUND:
        return status, None, None
    short = rrt.shortcut(numba_checker, path, 50, trees.state)
    our_short = ours.shortcut(path, 50, mine)
    assert np.array_equal(our_short, short) and mine.random == trees.state[1]
    assert ours.states_checked == numba_checker.counter[0]
    return status, path, short


def test_the_random_stream_is_numbas_draw_for_draw() -> None:
    from pfield.planning import _rrt_kernel as rrt

    for seed in (0, 1, 7, 2**31, 2**63 - 1):  # numba takes int64 seeds
        state = rrt.make_trees(np.zeros(2), np.ones((1, 2)), 2, seed).state
        draws, after = core.uniforms(core.seeded_state(seed), 2000)
        expected = np.array([rrt.uniform(state) for _ in range(2000)])
        assert np.array_equal(draws, expected) and after == state[1]
        assert np.all((draws >= 0.0) & (draws < 1.0))


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_state_and_edge_checks_equal_numba(name: str) -> None:
    """Random configurations, many near contact, decided alike at every level of the capsule test; edges of every
    length checked in the same order (the same count)."""
    from pfield.planning import _rrt_kernel as rrt

    decided = {True: 0, False: 0}
    for seed in range(6):
        problem = Problem(name, 500 + seed, count=12)
        for margin in (0.0, MARGIN, 0.05):
            theirs = _numba_checker(problem.arrays, problem.scene, margin, 0.02)
            ours = _core_checker(problem.arrays, problem.scene, margin, 0.02)
            rng = np.random.default_rng(seed)
            for _ in range(150):
                q = rng.uniform(problem.lower, problem.upper)
                verdict = ours.state_valid(q)
                assert verdict == rrt.state_valid(theirs, q), (name, seed, margin)
                decided[verdict] += 1
            for _ in range(30):
                a = problem.start if rng.uniform() < 0.5 else rng.uniform(problem.lower, problem.upper)
                b = a + rng.normal(scale=rng.choice([0.01, 0.1, 1.0]), size=len(a))
                assert ours.edge_valid(a, b) == rrt.edge_valid(theirs, a, b, np.empty(len(a)))
                assert ours.states_checked == theirs.counter[0]
    assert min(decided.values()) > 200, decided  # the scenes block and clear configurations alike
    # the tracking's overlap test: the capsule test at margin 0 on the raw scene
    from pfield.planning._track_kernel import overlapping_waypoints

    problem = Problem(name, 600, count=12)
    qs = np.random.default_rng(1).uniform(problem.lower, problem.upper, (300, len(problem.start)))
    robot = core.Robot(*problem.arrays)
    raw = problem.raw
    ours = core.overlapping_waypoints(robot, core.Scene(robot, *raw.packed, raw.centres, raw.bounds,
                                                        raw.obstacle_offsets, raw.self_offsets), qs)
    expected = overlapping_waypoints(qs, problem.arrays, raw)
    assert np.array_equal(ours, expected) and 0 < np.count_nonzero(ours) < len(qs)


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_searches_and_shortcuts_equal_numba_draw_for_draw(name: str) -> None:
    found = 0
    for seed in range(5):  # 24 obstacles: searches of hundreds to thousands of nodes over several chunks
        problem = Problem(name, 700 + seed, count=24)
        theirs = _numba_checker(problem.arrays, problem.scene, MARGIN, 0.02)
        ours = _core_checker(problem.arrays, problem.scene, MARGIN, 0.02)
        goals = np.array([problem.goal])
        status, _, _ = _connect_both(theirs, ours, problem.start, goals, problem.lower, problem.upper, 0.5, 4000,
                                     seed, 20)
        found += status == 0
    assert found >= 3, found


def test_a_search_with_several_goals_and_small_trees_equals_numba() -> None:
    """Several goal roots; trees that fill up (EXHAUSTED)."""
    problem = Problem("panda", 800, count=14)
    rng = np.random.default_rng(3)
    from pfield.planning import _rrt_kernel as rrt

    candidates = [problem.goal, *(rng.uniform(problem.lower, problem.upper, (4, len(problem.goal))))]
    ours = _core_checker(problem.arrays, problem.scene, MARGIN, 0.02)
    theirs = _numba_checker(problem.arrays, problem.scene, MARGIN, 0.02)
    verdicts = [(ours.state_valid(g), rrt.state_valid(theirs, g)) for g in candidates]
    assert all(a == b for a, b in verdicts)
    goals = np.array([g for g, (valid, _) in zip(candidates, verdicts, strict=True) if valid])
    statuses = {_connect_both(theirs, ours, problem.start, goals, problem.lower, problem.upper, step, capacity, seed,
                              40)[0] for step, capacity, seed in ((0.3, 40, 11), (1.0, 4000, 12), (0.5, 400, 13))}
    assert 2 in statuses, statuses  # a tree filled up


def test_the_point_search_equals_numba() -> None:
    found = 0
    for seed in range(8):
        rng = np.random.default_rng(900 + seed)
        scene = make_scene(pack_obstacles(_obstacles(rng, 10, np.zeros(3))))
        points: list[np.ndarray] = []
        checker = core.Checker(core.Obstacles(*scene.packed), 0.02, 0.005)
        while len(points) < 2:
            p = rng.uniform(-0.8, 0.8, 3) + np.array([0.0, 0.0, 0.4])
            if checker.state_valid(p):
                points.append(p)
        lower, upper = np.full(3, -1.0), np.full(3, 1.5)
        theirs = _numba_point_checker(scene, 0.02, 0.005)
        ours = core.Checker(core.Obstacles(*scene.packed), 0.02, 0.005)
        status, _, _ = _connect_both(theirs, ours, points[0], points[1][None], lower, upper, 0.1, 3000, seed, 40)
        found += status == 0
    assert found >= 5, found
    # a box "cup" open toward -x around the start, the goal behind its bottom: the trees must leave the cup
    cup = [Obstacle("bottom", Box(0.05, 0.7, 0.7), Pose((0.3, 0.0, 0.0))),
           Obstacle("left", Box(0.55, 0.05, 0.7), Pose((0.05, 0.35, 0.0))),
           Obstacle("right", Box(0.55, 0.05, 0.7), Pose((0.05, -0.35, 0.0))),
           Obstacle("top", Box(0.55, 0.7, 0.05), Pose((0.05, 0.0, 0.35))),
           Obstacle("floor", Box(0.55, 0.7, 0.05), Pose((0.05, 0.0, -0.35)))]
    scene = make_scene(pack_obstacles(cup))
    for seed in range(4):
        theirs = _numba_point_checker(scene, 0.02, 0.005)
        ours = core.Checker(core.Obstacles(*scene.packed), 0.02, 0.005)
        status, path, _ = _connect_both(theirs, ours, np.zeros(3), np.array([[0.8, 0.0, 0.0]]), np.full(3, -1.5),
                                        np.full(3, 1.8), 0.1, 5000, seed, 40)
        assert status == 0 and len(path) > 10


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_tracked_paths_equal_numba_bit_for_bit(name: str) -> None:
    from pfield.planning._track_kernel import track_path

    config = FieldConfig()
    params = kernel_parameters(config, PlanOptions(dt=0.02).resolved(config), WholeBodyOptions())
    options = GlobalOptions()
    statuses = set()
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
            expected = track_path(path[0].copy(), path, problem.arrays, problem.scene, np.array(goal.position),
                                  np.array(goal.orientation), params, max_iterations, options.tracking_gain,
                                  options.tracking_lead, flag.copy())
            loop = track(problem.robot, problem.arrays, problem.scene, path, goal, params, max_iterations, options,
                         flag)
            assert loop[0] == expected[0] and loop[1] == expected[1], (name, seed, loop[0], expected[0])
            for a, b in zip(loop[2:], expected[2:], strict=True):
                assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True), (name, seed)
            statuses.add(PlanStatus(loop[0]))
    assert {PlanStatus.REACHED, PlanStatus.ITERATION_LIMIT, PlanStatus.CANCELLED} <= statuses, statuses


def test_tracking_a_lagging_joint_equals_numba() -> None:
    """test_global_search's lagging joint (the pull capped at the braking speed, a joint-limited acceleration) on the
    core: the same motion as numba's, step for step."""
    from pfield.planning._track_kernel import track_path

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
    expected = track_path(lagging, np.stack([start, start]), arrays, scene, np.array(unreachable.position),
                          np.array(unreachable.orientation), params, 1500, options.tracking_gain,
                          options.tracking_lead, np.zeros(1, dtype=np.uint8))
    # the numba call starts at `lagging` with the waypoints (start, start); the same through the core
    robot = core.Robot(*arrays)
    where = core.Scene(robot, *scene.packed, scene.centres, scene.bounds, scene.obstacle_offsets, scene.self_offsets)
    n, total = len(start), 1501
    outputs = (np.empty((total, n)), np.empty((total, n)), np.empty((total, 3)), np.empty((total, 4)),
               np.empty((total, 6)), np.empty(total))
    result = core.track_path(robot, where, lagging, np.stack([start, start]), np.array(unreachable.position),
                             np.array(unreachable.orientation), params, 1500, options.tracking_gain,
                             options.tracking_lead, np.zeros(1, dtype=np.uint8), *outputs)
    assert (result.status, result.count) == (expected[0], expected[1])
    for ours, theirs in zip(outputs, expected[2:8], strict=True):
        assert np.array_equal(ours[:result.count], theirs)


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
    robot = core.Robot(*_arrays("panda"))
    with pytest.raises(ValueError, match="obstacle_offsets"):
        core.Scene(robot, *problem.scene.packed, problem.scene.centres, problem.scene.bounds,
                   np.zeros((1, 1)), problem.scene.self_offsets)
