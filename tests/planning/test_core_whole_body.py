"""The compiled whole-body step, loop and stepper (``src/core/planning/whole_body``): numba's bits, and what they
must satisfy.

The planner, :class:`~pfield.planning.WholeBodyStepper`, the global fallback's tracking and the assistance run this
core. It replaced numba kernels (``_whole_body_kernel``, ``_whole_body_loop``, ``_whole_body_flat``, issue 32) to the
bit, and every exact figure the test suite holds for a whole-body plan carried over because the two agreed in the
last digit. Those kernels are gone; what they computed stays here as digests: the sha256 (first 16 hex digits) of
every number of a step (its row: twist, pose, clearances, goal errors, nearest pairs, and q̇), its damper-row count,
and every output of a plan (status, count, waypoints, velocities, poses, twists, clearances, culprit), per seeded
problem. The digests were computed from the core's outputs after checking, case by case, that numba's kernels gave
the same bits (``np.array_equal``) on the same inputs: they are numba's results. A change of any bit fails them;
the invariants beside them (the twist is J q̇, the pose is the forward kinematics, the clearances and nearest pairs
are the link model's exact distances less their offsets, each waypoint is the last one plus q̇ dt clipped) say
whether such a change is still right.

The scenes aim at every branch: the Panda and a URDF robot (the UR5 with its gripper) among random obstacles of all
six kinds placed at random distances from random links (pairs beyond Q, within it, within d_s and in contact: start
offsets, the capsule and fitted levels, damper rows, the null-space push), random previous velocities (the rate
limit, kept or dropped), configurations at the joint limits (their dampers), random parameters. The digests hold on
this machine class's libm (glibc's sin, cos, atan2, exp); numpy's random streams and trimesh's shapes make the inputs.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

from core_scenes import random_shape, robot
from digests import digest
from pfield import safety
from pfield._core import whole_body as core
from pfield.field.config import FieldConfig
from pfield.geometry import Obstacle, pack_obstacles
from pfield.planning import _whole_body_layout as wb
from pfield.planning._whole_body_core import pair_distances, plan_loop, planner
from pfield.planning.cancel import cancel_flag
from pfield.planning.options import PlanOptions
from pfield.planning.status import PlanStatus
from pfield.planning.whole_body import WholeBodyOptions, kernel_parameters, make_scene, pack_robot
from pfield.robot import RobotModel
from pfield.robot.model import LIMIT_TOLERANCE
from pfield.spatial import Pose, quaternion_exp

_robot = robot



def _shape(rng: np.random.Generator, kind: int) -> Any:
    return random_shape(rng, kind, 0.02)


def _obstacles(rng: np.random.Generator, robot: RobotModel, arrays: wb.RobotArrays, q: np.ndarray,
               count: int) -> list[Obstacle]:
    """``count`` obstacles, every kind in turn, each near a random link's bounding capsule at q (from inside it to
    twice the influence distance away), turned at random."""
    rotations, origins = robot.joint_frames(q)
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
    """One robot among one random scene with one goal and one parameter vector, bound into the core."""

    def __init__(self, robot: RobotModel, rng: np.random.Generator, count: int) -> None:
        config = _config(rng)
        self.robot, self.config = robot, config
        dt = float(rng.choice([0.005, 0.01, 0.02]))
        self.params = kernel_parameters(config, PlanOptions(dt=dt, stagnation_window=float(rng.uniform(0.05, 0.6)))
                                        .resolved(config), WholeBodyOptions(damping=float(rng.uniform(1e-4, 1e-2))))
        self.arrays = pack_robot(robot, config, WholeBodyOptions())
        self.q0 = _random_q(rng, robot)
        packed = pack_obstacles(_obstacles(rng, robot, self.arrays, self.q0, count))
        self.scene = make_scene(packed, self.arrays, self.q0, config.safety_distance)  # start offsets at q0
        goal = robot.forward_kinematics(_random_q(rng, robot))
        self.goal_p, self.goal_q = np.array(goal.position), np.array(goal.orientation)
        self.core = planner(self.arrays, self.scene, self.goal_p, self.goal_q, self.params)


def _problems(name: str, seeds: range, count: int) -> list[Problem]:
    robot = _robot(name)
    return [Problem(robot, np.random.default_rng(seed), count) for seed in seeds]


def _digest(values: Iterator[Any]) -> str:
    """The first 16 hex digits of :func:`digests.digest`."""
    return digest(values)[:16]


def test_the_structs_are_the_python_layouts() -> None:
    assert core.PARAM_OFFSETS == {name: wb.PARAMS.index(name) for name in wb.PARAMS.names}
    spans = {name: wb.STEP_OUT.span(name) if shape else (wb.STEP_OUT.index(name), wb.STEP_OUT.index(name) + 1)
             for name, shape in wb.STEP_OUT.entries}
    assert core.STEP_SPANS == spans


# ---- steps ------------------------------------------------------------------------------------------------------

def _steps(problem: Problem, seed: int) -> Iterator[tuple[str, np.ndarray, np.ndarray | None, np.ndarray, int]]:
    """(kind, q, previous, row, damper rows) of both steps at the problem's start and 11 random configurations."""
    rng = np.random.default_rng(1000 + seed)
    for k in range(12):
        q = problem.q0 if k == 0 else _random_q(rng, problem.robot)
        previous = None if k % 3 == 0 else rng.normal(scale=0.5, size=len(q))
        for kind in ("joint_velocity_step", "autonomy_step"):
            row, count = getattr(problem.core, kind)(q, previous)
            yield kind, q, previous, row, count


def _step_digest(problem: Problem, seed: int) -> str:
    return _digest(value for _, _, _, row, count in _steps(problem, seed) for value in (row, np.int64(count)))


# numba's joint_velocity_step and autonomy_step (pfield.planning._whole_body_kernel / _whole_body_loop), digested by
# _step_digest per problem seed after the core was checked equal to them bit for bit on every step; panda 8, ur5 7
# and ur5 11 since the QP's stopping test checks x against every row (issue 32, src/core/math/qp.cpp): 4 of their
# steps had a QP that numba stopped with a row violated (by up to 3.7e-5, tolerance 1e-7), whose q̇ now moves by up
# to 3.3e-3 rad/s (the other steps kept numba's bits; _check_step's oracles hold on all)
STEP_DIGESTS = {
    "panda": {0: "bed4395f04a87863", 1: "452e0a23bb9505a4", 2: "b34ca3ee85e7456a", 3: "1868060fadecbad5",
              4: "3cbb9f38e489aa18", 5: "6a76a276aafed311", 6: "dd20987d1d9e1025", 7: "a655a7b0279c11b6",
              8: "33a9176c8c6d0e66", 9: "f22c0388adf5cd5a", 10: "327a8e38726a7aef", 11: "f08e74a4d0414d90"},
    "ur5": {0: "b71bb60fcb2ed27a", 1: "e2a9d46f703972aa", 2: "e8dbf4d09694df11", 3: "429760836000ee88",
            4: "aacb5fdf74abebec", 5: "8f73909592df83c7", 6: "1813c2b12d484371", 7: "06bedfa76068fb5a",
            8: "754e4d99aceac70b", 9: "b9dac5e5d3d176db", 10: "312ba7121e49c112", 11: "13d974bc2a941c25"},
}


def _check_step(problem: Problem, kind: str, q: np.ndarray, row: np.ndarray) -> None:
    """What a step's row must be whatever the bits: the twist J q̇, the pose FK(q), the goal error, and for the
    planner's step the clearance and nearest pairs of the link model's exact distances (less the start offsets)."""
    robot, result, qdot = problem.robot, wb.StepResult.of(row), row[wb.OUT_SIZE:]
    np.testing.assert_allclose(result.twist, robot.jacobian(q) @ qdot, rtol=0, atol=1e-12 * (1 + abs(qdot).max()))
    pose = robot.forward_kinematics(q)
    np.testing.assert_allclose(result.position, pose.position, rtol=0, atol=1e-12)
    sign = 1.0 if np.dot(result.orientation, pose.orientation) >= 0.0 else -1.0
    np.testing.assert_allclose(result.orientation, sign * np.array(pose.orientation), rtol=0, atol=1e-12)
    assert result.position_error == pytest.approx(np.linalg.norm(problem.goal_p - result.position), abs=1e-12)
    if kind != "joint_velocity_step":  # the autonomy step takes its offsets at q itself
        return
    obstacle, own = pair_distances(q, problem.arrays, problem.scene)
    influence = problem.params[wb.INFLUENCE]
    exact = obstacle.min(initial=math.inf)
    assert result.clearance <= exact + 1e-12  # a lower bound, exact below min(Q, 10 cm)
    if exact < min(influence, 0.1):
        assert result.clearance == pytest.approx(exact, abs=1e-12)
    less = obstacle - problem.scene.obstacle_offsets
    if result.nearest_capsule >= 0 and result.nearest_distance < influence:
        pair = (int(result.nearest_capsule), int(result.nearest_obstacle))
        assert result.nearest_distance == pytest.approx(less[pair], abs=1e-12)
        assert result.nearest_distance <= less.min() + 1e-12
    if len(own):
        assert result.self_clearance == pytest.approx(np.min(own - problem.scene.self_offsets), abs=1e-12)


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_steps_are_numbas(name: str) -> None:
    rows = 0
    digests = {}
    for seed, problem in enumerate(_problems(name, range(12), 12)):
        for kind, q, _, row, count in _steps(problem, seed):
            _check_step(problem, kind, q, row)
            rows += count
        digests[seed] = _step_digest(problem, seed)
    assert digests == STEP_DIGESTS[name]
    assert rows > 100  # the scenes do put links within reach: damper rows were digested


# ---- plans ------------------------------------------------------------------------------------------------------

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


def _plans(problem: Problem, seed: int, plan: Callable[..., tuple[Any, ...]] = plan_loop
           ) -> Iterator[tuple[np.ndarray, np.ndarray, tuple[Any, ...]]]:
    """(start, goal position, outputs of the plan) of every variant, 300 iterations at most."""
    for start, scene, goal_p, goal_q, cancelled in _variants(problem, seed):
        flag = cancel_flag(None)
        flag[0] = cancelled
        yield start, goal_p, plan(start, problem.arrays, scene, goal_p, goal_q, problem.params, 300, flag)


def _plan_digest(outputs: list[tuple[Any, ...]]) -> str:
    return _digest(np.int64(value) if k < 2 else value for plan in outputs for k, value in enumerate(plan))


# numba's plan_loop (pfield.planning._whole_body_loop), digested by _plan_digest per problem seed after the core's
# plans were checked equal to it bit for bit, output for output
PLAN_DIGESTS = {
    "panda": {0: "2b8b87ab2687e865", 1: "a6cf7bd83df0dc7f", 2: "9e418337b6c55def", 3: "b2897f34043ab42f",
              4: "1c97d7c6099a11ce", 5: "0ac3d26b3ecdc3a9", 6: "4733cb078d701266", 7: "bfb38db0fb85447a",
              8: "d16506054a360987", 9: "a9621649deb0bd48"},
    "ur5": {0: "ab396ed1feec289e", 1: "41af2fdb189b27d4", 2: "e40d6e8f33a353c1", 3: "357d2962863a1580",
            4: "cefb09d33ac20771", 5: "72f9f93e67aa9185", 6: "2d9b548eb3c363f4", 7: "38e21bd8a1d78c46",
            8: "fc3d5e87edc9cc0e", 9: "1a06d3859bdd418d"},
}


def _check_plan(problem: Problem, start: np.ndarray, goal_p: np.ndarray, outputs: tuple[Any, ...]) -> None:
    """Each waypoint is the last plus its q̇ dt, clipped into the limits (the integration, exactly); poses and twists
    are the kinematics'; a reached goal is within the tolerance; a collision names a pair in contact."""
    status, count, qs, qds, positions, _, twists, clearances, culprit = outputs
    robot, dt = problem.robot, problem.params[wb.DT]
    assert 1 <= count <= 301 and len(qs) == count and np.array_equal(qs[0], start)
    assert np.array_equal(qs[1:], np.minimum(np.maximum(qs[:-1] + qds[:-1] * dt, robot.lower_limits),
                                             robot.upper_limits))
    for k in range(0, count, 25):
        np.testing.assert_allclose(positions[k], robot.forward_kinematics(qs[k]).position, rtol=0, atol=1e-12)
        np.testing.assert_allclose(twists[k], robot.jacobian(qs[k]) @ qds[k], rtol=0,
                                   atol=1e-12 * (1 + abs(qds[k]).max()))
    assert not np.isnan(clearances).any()
    if status == PlanStatus.REACHED:
        assert np.linalg.norm(positions[-1] - goal_p) <= problem.params[wb.TOL]
        assert not qds[-1].any() and not twists[-1].any()
    if status == PlanStatus.COLLISION:
        assert culprit[2] < 0.0
    if status == PlanStatus.SELF_COLLISION:
        assert culprit[4] < 0.0


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_plans_are_numbas(name: str) -> None:
    statuses = set()
    digests = {}
    for seed, problem in enumerate(_problems(name, range(100, 110), 8)):
        outputs = []
        for start, goal_p, plan in _plans(problem, seed):
            _check_plan(problem, start, goal_p, plan)
            statuses.add(PlanStatus(plan[0]))
            outputs.append(plan)
        digests[seed] = _plan_digest(outputs)
    assert digests == PLAN_DIGESTS[name]
    assert statuses >= {PlanStatus.REACHED, PlanStatus.STAGNATION, PlanStatus.ITERATION_LIMIT, PlanStatus.COLLISION,
                        PlanStatus.SELF_COLLISION, PlanStatus.CANCELLED}, statuses


# ---- the prepared stepper ---------------------------------------------------------------------------------------

def _stepper_calls(problem: Problem, seed: int) -> Iterator[tuple[np.ndarray, np.ndarray | None, float]]:
    """(q, previous, dt) of 20 steps: some q a hair beyond a limit, some previous beyond the velocity limits."""
    rng = np.random.default_rng(2000 + seed)
    robot = problem.robot
    for k in range(20):
        q = _random_q(rng, robot)
        q[0] = robot.lower_limits[0] - 0.5 * LIMIT_TOLERANCE if k % 4 == 1 else q[0]
        previous = None if k % 3 == 0 else rng.normal(scale=2.0, size=len(q))  # some beyond the limits
        yield q, previous, float(rng.choice([0.0, 0.01, 0.03]))


def _stepper(problem: Problem) -> Any:
    config = problem.config
    return core.Stepper(problem.core, np.ascontiguousarray(problem.robot.velocity_limits), config.max_linear_velocity,
                        config.max_angular_velocity, LIMIT_TOLERANCE)


# numba's flat_step (pfield.planning._whole_body_flat) then pfield.safety's output contract, digested per problem
# seed (every row, then every outcome) after the core's Stepper was checked equal to them bit for bit
STEPPER_DIGESTS = {
    # panda seeds 0 and 3 scale a command: their digests are of the contract's one compiled copy (safety/limits.cpp,
    # no fused multiply-add), whose scale factor differs in a last bit from the fused copies of the binding files
    "panda": {0: "2ed9acb2f00e1584", 1: "b3f31a3b2a020c6c", 2: "5adf33bd64b93dec", 3: "e88dd6ff2e5c429e"},
    "ur5": {0: "3c44c118a1c26aa0", 1: "e004b88c1d8987b6", 2: "f08a6534094a9402", 3: "b0ba1cecc093ffed"},
}


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_the_stepper_is_the_autonomy_step_under_the_output_contract(name: str) -> None:
    """The prepared stepper (WholeBodyStepper's core): q clamped within the tolerance, previous clipped into the
    velocity limits and used only with dt > 0, the parameters of dt, the autonomy step, then the output contract
    (pfield.safety) — step by step the same bits as those parts called one after the other; and numba's bits."""
    digests = {}
    for seed, problem in enumerate(_problems(name, range(200, 204), 10)):
        robot, config = problem.robot, problem.config
        limits = np.ascontiguousarray(robot.velocity_limits)
        stepper = _stepper(problem)
        rows, outcomes = [], []
        for q, previous, dt in _stepper_calls(problem, seed):
            params = problem.params.copy()
            if dt > 0.0:
                params[wb.DT] = dt
            clamped = robot.check_joint_angles(q, "q")
            clipped = safety.clip_joint_velocities(previous, limits) if previous is not None and dt > 0.0 else None
            expected, _ = planner(problem.arrays, problem.scene, problem.goal_p, problem.goal_q, params).autonomy_step(
                clamped, clipped)
            outcome = safety.limit_joint_command(expected[wb.OUT_SIZE:], expected[:6], limits,
                                                 config.max_linear_velocity, config.max_angular_velocity)
            row = np.empty(len(expected))
            linear, angular, twist_outcome = stepper.twist(q, previous, dt)
            assert stepper.row(q, previous, dt, row) == outcome and twist_outcome == outcome
            assert not linear.flags.writeable and not angular.flags.writeable
            twist = np.concatenate([linear, angular])
            assert np.array_equal(row, expected, equal_nan=True) and np.array_equal(twist, expected[:6]), (seed, q)
            rows.append(row)
            outcomes.append(np.int64(outcome))
        digests[seed] = _digest(iter(rows + outcomes))
    assert digests == STEPPER_DIGESTS[name]


def test_the_stepper_refuses_what_check_joint_angles_refuses() -> None:
    problem = _problems("panda", range(300, 301), 3)[0]
    stepper = core.Stepper(problem.core, np.ascontiguousarray(problem.robot.velocity_limits), 1.0, 1.0,
                           LIMIT_TOLERANCE)
    q = problem.q0.copy()

    def row(q: np.ndarray, previous: np.ndarray | None = None, dt: float = 0.0) -> int:
        out = np.full(wb.OUT_SIZE + len(problem.q0), 7.0)
        outcome = stepper.row(q, previous, dt, out)
        assert outcome >= 0 or np.all(out == 7.0)  # refused: out untouched
        linear, angular, twist_outcome = stepper.twist(q, previous, dt)  # the twist alone refuses the same
        assert twist_outcome == outcome and (outcome >= 0 or (linear is None and angular is None))
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


def test_the_posture_term_is_the_damped_least_squares_free_term() -> None:
    """With a joint goal, the step minimises |J q̇ − v|²_W + λ²|q̇ − k (q_goal − q)|²: at the goal pose (v = 0), among
    no obstacles and far from the joint limits, q̇ = (JᵀWJ + λ²I)⁻¹ λ² k (q_goal − q) exactly; its component in J's
    null space is k (q_goal − q)'s own, and a step without the joint goal is zero."""
    panda = RobotModel.builtin("panda")
    config, options = FieldConfig(), WholeBodyOptions()
    params = kernel_parameters(config, PlanOptions(dt=0.02).resolved(config), options)
    arrays = pack_robot(panda, config, options)
    scene = make_scene(None, arrays, None)
    q = panda.named_configuration("ready")
    goal = panda.forward_kinematics(q)
    goal_p, goal_q = np.array(goal.position), np.array(goal.orientation)
    target = q + np.array([0.05, -0.03, 0.04, 0.02, -0.05, 0.03, 0.06])
    gain = 0.7
    row, _ = planner(arrays, scene, goal_p, goal_q, params, target, gain).joint_velocity_step(q)
    qd = np.asarray(row)[wb.STEP_OUT.size():]
    jac = panda.jacobian(q)
    weights = np.diag([1.0, 1.0, 1.0] + [options.rotation_weight] * 3)
    damping = options.damping
    expected = np.linalg.solve(jac.T @ weights @ jac + damping * np.eye(7), damping * gain * (target - q))
    np.testing.assert_allclose(qd, expected, rtol=1e-9, atol=1e-12)
    null = np.eye(7) - np.linalg.pinv(jac) @ jac
    np.testing.assert_allclose(null @ qd, null @ (gain * (target - q)), atol=1e-6)
    still, _ = planner(arrays, scene, goal_p, goal_q, params).joint_velocity_step(q)
    np.testing.assert_allclose(np.asarray(still)[wb.STEP_OUT.size():], 0.0, atol=1e-12)


@pytest.mark.parametrize(("field", "value"), [
    ("rotation_weight", 0.0), ("damping", -1e-3), ("damping", math.nan), ("joint_influence", 0.0),
    ("null_space_gain", math.inf), ("posture_gain", -1.0), ("posture_gain", math.nan), ("joint_safety", 0.2),
])
def test_whole_body_options_refuse_bad_values_naming_them(field: str, value: float) -> None:
    from pfield.errors import InvalidInput

    with pytest.raises(InvalidInput) as info:
        WholeBodyOptions(**{field: value})
    assert info.value.field == field
