"""The compiled whole-body step, loop and stepper give numba's bits.

The planner, :class:`~pfield.planning.WholeBodyStepper` and the core's later ports (the tracking, the RRT, the
assistance) run ``src/core/planning/whole_body``; the numba kernels it replaces (``pfield.planning``'s
``_whole_body_kernel``, ``_whole_body_loop``, ``_whole_body_flat``) stay as its twins while numba kernels still
inline them. Every exact figure the test suite holds for a whole-body plan carried over only because the two agree in
the last digit, so every number of a step (its row: twist, pose, clearances, goal errors, nearest pairs, and q̇), its
damper-row count, and every output of a plan (status, count, waypoints, velocities, poses, twists, clearances,
culprit) is held equal bit for bit.

The scenes aim at every branch: the Panda and a URDF robot (the UR5 with its gripper) among random obstacles of all
six kinds placed at random distances from random links (pairs beyond Q, within it, within d_s and in contact: start
offsets, the capsule and fitted levels, damper rows, the null-space push), random previous velocities (the rate
limit, kept or dropped), configurations at the joint limits (their dampers), random parameters.
"""

from __future__ import annotations

import functools
import math
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from pfield import safety
from pfield._core import whole_body as core
from pfield.field.config import FieldConfig
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, Sphere, pack_obstacles
from pfield.planning import _whole_body_layout as wb
from pfield.planning._whole_body_core import plan_loop, planner
from pfield.planning.cancel import cancel_flag
from pfield.planning.options import PlanOptions
from pfield.planning.status import PlanStatus
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters, make_scene, pack_robot
from pfield.robot import RobotModel
from pfield.robot._kinematics import joint_transforms
from pfield.robot.model import LIMIT_TOLERANCE
from pfield.spatial import Pose, quaternion_exp

UR5 = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "mbm" / "ur5"


@functools.cache
def _robot(name: str) -> RobotModel:
    if name == "panda":
        return RobotModel.builtin("panda")
    if not (UR5 / "ur5.urdf").exists():
        pytest.skip("the UR5 of ../shared/benchmarks/mbm is not here")
    return RobotModel.from_urdf(UR5 / "ur5.urdf", "ee_link", {"meshes": UR5 / "meshes"}, srdf=UR5 / "ur5.srdf")


@functools.cache
def _meshes() -> tuple[Mesh, ...]:
    torus = trimesh.creation.torus(major_radius=0.08, minor_radius=0.03, major_sections=16, minor_sections=8)
    ball = trimesh.creation.icosphere(subdivisions=1, radius=0.06)
    return (Mesh.from_arrays(torus.vertices, torus.faces, name="torus"),
            Mesh.from_arrays(ball.vertices, ball.faces[: len(ball.faces) // 2], name="open-cap"))


def _shape(rng: np.random.Generator, kind: int) -> Any:
    size = rng.uniform(0.02, 0.12, 3)
    return (Sphere(size[0]), Box(*(2.0 * size)), Capsule(size[0], 2.0 * size[1]), Cylinder(size[0], 2.0 * size[1]),
            Ellipsoid(*size), _meshes()[int(rng.integers(2))])[kind]


def _obstacles(rng: np.random.Generator, arrays: wb.RobotArrays, q: np.ndarray, count: int) -> list[Obstacle]:
    """``count`` obstacles, every kind in turn, each near a random link's bounding capsule at q (from inside it to
    twice the influence distance away), turned at random."""
    rotations, origins = np.empty((len(q), 3, 3)), np.empty((len(q), 3))
    joint_transforms(q, arrays.parents, arrays.place_rot, arrays.place_pos, arrays.axes, arrays.kinds, rotations,
                     origins)
    obstacles = []
    for k in range(count):
        c = int(rng.integers(len(arrays.cap_joint)))
        joint = arrays.cap_joint[c]
        t = rng.uniform()
        local = arrays.cap_a[c] + t * (arrays.cap_b[c] - arrays.cap_a[c])
        point = local if joint < 0 else rotations[joint] @ local + origins[joint]
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        shape = _shape(rng, k % 6)
        reach = arrays.cap_r[c] + shape.bounding_radius() * rng.uniform(0.3, 1.0) + rng.uniform(-0.03, 0.4)
        orientation = Pose(orientation=quaternion_exp(rng.uniform(-2.0, 2.0, 3))).orientation
        obstacles.append(Obstacle(f"o{k}", shape, Pose(point + reach * direction, orientation)))
    return obstacles


def _config(rng: np.random.Generator) -> FieldConfig:
    influence = float(rng.uniform(0.1, 0.3))
    return FieldConfig(influence_distance=influence, safety_distance=float(rng.uniform(0.0, 0.5 * influence)),
                       attractive_gain=float(rng.uniform(0.5, 3.0)), max_linear_velocity=float(rng.uniform(0.2, 1.0)))


def _random_q(rng: np.random.Generator, robot: RobotModel) -> np.ndarray:
    lower, upper = robot.lower_limits, robot.upper_limits
    lo, hi = np.maximum(lower, -np.pi), np.minimum(upper, np.pi)
    q = rng.uniform(lo, hi)
    at_limit = rng.uniform(size=len(q)) < 0.15  # some joints at (or within a hair of) a limit: its damper rows
    q[at_limit] = np.where(rng.uniform(size=len(q)) < 0.5, lo, hi)[at_limit]
    return q


class Problem:
    """One robot among one random scene with one goal and one parameter vector, bound for both engines."""

    def __init__(self, robot: RobotModel, rng: np.random.Generator, count: int) -> None:
        config = _config(rng)
        self.robot, self.config = robot, config
        dt = float(rng.choice([0.005, 0.01, 0.02]))
        self.params = kernel_parameters(config, PlanOptions(dt=dt, stagnation_window=float(rng.uniform(0.05, 0.6)))
                                        .resolved(config), WholeBodyOptions(damping=float(rng.uniform(1e-4, 1e-2))))
        self.arrays = pack_robot(robot, config, WholeBodyOptions())
        self.q0 = _random_q(rng, robot)
        packed = pack_obstacles(_obstacles(rng, self.arrays, self.q0, count))
        self.scene = make_scene(packed, self.arrays, self.q0, config.safety_distance)  # start offsets at q0
        goal = robot.forward_kinematics(_random_q(rng, robot))
        self.goal_p, self.goal_q = np.array(goal.position), np.array(goal.orientation)
        self.core = planner(self.arrays, self.scene, self.goal_p, self.goal_q, self.params)

    def numba_step(self, kernel: Any, q: np.ndarray, previous: np.ndarray | None) -> tuple[np.ndarray, int]:
        n = len(q)
        ws = wb.make_workspace(n, len(self.arrays.cap_joint), len(self.scene.bounds), len(self.arrays.self_pairs),
                               len(self.arrays.prim_r))
        given = previous is not None
        m = kernel(q, previous if given else np.zeros(n), given, self.arrays, self.scene, self.goal_p, self.goal_q,
                   self.params, ws)
        return np.concatenate([ws.out, ws.x]), int(m)


def _problems(name: str, seeds: range, count: int) -> list[Problem]:
    robot = _robot(name)
    return [Problem(robot, np.random.default_rng(seed), count) for seed in seeds]


def test_the_structs_are_the_python_layouts() -> None:
    assert core.PARAM_OFFSETS == {name: wb.PARAMS.index(name) for name in wb.PARAMS.names}
    spans = {name: wb.STEP_OUT.span(name) if shape else (wb.STEP_OUT.index(name), wb.STEP_OUT.index(name) + 1)
             for name, shape in wb.STEP_OUT.entries}
    assert core.STEP_SPANS == spans


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_steps_equal_numba_bit_for_bit(name: str) -> None:
    from pfield.planning._whole_body_kernel import joint_velocity_step
    from pfield.planning._whole_body_loop import autonomy_step

    rows = 0
    for seed, problem in enumerate(_problems(name, range(12), 12)):
        rng = np.random.default_rng(1000 + seed)
        for k in range(12):
            q = problem.q0 if k == 0 else _random_q(rng, problem.robot)
            previous = None if k % 3 == 0 else rng.normal(scale=0.5, size=len(q))
            for kernel, ours in ((joint_velocity_step, problem.core.joint_velocity_step),
                                 (autonomy_step, problem.core.autonomy_step)):
                expected, m = problem.numba_step(kernel, q, previous)
                row, count = ours(q, previous)
                assert count == m and np.array_equal(row, expected, equal_nan=True), (name, seed, k, kernel)
                rows += m
    assert rows > 100  # the scenes do put links within reach: damper rows were compared


def _variants(problem: Problem, seed: int) -> list[tuple[np.ndarray, wb.Scene, np.ndarray, np.ndarray, bool]]:
    """(start, scene, goal position, goal orientation, cancelled) of the plans from one problem: as drawn; from the
    middle of the joint ranges without obstacles to a goal a small motion away (reached); offsets that put pairs in
    contact from the start (the collision branches); cancelled at once."""
    rng = np.random.default_rng(3000 + seed)
    robot, q0, scene = problem.robot, problem.q0, problem.scene
    lower, upper = np.maximum(robot.lower_limits, -np.pi), np.minimum(robot.upper_limits, np.pi)
    middle = 0.5 * (lower + upper) + rng.normal(scale=0.1, size=len(q0))
    near = robot.forward_kinematics(np.clip(middle + rng.normal(scale=0.05, size=len(q0)), lower, upper))
    free = make_scene(None, problem.arrays, middle, problem.config.safety_distance)
    shifted = scene._replace(obstacle_offsets=scene.obstacle_offsets + 0.05) if seed % 2 else \
        scene._replace(self_offsets=scene.self_offsets + 0.05)
    goal_p, goal_q = problem.goal_p, problem.goal_q
    reach = (middle, free, np.array(near.position), np.array(near.orientation), False)
    return [(q0, scene, goal_p, goal_q, False), reach, (q0, shifted, goal_p, goal_q, False),
            (q0, scene, goal_p, goal_q, True)]


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_plans_equal_numba_bit_for_bit(name: str) -> None:
    from pfield.planning import _whole_body_loop

    statuses = set()
    for seed, problem in enumerate(_problems(name, range(100, 110), 8)):
        for start, scene, goal_p, goal_q, cancelled in _variants(problem, seed):
            flag = cancel_flag(None)
            flag[0] = cancelled
            args = (start, problem.arrays, scene, goal_p, goal_q, problem.params, 300)
            expected = _whole_body_loop.plan_loop(*args, flag.copy())
            ours = plan_loop(*args, flag)
            assert ours[0] == expected[0] and ours[1] == expected[1], (seed, ours[0], expected[0])
            for a, b in zip(ours[2:], expected[2:], strict=True):
                assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True), (name, seed)
            statuses.add(PlanStatus(ours[0]))
    assert statuses >= {PlanStatus.REACHED, PlanStatus.STAGNATION, PlanStatus.ITERATION_LIMIT, PlanStatus.COLLISION,
                        PlanStatus.SELF_COLLISION, PlanStatus.CANCELLED}, statuses


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_stepper_equals_numba_bit_for_bit(name: str) -> None:
    """The prepared stepper (WholeBodyStepper's core): q clamped within the tolerance, previous clipped into the
    velocity limits, dt's parameters, then the output contract, as flat_step and pfield.safety did."""
    from pfield.planning._whole_body_flat import FlatStep, flat_step

    for seed, problem in enumerate(_problems(name, range(200, 204), 10)):
        rng = np.random.default_rng(2000 + seed)
        robot, config = problem.robot, problem.config
        limits = np.ascontiguousarray(robot.velocity_limits)
        stepper = core.Stepper(problem.core, limits, config.max_linear_velocity, config.max_angular_velocity,
                               LIMIT_TOLERANCE)
        flat = FlatStep(problem.arrays, problem.scene)
        for k in range(20):
            q = _random_q(rng, robot)
            q[0] = robot.lower_limits[0] - 0.5 * LIMIT_TOLERANCE if k % 4 == 1 else q[0]
            previous = None if k % 3 == 0 else rng.normal(scale=2.0, size=len(q))  # some beyond the limits
            dt = float(rng.choice([0.0, 0.01, 0.03]))
            params = problem.params.copy()
            if dt > 0.0:
                params[wb.DT] = dt
            clamped = robot.check_joint_angles(q, "q")
            given = previous is not None
            clipped = safety.clip_joint_velocities(previous, limits) if given else np.zeros(len(q))
            expected = flat_step(clamped, clipped, given and dt > 0.0, problem.goal_p, problem.goal_q, params,
                                 *flat.buffers())
            outcome = safety.limit_joint_command(expected[wb.OUT_SIZE:], expected[:6], limits,
                                                 config.max_linear_velocity, config.max_angular_velocity)
            row, twist = np.empty(len(expected)), np.empty(6)
            assert stepper.row(q, previous, dt, row) == outcome and stepper.twist(q, previous, dt, twist) == outcome
            assert np.array_equal(row, expected, equal_nan=True) and np.array_equal(twist, expected[:6]), (seed, k)


def test_the_stepper_refuses_what_check_joint_angles_refuses() -> None:
    problem = _problems("panda", range(300, 301), 3)[0]
    stepper = core.Stepper(problem.core, np.ascontiguousarray(problem.robot.velocity_limits), 1.0, 1.0,
                           LIMIT_TOLERANCE)
    q = problem.q0.copy()

    def row(q: np.ndarray, previous: np.ndarray | None = None, dt: float = 0.0) -> int:
        out = np.full(wb.OUT_SIZE + len(problem.q0), 7.0)
        outcome = stepper.row(q, previous, dt, out)
        assert outcome >= 0 or np.all(out == 7.0)  # refused: out untouched
        return int(outcome)

    assert row(q) >= 0
    for bad in (q[:-1], np.r_[q[:-1], math.nan], np.r_[problem.robot.upper_limits[0] + 2 * LIMIT_TOLERANCE, q[1:]]):
        assert row(np.ascontiguousarray(bad)) == -1
    assert row(q, np.r_[np.zeros(len(q) - 1), math.inf], 0.01) == -1
    assert row(q, np.zeros(len(q) - 1), 0.01) == -1
    assert row(q, None, -0.01) == -1 and row(q, None, math.nan) == -1
    with pytest.raises(TypeError):  # not float64, strided: the Python layer validates them
        row(q.astype(np.float32))
    with pytest.raises(TypeError):
        row(np.repeat(q, 2)[::2])


def test_the_plan_releases_the_gil_and_reads_the_cancel_flag() -> None:
    """A plan that could run for seconds (a goal out of reach, no stagnation) ends CANCELLED soon after another
    thread sets the flag: it ran without the GIL and read the flag every step."""
    problem = _problems("panda", range(400, 401), 0)[0]
    params = problem.params.copy()
    params[wb.STAG_PROGRESS] = -1.0  # never stagnates
    far = planner(problem.arrays, problem.scene, np.array([5.0, 0.0, 0.0]), problem.goal_q, params)
    n, total = len(problem.q0), 2_000_001
    outputs = (np.empty((total, n)), np.empty((total, n)), np.empty((total, 3)), np.empty((total, 4)),
               np.empty((total, 6)), np.empty(total))
    flag = cancel_flag(None)
    results: list[Any] = []
    worker = threading.Thread(target=lambda: results.append(far.plan(problem.q0, total - 1, flag, *outputs)))
    started = time.perf_counter()
    worker.start()
    time.sleep(0.05)  # runs only if the plan let go of the GIL
    flag[0] = 1
    worker.join()
    assert results[0].status == PlanStatus.CANCELLED and results[0].count < total
    assert time.perf_counter() - started < 2.0
