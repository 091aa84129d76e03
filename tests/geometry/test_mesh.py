"""Mesh obstacles: loading, scale, exact distances, the sign, caching and bad files."""

from __future__ import annotations

import logging
import shutil

import numpy as np
import pytest
import trimesh

from pfield.errors import InvalidInput, ResourceNotFound
from pfield.geometry import Box, Mesh, Obstacle, ResourceResolver, load_mesh_arrays, pack_obstacles, signed_distances
from pfield.spatial import Pose

from ._helpers import MESHES, PACKAGE, random_pose, to_local, triangle_distance_reference, winding_number

RESOLVER = ResourceResolver(allowed_roots=[MESHES], package_paths={"my_robot_description": PACKAGE})


@pytest.mark.parametrize("suffix", ["obj", "stl", "dae"])
def test_unit_cube_exact_values(suffix):
    cube = Obstacle("cube", Mesh(str(MESHES / f"unit_cube.{suffix}"), resolver=RESOLVER), Pose())
    assert cube.shape.watertight
    assert len(cube.shape.data.faces) == 12
    d, n = cube.signed_distance([(0.8, 0.0, 0.0), (0.8, 0.9, 0.0), (0.0, 0.0, 0.3)])
    np.testing.assert_allclose(d, [0.3, 0.5, -0.2], atol=1e-12)
    np.testing.assert_allclose(n[0], (1.0, 0.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(n[1], (0.6, 0.8, 0.0), atol=1e-12)
    np.testing.assert_allclose(n[2], (0.0, 0.0, 1.0), atol=1e-12)


def test_scaled_rotated_cube_mesh_equals_the_box(rng):
    pose = random_pose(rng)
    mesh = Obstacle("m", Mesh(f"file://{MESHES}/unit_cube.obj", 0.4, 0.2, 0.6, resolver=RESOLVER), pose)
    box = Obstacle("b", Box(length=0.4, width=0.2, height=0.6), pose)
    points = pose.transform_points(rng.uniform(-0.5, 0.5, (500, 3)))
    d_mesh, n_mesh = mesh.signed_distance(points)
    d_box, n_box = box.signed_distance(points)
    np.testing.assert_allclose(d_mesh, d_box, atol=1e-12)
    assert np.any(d_box < 0)
    # Normals agree wherever the box's closest feature is unique (away from its medial planes).
    local = np.abs(to_local(pose, points)) - np.array([0.2, 0.1, 0.3])
    top_two = np.sort(local, axis=1)[:, -2:]
    unique = (d_box > 0) | (top_two[:, 1] - top_two[:, 0] > 1e-9)
    np.testing.assert_allclose(n_mesh[unique], n_box[unique], atol=1e-9)


def test_448_triangle_mesh_against_brute_force(rng):
    obstacle = Obstacle("c", Mesh(str(MESHES / "cylinder_448.stl"), resolver=RESOLVER), random_pose(rng, 0.2))
    triangles = obstacle.shape.data.vertices[obstacle.shape.data.faces]
    assert len(triangles) == 448
    points = obstacle.pose.transform_points(rng.uniform(-0.15, 0.15, (150, 3)))
    distances, _ = obstacle.signed_distance(points)
    for point, distance in zip(to_local(obstacle.pose, points), distances, strict=True):
        unsigned = triangle_distance_reference(triangles, point)
        sign = -1.0 if winding_number(triangles, point) > 0.5 else 1.0
        assert distance == pytest.approx(sign * unsigned, abs=1e-12)
    assert np.any(distances < 0) and np.any(distances > 0)


def test_seed_package_mesh_loads_through_package_uri():
    mesh = Mesh("package://my_robot_description/meshes/obstacle.dae", resolver=RESOLVER)
    obstacle = Obstacle("mesh_obs", mesh, Pose((0.5, 0.0, 0.1)))
    assert mesh.watertight and mesh.source == str(PACKAGE / "meshes" / "obstacle.dae")
    d, n = obstacle.signed_distance([(0.5, 0.0, 0.1), (0.5, 0.0, 0.3)])
    assert -0.05 < d[0] < -0.04  # centre of an icosphere of radius 0.05
    assert d[1] == pytest.approx(0.15, abs=1e-6)  # above the pole vertex (COLLADA stores ~7 digits)
    np.testing.assert_allclose(n[1], (0.0, 0.0, 1.0), atol=1e-6)


def test_open_mesh_is_unsigned_with_a_warning(tmp_path, caplog):
    cube = trimesh.load(MESHES / "unit_cube.obj", force="mesh")
    cube.update_faces(np.arange(len(cube.faces)) != 0)
    cube.export(tmp_path / "open.obj")
    with caplog.at_level(logging.WARNING, logger="pfield.geometry.mesh"):
        mesh = Mesh(str(tmp_path / "open.obj"), resolver=ResourceResolver(allowed_roots=[tmp_path]))
    assert not mesh.watertight
    assert "not watertight" in caplog.text
    d, _ = Obstacle("o", mesh, Pose()).signed_distance([(0.0, 0.0, 0.1), (0.0, 0.0, 0.9)])
    assert d[0] == pytest.approx(0.4, abs=1e-12)  # unsigned inside
    assert d[1] == pytest.approx(0.4, abs=1e-12)


def test_inward_oriented_mesh_is_flipped(tmp_path):
    cube = trimesh.load(MESHES / "unit_cube.obj", force="mesh")
    trimesh.Trimesh(cube.vertices, cube.faces[:, ::-1], process=False).export(tmp_path / "inverted.obj")
    mesh = Mesh(str(tmp_path / "inverted.obj"), resolver=ResourceResolver(allowed_roots=[tmp_path]))
    d, n = Obstacle("o", mesh, Pose()).signed_distance((0.0, 0.0, 0.3))
    assert d[0] == pytest.approx(-0.2, abs=1e-12)
    np.testing.assert_allclose(n[0], (0.0, 0.0, 1.0), atol=1e-12)


def test_obstacles_sharing_a_mesh_share_its_arrays():
    mesh = Mesh(str(MESHES / "unit_cube.stl"), resolver=RESOLVER)
    other = Mesh(str(MESHES / "cylinder_448.stl"), resolver=RESOLVER)
    obstacles = [Obstacle("a", mesh, Pose((2.0, 0, 0))), Obstacle("b", other, Pose()),
                 Obstacle("c", mesh, Pose((-2.0, 0, 0)))]
    packed = pack_obstacles(obstacles)
    assert packed.mesh_table.shape == (2, 5)
    assert packed.triangles.shape == (12 + 448, 3, 3)
    np.testing.assert_array_equal(packed.rows[:, 15], [0.0, 1.0, 0.0])
    d, _ = signed_distances(packed, np.array([[2.0, 0.0, 0.8], [0.0, 0.0, 0.0], [-2.0, 0.0, -0.9]]))
    assert d[0, 0] == pytest.approx(0.3) and d[2, 2] == pytest.approx(0.4) and d[1, 1] < 0


def test_loading_is_cached_and_reloads_when_the_file_changes(tmp_path):
    resolver = ResourceResolver(allowed_roots=[tmp_path])
    shutil.copy(MESHES / "unit_cube.obj", tmp_path / "m.obj")
    first, second = Mesh(str(tmp_path / "m.obj"), resolver=resolver), Mesh(str(tmp_path / "m.obj"), resolver=resolver)
    assert first.data is second.data
    big = trimesh.creation.box((2.0, 2.0, 2.0))
    big.export(tmp_path / "m.obj")
    import os

    stat = os.stat(tmp_path / "m.obj")
    os.utime(tmp_path / "m.obj", ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    reloaded = Mesh(str(tmp_path / "m.obj"), resolver=resolver)
    assert reloaded.data is not first.data
    assert Obstacle("m", reloaded, Pose()).signed_distance((0, 0, 0))[0][0] == pytest.approx(-1.0)


def test_load_mesh_arrays_applies_scale():
    vertices, faces = load_mesh_arrays(str(MESHES / "unit_cube.stl"), RESOLVER, scale=(2.0, 1.0, 0.5))
    assert faces.shape == (12, 3)
    np.testing.assert_allclose(vertices.max(axis=0), (1.0, 0.5, 0.25))


def test_from_arrays_builds_a_mesh():
    cube = trimesh.creation.box((1.0, 1.0, 1.0))
    mesh = Mesh.from_arrays(cube.vertices, cube.faces, name="cube", scale=(2.0, 2.0, 2.0))
    assert mesh.mesh_resource == "memory://cube" and mesh.watertight
    assert Obstacle("m", mesh, Pose()).signed_distance((1.5, 0, 0))[0][0] == pytest.approx(0.5)


@pytest.mark.parametrize(("name", "content", "error"), [
    ("notes.txt", b"hello", InvalidInput),
    ("empty.stl", b"", InvalidInput),
    ("garbage.obj", b"this is not a mesh\n", InvalidInput),
    ("garbage.dae", b"<not collada", InvalidInput),
])
def test_bad_mesh_files(tmp_path, name, content, error):
    (tmp_path / name).write_bytes(content)
    with pytest.raises(error) as info:
        Mesh(str(tmp_path / name), resolver=ResourceResolver(allowed_roots=[tmp_path]))
    assert info.value.field == "mesh_resource"
    assert info.value.value == str(tmp_path / name)


def test_missing_mesh_file(tmp_path):
    with pytest.raises(ResourceNotFound, match="no such file"):
        Mesh(str(tmp_path / "absent.stl"), resolver=ResourceResolver(allowed_roots=[tmp_path]))
    # the root cause first (issue 33): a message's Mesh without scales and without its file is a missing file
    with pytest.raises(ResourceNotFound, match="no such file"):
        Mesh(str(tmp_path / "absent.stl"), 0.0, 0.0, 0.0, resolver=ResourceResolver(allowed_roots=[tmp_path]))


@pytest.mark.parametrize("field", ["scale_x", "scale_y", "scale_z"])
@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_mesh_scale(field, value):
    scales = {"scale_x": 1.0, "scale_y": 1.0, "scale_z": 1.0, field: value}
    with pytest.raises(InvalidInput) as info:
        Mesh(str(MESHES / "unit_cube.obj"), **scales, resolver=RESOLVER)
    assert info.value.field == field


def test_non_convex_torus_sign_matches_the_winding_number(rng):
    torus = trimesh.creation.torus(major_radius=0.3, minor_radius=0.1, major_sections=24, minor_sections=12)
    obstacle = Obstacle("t", Mesh.from_arrays(torus.vertices, torus.faces, name="torus"), Pose())
    triangles = obstacle.shape.data.vertices[obstacle.shape.data.faces]
    points = rng.uniform(-0.45, 0.45, (200, 3)) * (1.0, 1.0, 0.4)
    distances, _ = obstacle.signed_distance(points)
    for point, distance in zip(points, distances, strict=True):
        sign = -1.0 if winding_number(triangles, point) > 0.5 else 1.0
        assert distance == pytest.approx(sign * triangle_distance_reference(triangles, point), abs=1e-12)
    assert np.sum(distances < 0) > 20  # points in the ring, and points in the hole (outside)


def test_closed_mesh_with_inconsistent_winding_is_repaired(tmp_path):
    cube = trimesh.load(MESHES / "unit_cube.obj", force="mesh")
    faces = np.array(cube.faces)
    faces[:3] = faces[:3, ::-1]  # three triangles wound the wrong way
    trimesh.Trimesh(cube.vertices, faces, process=False).export(tmp_path / "sloppy.obj")
    mesh = Mesh(str(tmp_path / "sloppy.obj"), resolver=ResourceResolver(allowed_roots=[tmp_path]))
    assert mesh.watertight
    d, _ = Obstacle("o", mesh, Pose()).signed_distance([(0.0, 0.0, 0.3), (0.0, 0.0, 0.8), (0.1, -0.2, 0.0)])
    np.testing.assert_allclose(d, [-0.2, 0.3, -0.3], atol=1e-12)


@pytest.mark.parametrize("scale", [(1.0, 1.0), (1.0, 0.0, 1.0), (1.0, float("nan"), 1.0)])
def test_load_mesh_arrays_rejects_bad_scales(scale):
    with pytest.raises(InvalidInput):
        load_mesh_arrays(str(MESHES / "unit_cube.stl"), RESOLVER, scale=scale)


def test_each_body_of_a_multi_body_mesh_faces_outward():
    left = trimesh.creation.box((1.0, 1.0, 1.0))
    right = trimesh.creation.box((1.0, 1.0, 1.0))
    right.apply_translation((3.0, 0.0, 0.0))
    right.invert()  # this body's triangles face inward
    both = trimesh.util.concatenate([left, right])
    mesh = Mesh.from_arrays(both.vertices, both.faces, name="two")
    d, _ = Obstacle("o", mesh, Pose()).signed_distance([(0.0, 0.0, 0.3), (3.0, 0.0, 0.3), (1.5, 0.0, 0.0)])
    np.testing.assert_allclose(d, [-0.2, -0.2, 1.0], atol=1e-12)
