"""Shape and obstacle validation, packing layout and the point-array interface."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pfield import Box, Capsule, Cylinder, Ellipsoid, Obstacle, Sphere, pack_obstacles
from pfield.errors import InvalidInput, PfieldError
from pfield.geometry.packed import BOX, CAPSULE, CYLINDER, ELLIPSOID, SPHERE
from pfield.spatial import Pose

VALID = {
    Sphere: {"radius": 0.1},
    Box: {"length": 0.1, "width": 0.2, "height": 0.3},
    Cylinder: {"radius": 0.1, "height": 0.3},
    Ellipsoid: {"semi_x": 0.1, "semi_y": 0.2, "semi_z": 0.3},
    Capsule: {"radius": 0.1, "height": 0.3},
}
BAD_SIZE_CASES = [(shape, name, value) for shape, sizes in VALID.items() for name in sizes
                  for value in (0.0, -0.1, float("nan"), float("inf"), "big")]


@pytest.mark.parametrize(("shape", "name", "value"), BAD_SIZE_CASES)
def test_bad_sizes_name_the_field(shape, name, value):
    with pytest.raises(InvalidInput) as info:
        shape(**{**VALID[shape], name: value})
    assert info.value.field == name
    assert isinstance(info.value, PfieldError)


def test_shapes_are_frozen_and_keep_the_seed_names():
    box = Box(length=1, width=2, height=3)
    assert (box.length, box.width, box.height) == (1.0, 2.0, 3.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        box.length = 2.0  # type: ignore[misc]


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"id": ""}, "id"),
    ({"group": "Movable"}, "group"),
    ({"group": "static"}, "group"),
    ({"shape": "Sphere"}, "type"),
    ({"pose": (0.0, 0.0, 0.0)}, "pose"),
])
def test_bad_obstacles_name_the_field(kwargs, field):
    arguments = {"id": "o", "shape": Sphere(0.1), "pose": Pose(), "group": "Static"} | kwargs
    with pytest.raises(InvalidInput) as info:
        Obstacle(**arguments)
    assert info.value.field == field


@pytest.mark.parametrize("group", ["Static", "Dynamic", "Robot"])
def test_groups(group):
    assert Obstacle("o", Sphere(0.1), Pose(), group=group).group == group


def test_signed_distance_accepts_one_point_or_many():
    obstacle = Obstacle("ball", Sphere(radius=0.1), Pose(position=(0.4, 0, 0.1)))
    d, n = obstacle.signed_distance((0.4, 0.0, 0.5))
    assert d.shape == (1,) and n.shape == (1, 3)
    assert d[0] == pytest.approx(0.3)
    d, n = obstacle.signed_distance(np.zeros((7, 3)))
    assert d.shape == (7,) and n.shape == (7, 3)
    d, n = obstacle.signed_distance(np.zeros((0, 3)))
    assert d.shape == (0,) and n.shape == (0, 3)


@pytest.mark.parametrize("points", [np.zeros((3, 2)), [1.0, 2.0], [[np.nan, 0.0, 0.0]], "abc"])
def test_bad_points(points):
    with pytest.raises(InvalidInput) as info:
        Obstacle("o", Sphere(0.1), Pose()).signed_distance(points)
    assert info.value.field == "points"


def test_pack_layout():
    turn = (0.0, 0.0, np.sin(0.25), np.cos(0.25))
    obstacles = [
        Obstacle("s", Sphere(0.1), Pose((1, 2, 3))),
        Obstacle("b", Box(0.2, 0.4, 0.6), Pose((0, 0, 1), turn)),
        Obstacle("c", Cylinder(0.1, 0.5), Pose()),
        Obstacle("e", Ellipsoid(0.1, 0.2, 0.3), Pose()),
        Obstacle("k", Capsule(0.05, 0.2), Pose()),
    ]
    packed = pack_obstacles(obstacles)
    np.testing.assert_array_equal(packed.kinds, [SPHERE, BOX, CYLINDER, ELLIPSOID, CAPSULE])
    np.testing.assert_allclose(packed.rows[0, :3], (1, 2, 3))
    np.testing.assert_allclose(packed.rows[1, 3:12].reshape(3, 3), obstacles[1].pose.rotation)
    np.testing.assert_allclose(packed.rows[:, 12:15], [
        [0.1, 0, 0], [0.1, 0.2, 0.3], [0.1, 0.25, 0], [0.1, 0.2, 0.3], [0.05, 0.1, 0]])
    np.testing.assert_array_equal(packed.rows[:, 15], -1.0)
    assert packed.triangles.shape == (0, 3, 3) and packed.mesh_table.shape == (0, 5)
    assert pack_obstacles([]).kinds.shape == (0,)


def test_pack_rejects_non_obstacles():
    with pytest.raises(InvalidInput) as info:
        pack_obstacles([Obstacle("a", Sphere(0.1), Pose()), Sphere(0.1)])  # type: ignore[list-item]
    assert info.value.field == "obstacles[1]"


def test_obstacle_type_and_bounding_radius():
    obstacle = Obstacle("k", Capsule(radius=0.05, height=0.2), Pose())
    assert obstacle.type == "Capsule"
    assert obstacle.bounding_radius() == pytest.approx(0.15)
    assert Obstacle("b", Box(0.2, 0.2, 0.2), Pose()).bounding_radius() == pytest.approx(np.sqrt(0.03))
