"""Robots and a free-space Panda plan shared by the simulator tests (one load per module)."""

from __future__ import annotations

import pytest

from pfield.field import FieldConfig, PotentialField
from pfield.planning import PlannedPath
from pfield.robot import RobotModel
from pfield.spatial import Pose


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return RobotModel.builtin("panda")


@pytest.fixture(scope="module")
def xarm() -> RobotModel:
    return RobotModel.builtin("xarm7")


FREE_GOAL = Pose((0.45, 0.3, 0.35), (1.0, 0.0, 0.0, 0.0))


@pytest.fixture(scope="module")
def free_plan(panda: RobotModel) -> PlannedPath:
    """A whole-body plan from the ready pose to :data:`FREE_GOAL` without obstacles."""
    field = PotentialField(FieldConfig(max_linear_velocity=0.25, max_angular_velocity=1.0,
                                       rotational_attractive_gain=0.6), FREE_GOAL, [])
    path = field.plan_whole_body(panda, panda.named_configuration("ready"), dt=0.02, goal_tolerance=0.005,
                                 max_iterations=5000)
    assert path.success and path.trajectory is not None
    return path
