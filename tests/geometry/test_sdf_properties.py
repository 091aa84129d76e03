"""Property tests: the signed distance is a distance function (|∇d| = 1, exact along the normal ray)."""

from __future__ import annotations

import functools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, ResourceResolver, Sphere
from pfield.spatial import Pose

from ._helpers import MESHES

sizes = st.floats(min_value=0.02, max_value=0.5)
coordinates = st.floats(min_value=-0.8, max_value=0.8)
unit_quaternions = st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1)

shapes = st.one_of(
    st.builds(Sphere, sizes),
    st.builds(Box, sizes, sizes, sizes),
    st.builds(Cylinder, sizes, sizes),
    st.builds(Ellipsoid, sizes, sizes, sizes),
    st.builds(Capsule, sizes, sizes),
)


@functools.cache
def _cube() -> Mesh:
    """The unit cube mesh, built on first use (not while pytest collects: building it reads a file)."""
    return Mesh(str(MESHES / "unit_cube.stl"), resolver=ResourceResolver(allowed_roots=[MESHES]))


CUBE = st.deferred(lambda: st.just(_cube()))


def _obstacle(shape, quaternion) -> Obstacle:  # type: ignore[no-untyped-def]
    return Obstacle("o", shape, Pose((0.1, -0.2, 0.05), quaternion))


@settings(max_examples=150, deadline=None)
@given(shape=st.one_of(shapes, CUBE), quaternion=unit_quaternions,
       point=st.tuples(coordinates, coordinates, coordinates))
def test_moving_along_the_normal_changes_d_by_the_step(shape, quaternion, point):
    obstacle = _obstacle(shape, quaternion)
    p = np.array(point) + np.array([0.1, -0.2, 0.05])
    (d,), (n,) = obstacle.signed_distance(p)
    assert abs(np.linalg.norm(n) - 1.0) < 1e-12
    # Outside, the closest point stays the same along the outward ray; inside (convex shapes) it stays
    # the same until the surface, so d(p + t n) = d(p) + t for 0 ≤ t ≤ |d|.
    step = 0.01 if d >= 0 else 0.5 * abs(d)
    (moved,), _ = obstacle.signed_distance(p + step * n)
    assert abs(moved - (d + step)) < 1e-9
    # The closest surface point p − d n lies on the surface.
    (on_surface,), _ = obstacle.signed_distance(p - d * n)
    assert abs(on_surface) < 1e-9


@settings(max_examples=100, deadline=None)
@given(shape=shapes, quaternion=unit_quaternions, point=st.tuples(coordinates, coordinates, coordinates),
       other=st.tuples(coordinates, coordinates, coordinates))
def test_signed_distance_is_1_lipschitz(shape, quaternion, point, other):
    obstacle = _obstacle(shape, quaternion)
    d, _ = obstacle.signed_distance(np.array([point, other]))
    assert abs(d[0] - d[1]) <= np.linalg.norm(np.subtract(point, other)) + 1e-12


@settings(max_examples=100, deadline=None)
@given(shape=shapes, quaternion=unit_quaternions, point=st.tuples(coordinates, coordinates, coordinates))
def test_rigid_motion_invariance(shape, quaternion, point):
    local_obstacle = Obstacle("o", shape, Pose())
    moved = _obstacle(shape, quaternion)
    d_local, n_local = local_obstacle.signed_distance(point)
    d_world, n_world = moved.signed_distance(moved.pose.transform_points(np.array(point)))
    assert abs(d_local[0] - d_world[0]) < 1e-12
    if d_local[0] > 1e-6:  # outside a convex shape the closest point, hence the normal, is unique
        np.testing.assert_allclose(moved.pose.rotation @ n_local[0], n_world[0], atol=1e-9)


def test_an_ellipsoid_is_measured_right_at_points_a_hair_from_its_centre() -> None:
    """Coordinates between 1e-100 (taken as 0) and about 1e-65 of an axis: the root solve began from a bracket
    [z2, 1] around a root of 1e-70, where Halley's steps shrink u by a constant factor and ran out of iterations
    (the distance came out as -1.7e-9 instead of -0.5). Found by the rigid-motion property above."""
    for axes, deepest in (((0.5, 0.5, 0.5), -0.5), ((0.5, 0.3, 0.2), -0.2)):
        obstacle = Obstacle("o", Ellipsoid(*axes), Pose())
        for tiny in (1e-30, 1e-70, 2.79e-77, 1e-90, 1e-99):
            for point in ((0.0, tiny, tiny), (tiny, tiny, tiny), (tiny, 0.0, 0.0)):
                assert abs(obstacle.signed_distance(np.array(point))[0][0] - deepest) < 1e-12, (axes, point)
