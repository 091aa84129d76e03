"""IKSolver: solve_ik prepared once (bound arrays), the same answers bit for bit, bad input refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfield import errors
from pfield.robot import RobotModel
from pfield.robot.ik import IKSolver, solve_ik
from pfield.spatial import Pose


@pytest.mark.parametrize("name", ["xarm7", "panda"])
def test_same_answers_as_solve_ik(name: str, xarm: RobotModel, panda: RobotModel) -> None:
    robot = xarm if name == "xarm7" else panda
    rng = np.random.default_rng(5)
    lower, upper = np.array(robot.lower_limits), np.array(robot.upper_limits)
    solver = IKSolver(robot, max_iterations=50)
    for _ in range(15):
        q = rng.uniform(np.maximum(lower, -3.0), np.minimum(upper, 3.0))
        seed = np.clip(q + rng.normal(scale=0.2, size=q.shape), lower, upper)
        target = robot.forward_kinematics(q)
        target = Pose(target.position + rng.normal(scale=0.01, size=3), target.orientation)
        solver.target[:3], solver.target[3:], solver.seed[:] = target.position, target.orientation, seed
        success = solver.solve()
        expected = solve_ik(robot, target, seed, max_iterations=50)
        assert success == expected.success
        assert np.array_equal(solver.q, expected.q)
        assert solver.iterations == expected.iterations
        assert solver.position_error == expected.position_error
        assert solver.rotation_error == expected.rotation_error


def test_reaches_one_centimetre_away(xarm: RobotModel) -> None:
    q0 = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])
    start = xarm.forward_kinematics(q0)
    solver = IKSolver(xarm)
    solver.target[:3] = start.position + np.array([0.01, 0.0, 0.0])
    solver.target[3:], solver.seed[:] = start.orientation, q0
    assert solver.solve()
    reached = xarm.forward_kinematics(solver.q)
    assert np.linalg.norm(reached.position - solver.target[:3]) <= 1e-4
    assert solver.position_error <= 1e-4 and solver.rotation_error <= 1e-3


@pytest.mark.parametrize(("slot", "index", "value", "field"), [
    ("target", 0, math.nan, "target[0:3]"), ("target", 2, math.inf, "target[0:3]"),
    ("target", 6, 3.0, "target[3:7]"), ("seed", 1, math.nan, "seed"), ("seed", 0, 10.0, "seed[0]")])
def test_bad_input_is_refused(xarm: RobotModel, slot: str, index: int, value: float, field: str) -> None:
    solver = IKSolver(xarm)
    start = xarm.forward_kinematics(np.zeros(7))
    solver.target[:3], solver.target[3:] = start.position, start.orientation
    assert solver.solve()
    q = solver.q.copy()
    getattr(solver, slot)[index] = value
    with pytest.raises(errors.InvalidInput) as info:
        solver.solve()
    assert info.value.field == field
    assert np.array_equal(solver.q, q) or slot == "seed"  # a bad target leaves the last answer


@pytest.mark.parametrize(("option", "value"), [("max_iterations", 0), ("max_iterations", 1.5),
                                               ("damping", -1.0), ("max_step", math.nan)])
def test_bad_settings_are_refused(xarm: RobotModel, option: str, value: float) -> None:
    with pytest.raises(errors.InvalidInput):
        IKSolver(xarm, **{option: value})  # type: ignore[arg-type]


def test_needs_a_robot() -> None:
    with pytest.raises(errors.InvalidInput, match="robot"):
        IKSolver(object())  # type: ignore[arg-type]
