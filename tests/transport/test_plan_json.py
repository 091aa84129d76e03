"""The ``PlanPath`` response written from a real plan's arrays equals, byte for byte, what the validated
pydantic models of the same plan write, and reads back as the same models."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from _plan_reference import reference_response

from pfield import geometry
from pfield.errors import InvalidInput
from pfield.field import FieldConfig, PotentialField
from pfield.interfaces.convert import CHUNK_ROWS, plan_response
from pfield.robot import RobotModel
from pfield.spatial import Pose

ORIENTATION = (0.707, 0.0, 0.707, 0.0)


@pytest.fixture(scope="module")
def field() -> PotentialField:
    ball = geometry.Obstacle("ball", geometry.Sphere(radius=0.1), Pose((0.4, 0.0, 0.1), (0.0, 0.0, 0.0, 1.0)))
    return PotentialField(FieldConfig(), goal=Pose((0.5, 0.2, 0.4), ORIENTATION), obstacles=[ball])


def test_a_task_space_plan_writes_the_same_bytes(field: PotentialField) -> None:
    slow = PotentialField(FieldConfig(max_linear_velocity=0.0002, stagnation_progress=1e-6), goal=field.goal,
                          obstacles=field.obstacles)
    path = slow.plan(start=Pose((0.3, 0.1, 0.35), ORIENTATION), dt=0.02, goal_tolerance=0.01, max_iterations=5000)
    assert len(path) > 4 * CHUNK_ROWS  # several chunks
    fast, reference = plan_response(path, "world"), reference_response(path, "world")
    assert fast.model_dump_json() == reference.model_dump_json()
    assert fast.end_effector_path.model_dump_json() == reference.end_effector_path.model_dump_json()
    assert fast.end_effector_path.poses == reference.end_effector_path.poses  # built when read
    assert fast == reference and fast.model_dump() == reference.model_dump()
    assert fast.model_dump_json(indent=1) == reference.model_dump_json(indent=1)


def test_a_whole_body_plan_writes_the_same_bytes(field: PotentialField) -> None:
    robot = RobotModel.builtin("xarm7")
    path = field.plan_whole_body(robot, np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0]), 0.02, 0.01, 3000)
    assert path.joint_positions is not None
    for frame in ("world", 'a "quoted" % {} frame ✓'):
        fast, reference = plan_response(path, frame), reference_response(path, frame)
        text = "".join(fast.json_chunks())  # type: ignore[attr-defined]
        assert text == reference.model_dump_json()
        assert json.loads(text) == json.loads(reference.model_dump_json())
        assert fast.joint_trajectory.points == reference.joint_trajectory.points
        assert fast.end_effector_velocity_trajectory == reference.end_effector_velocity_trajectory


def test_the_joint_trajectory_is_the_retimed_one(field: PotentialField) -> None:
    robot = RobotModel.builtin("xarm7")
    path = field.plan_whole_body(robot, np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0]), 0.02, 0.01, 3000)
    timed = path.trajectory
    assert timed is not None
    points = plan_response(path, "world").joint_trajectory.points
    assert len(points) == len(timed.times)
    for point, q, v, a, t in zip(points, timed.positions, timed.velocities, timed.accelerations, timed.times,
                                 strict=True):
        assert (point.positions, point.velocities, point.accelerations) == (q.tolist(), v.tolist(), a.tolist())
        assert point.time_from_start.sec * 1_000_000_000 + point.time_from_start.nanosec == round(t * 1e9)
    samples = replace(path, trajectory=None)  # without one: the planner's samples at i·dt, no accelerations
    sampled = plan_response(samples, "world").joint_trajectory.points
    assert len(sampled) == len(path.times) and all(point.accelerations == [] for point in sampled)
    assert "".join(plan_response(samples, "world").json_chunks()) == \
        reference_response(samples, "world").model_dump_json()  # type: ignore[attr-defined]


def test_non_finite_values_and_long_plans(field: PotentialField) -> None:
    path = field.plan(start=Pose((0.3, 0.1, 0.35), ORIENTATION), dt=0.02, goal_tolerance=0.01, max_iterations=50)
    twists = path.twists.copy()
    twists[1, 2] = np.inf
    odd = replace(path, twists=twists, failure_reason="stagnated ✓")
    assert plan_response(odd, "world").model_dump_json() == reference_response(odd, "world").model_dump_json()
    too_long = replace(path, times=path.times * 3e9)  # the last stamp over 2^31 s
    with pytest.raises(InvalidInput) as refused:
        plan_response(too_long, "world")
    assert refused.value.field == "times"
