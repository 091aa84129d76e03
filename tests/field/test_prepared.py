"""PreparedTwist: bound arrays in, bound arrays out, the same twist as PotentialField.twist bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfield import Box, FieldConfig, InvalidInput, Obstacle, Pose, PotentialField, PreparedTwist, Sphere, Twist
from pfield.planning.scenes import BENCH_GOAL, DEFAULT_PARAMS, evaluation_query, evaluation_scene


def _poses() -> list[Pose]:
    rng = np.random.default_rng(3)
    poses = [evaluation_query()]
    for _ in range(20):
        quat = rng.normal(size=4)
        poses.append(Pose(rng.uniform((0.2, -0.1, 0.2), (0.7, 0.4, 0.6)), quat))
    return poses


@pytest.mark.parametrize("scene", ["empty", "spheres_10", "boxes_10", "capsules_10"])
def test_equals_field_twist_bit_for_bit(scene: str) -> None:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene(scene))
    prepared = PreparedTwist(field)
    previous = Twist((0.1, -0.2, 0.05), (0.0, 0.1, -0.3))
    for pose in _poses():
        prepared.pose[:3], prepared.pose[3:] = pose.position, pose.orientation
        prepared.previous[:] = 7.0  # ignored without dt
        assert np.array_equal(prepared.evaluate(), field.twist(pose).as_array())
        prepared.previous[:] = previous.as_array()
        out = prepared.evaluate(0.01)
        assert out is prepared.twist
        assert np.array_equal(out, field.twist(pose, previous, 0.01).as_array())


def test_rosyaml_defaults_near_an_obstacle() -> None:
    obstacles = [Obstacle("ball", Sphere(0.05), Pose((0.4, 0.0, 0.5))), Obstacle("box", Box(0.1, 0.1, 0.1),
                                                                                   Pose((0.3, 0.12, 0.5)))]
    field = PotentialField(FieldConfig(), Pose((0.6, 0.0, 0.5)), obstacles)
    prepared = PreparedTwist(field)
    pose = Pose((0.32, 0.0, 0.5))
    prepared.pose[:3], prepared.pose[3:] = pose.position, pose.orientation
    assert np.array_equal(prepared.evaluate(), field.twist(pose).as_array())


@pytest.mark.parametrize(("index", "value", "name"), [(0, math.nan, "pose[0:3]"), (2, math.inf, "pose[0:3]"),
                                                       (6, 2.0, "pose[3:7]"), (3, math.nan, "pose[3:7]")])
def test_bad_pose_is_refused_and_twist_unchanged(index: int, value: float, name: str) -> None:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("spheres_1"))
    prepared = PreparedTwist(field)
    before = prepared.evaluate().copy()
    prepared.pose[index] = value
    with pytest.raises(InvalidInput, match=re_escape(name)):
        prepared.evaluate()
    assert np.array_equal(prepared.twist, before)


def re_escape(text: str) -> str:
    import re

    return re.escape(text)


@pytest.mark.parametrize("dt", [-0.01, math.inf, math.nan, "x", True])
def test_bad_dt_is_refused(dt: object) -> None:
    prepared = PreparedTwist(PotentialField(DEFAULT_PARAMS, BENCH_GOAL, []))
    with pytest.raises(InvalidInput, match="dt"):
        prepared.evaluate(dt)  # type: ignore[arg-type]


def test_integer_dt_is_accepted() -> None:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, [])
    prepared = PreparedTwist(field)
    assert np.array_equal(prepared.evaluate(0), field.twist(Pose((0.0, 0.0, 0.0))).as_array())


def test_needs_a_field() -> None:
    with pytest.raises(InvalidInput, match="field"):
        PreparedTwist(object())
