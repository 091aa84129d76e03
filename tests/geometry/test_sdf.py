"""Signed distances of the primitive shapes against independent references, and their normals."""

from __future__ import annotations

import numpy as np
import pytest

from pfield.geometry import (
    Box,
    Capsule,
    Cylinder,
    Ellipsoid,
    Obstacle,
    Sphere,
    empty_packed,
    min_signed_distance,
    obstacle_signed_distance,
    pack_obstacles,
    signed_distances,
)
from pfield.spatial import Pose

from ._helpers import (
    box_reference,
    capsule_reference,
    cylinder_reference,
    ellipsoid_reference,
    finite_difference_gradient,
    random_pose,
    to_local,
)

TOLERANCE = 1e-6


def _sample(rng: np.random.Generator, pose: Pose, extent: float, count: int) -> np.ndarray:
    """Points around the obstacle: half in the bounding cube, half near the centre (mostly inside)."""
    local = np.concatenate([rng.uniform(-extent, extent, (count // 2, 3)),
                            rng.uniform(-0.3 * extent, 0.3 * extent, (count - count // 2, 3))])
    return pose.transform_points(local)


PRIMITIVE_CASES = [
    (Sphere(radius=0.3), lambda q: np.linalg.norm(q, axis=1) - 0.3),
    (Box(length=0.4, width=0.2, height=0.6), lambda q: box_reference(q, np.array([0.2, 0.1, 0.3]))),
    (Cylinder(radius=0.15, height=0.5), lambda q: cylinder_reference(q, 0.15, 0.25)),
    (Capsule(radius=0.1, height=0.3), lambda q: capsule_reference(q, 0.1, 0.15)),
]


@pytest.mark.parametrize(("shape", "reference"), PRIMITIVE_CASES, ids=lambda v: type(v).__name__)
def test_primitive_distance_matches_closed_form(shape, reference, rng):
    for _ in range(3):
        pose = random_pose(rng)
        points = _sample(rng, pose, 0.6, 400)
        distances, _ = Obstacle("o", shape, pose).signed_distance(points)
        expected = reference(to_local(pose, points))
        assert np.any(expected < 0) and np.any(expected > 0)
        np.testing.assert_allclose(distances, expected, atol=TOLERANCE, rtol=0)


def test_ellipsoid_distance_matches_numerical_minimisation(rng):
    semi = np.array([0.3, 0.1, 0.2])
    pose = random_pose(rng)
    obstacle = Obstacle("e", Ellipsoid(semi_x=0.3, semi_y=0.1, semi_z=0.2), pose)
    points = _sample(rng, pose, 0.45, 16)
    distances, _ = obstacle.signed_distance(points)
    expected = [ellipsoid_reference(q, semi) for q in to_local(pose, points)]
    assert min(expected) < 0 < max(expected)
    np.testing.assert_allclose(distances, expected, atol=TOLERANCE, rtol=0)


@pytest.mark.parametrize(
    ("point", "expected_distance", "expected_normal"),
    [
        ((0.0, 0.0, 0.0), -0.1, (0.0, 1.0, 0.0)),  # centre: nearest along the smallest axis, + side
        ((0.5, 0.0, 0.0), 0.2, (1.0, 0.0, 0.0)),  # on the long axis, outside
        ((0.0, 0.0, -0.5), 0.3, (0.0, 0.0, -1.0)),
        ((0.3, 0.0, 0.0), 0.0, (1.0, 0.0, 0.0)),  # vertex of the long axis, on the surface
        ((0.0, 0.05, 0.0), -0.05, (0.0, 1.0, 0.0)),  # inside on the short axis
    ],
)
def test_ellipsoid_axes_and_centre(point, expected_distance, expected_normal):
    obstacle = Obstacle("e", Ellipsoid(semi_x=0.3, semi_y=0.1, semi_z=0.2), Pose())
    distance, normal = obstacle.signed_distance(point)
    assert distance[0] == pytest.approx(expected_distance, abs=1e-12)
    np.testing.assert_allclose(normal[0], expected_normal, atol=1e-12)


def test_ellipsoid_inside_point_near_the_flat_plane_leaves_the_plane():
    # Inside, on the plane z = 0 of an ellipsoid flattened in z: the closest point is off the plane
    # (Eberly's special case), so the distance is smaller than to the in-plane ellipse.
    semi = np.array([0.3, 0.25, 0.05])
    q = np.array([0.1, 0.05, 0.0])
    distance, normal = Obstacle("e", Ellipsoid(*semi), Pose()).signed_distance(q)
    assert distance[0] == pytest.approx(ellipsoid_reference(q, semi), abs=TOLERANCE)
    assert normal[0, 2] > 0.9  # + side chosen on the tie


def test_ellipsoid_of_equal_axes_is_a_sphere(rng):
    points = rng.uniform(-0.4, 0.4, (300, 3))
    ellipsoid, _ = Obstacle("e", Ellipsoid(0.2, 0.2, 0.2), Pose()).signed_distance(points)
    spheroid, _ = Obstacle("s", Ellipsoid(0.2, 0.2, 0.1), Pose()).signed_distance(points)
    np.testing.assert_allclose(ellipsoid, np.linalg.norm(points, axis=1) - 0.2, atol=1e-12)
    assert np.all(spheroid >= ellipsoid - 1e-12)  # the spheroid lies inside the sphere


SHAPES = [
    Sphere(0.3), Box(0.4, 0.2, 0.6), Cylinder(0.15, 0.5), Capsule(0.1, 0.3), Ellipsoid(0.3, 0.1, 0.2),
]


@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: type(s).__name__)
def test_normal_is_the_finite_difference_gradient(shape, rng):
    pose = random_pose(rng)
    obstacle = Obstacle("o", shape, pose)
    points = _sample(rng, pose, 0.6, 200)
    _, normals = obstacle.signed_distance(points)
    checked = 0
    for point, normal in zip(points, normals, strict=True):
        gradient = finite_difference_gradient(lambda x: obstacle.signed_distance(x)[0][0], point)
        if abs(np.linalg.norm(gradient) - 1.0) > 1e-4:
            continue  # the stencil straddles the medial axis, where d has a kink
        checked += 1
        np.testing.assert_allclose(normal, gradient, atol=1e-5)
    assert checked > 180


@pytest.mark.parametrize(
    ("shape", "point", "distance", "normal"),
    [
        (Sphere(0.3), (0.0, 0.0, 0.0), -0.3, (0.0, 0.0, 1.0)),  # centre: local +z
        (Box(0.4, 0.4, 0.4), (0.0, 0.0, 0.0), -0.2, (1.0, 0.0, 0.0)),  # cube centre: x face first
        (Box(0.4, 0.4, 0.2), (0.0, 0.0, 0.0), -0.1, (0.0, 0.0, 1.0)),  # nearest face wins
        (Box(0.4, 0.2, 0.4), (0.05, 0.0, 0.0), -0.1, (0.0, 1.0, 0.0)),  # y = 0: + side
        (Cylinder(0.1, 1.0), (0.0, 0.0, 0.2), -0.1, (1.0, 0.0, 0.0)),  # on the axis: local +x
        (Cylinder(0.1, 0.2), (0.0, 0.0, 0.0), -0.1, (0.0, 0.0, 1.0)),  # cap and wall tie: the cap
        (Capsule(0.1, 0.4), (0.0, 0.0, 0.1), -0.1, (1.0, 0.0, 0.0)),
        (Capsule(0.1, 0.4), (0.0, 0.0, 0.5), 0.2, (0.0, 0.0, 1.0)),
        (Cylinder(0.1, 0.2), (0.2, 0.0, 0.2), np.sqrt(0.02), (np.sqrt(0.5), 0.0, np.sqrt(0.5))),
    ],
)
def test_exact_values_and_tie_rules(shape, point, distance, normal):
    d, n = Obstacle("o", shape, Pose()).signed_distance(point)
    assert d[0] == pytest.approx(distance, abs=1e-12)
    np.testing.assert_allclose(n[0], normal, atol=1e-12)


def test_rotated_box_normal_is_rotated():
    quarter_turn_z = (0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4))
    obstacle = Obstacle("b", Box(length=0.4, width=0.2, height=0.2), Pose((1.0, 2.0, 3.0), quarter_turn_z))
    d, n = obstacle.signed_distance((1.0, 2.5, 3.0))  # local +x now points along world +y
    assert d[0] == pytest.approx(0.3, abs=1e-12)
    np.testing.assert_allclose(n[0], (0.0, 1.0, 0.0), atol=1e-12)


def test_batch_min_and_empty_kernels_agree(rng):
    obstacles = [Obstacle(f"o{i}", shape, random_pose(rng)) for i, shape in enumerate(SHAPES)]
    packed = pack_obstacles(obstacles)
    points = rng.uniform(-1.5, 1.5, (50, 3))
    distances, normals = signed_distances(packed, points)
    assert distances.shape == (50, 5) and normals.shape == (50, 5, 3)
    for k, point in enumerate(points):
        for i, obstacle in enumerate(obstacles):
            d, n = obstacle.signed_distance(point)
            assert distances[k, i] == d[0]
            np.testing.assert_array_equal(normals[k, i], n[0])
            assert obstacle_signed_distance(packed, i, point)[0] == d[0]
        best = min_signed_distance(packed, point)
        assert best[4] == int(np.argmin(distances[k]))
        assert best[0] == distances[k].min()
    assert min_signed_distance(empty_packed(), points[0]) == (np.inf, 0.0, 0.0, 0.0, -1)
    assert signed_distances(empty_packed(), points)[0].shape == (50, 0)


def test_min_signed_distance_ties_go_to_the_lowest_index():
    twins = [Obstacle("a", Sphere(0.1), Pose((1.0, 0, 0))), Obstacle("b", Sphere(0.1), Pose((-1.0, 0, 0)))]
    assert min_signed_distance(pack_obstacles(twins), np.zeros(3))[4] == 0


def test_bounded_query_is_exact_within_the_cutoff_and_a_lower_bound_beyond(rng):
    from pfield.geometry import Mesh, ResourceResolver, obstacle_signed_distance_within

    from ._helpers import MESHES

    cube = Mesh(str(MESHES / "unit_cube.obj"), 0.2, 0.3, 0.1, resolver=ResourceResolver(allowed_roots=[MESHES]))
    obstacles = [Obstacle(f"o{i}", shape, random_pose(rng, 0.3)) for i, shape in enumerate([*SHAPES, cube])]
    packed = pack_obstacles(obstacles)
    cutoff = 0.1
    beyond = 0
    for point in rng.uniform(-1.0, 1.0, (400, 3)):
        for i in range(len(obstacles)):
            exact = obstacle_signed_distance(packed, i, point)
            bounded = obstacle_signed_distance_within(packed, i, point, cutoff)
            if exact[0] <= cutoff:
                assert bounded == exact
            else:
                beyond += bounded != exact
                assert cutoff < bounded[0] <= exact[0] + 1e-12
                assert abs(np.linalg.norm(bounded[1:]) - 1.0) < 1e-12
    assert beyond > 100  # the cheap bound was actually used


def test_inconsistent_hand_built_mesh_row_gives_nan_not_a_crash():
    from pfield.geometry.packed import MESH

    row = np.zeros((1, 16))
    row[0, 3:12] = np.eye(3).reshape(-1)
    packed = empty_packed()._replace(kinds=np.array([MESH]), rows=row)  # mesh 0 does not exist
    assert all(np.isnan(obstacle_signed_distance(packed, 0, np.zeros(3))))

