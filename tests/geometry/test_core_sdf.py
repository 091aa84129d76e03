"""The compiled core's signed distances: the numba kernels' exact values, and independent oracles.

:func:`pfield.geometry.signed_distances` runs the core (``src/core/geometry``); the Python faces
:func:`~pfield.geometry.obstacle_signed_distance`, ``_within`` and :func:`~pfield.geometry.min_signed_distance`
route to it. Two kinds of check:

* **the numba kernels' bits**: until issue 32 removed them, numba kernels computed every signed distance too, and
  the core was held equal to them bit for bit (signed zeros included) on every shape and mesh (watertight,
  non-convex, open) in random and exact (identity, half-turn) poses, at points inside, outside, on surfaces, at
  centres, on axes and symmetry planes, on the medial axis (equally deep faces, cylinder cap-and-wall ties) and
  on mesh vertices and edges (ties between triangles, decided by the BVH traversal order), exact and with a
  cutoff. :data:`NUMBA_DIGEST` is the digest of those outputs on the seeded cases of :func:`_cases`, recorded
  when the core and numba still agreed on every one of them: a plan or a clearance keeps its last digit.
* **oracles**: trimesh's closest points and signed distances for meshes, the closed forms of the primitives
  (``_helpers``), and the normal as a finite-difference gradient; the closest surface point ``p − d n`` found
  from the normal lies on the surface.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator

import numpy as np
import pytest
import trimesh

from digests import digest
from pfield.errors import InvalidInput
from pfield.geometry import (
    Box,
    Capsule,
    Cylinder,
    Ellipsoid,
    Mesh,
    Obstacle,
    ResourceResolver,
    Shape,
    Sphere,
    distances,
    empty_packed,
    min_signed_distance,
    nearest_distances,
    obstacle_signed_distance,
    obstacle_signed_distance_within,
    pack_obstacles,
    signed_distances,
)
from pfield.geometry.packed import MESH
from pfield.spatial import Pose

from ._helpers import (
    MESHES,
    box_reference,
    capsule_reference,
    cylinder_reference,
    finite_difference_gradient,
    to_local,
    triangle_distance_reference,
)

RESOLVER = ResourceResolver(allowed_roots=[MESHES])


@functools.cache
def _meshes() -> tuple[Mesh, ...]:
    """Built on first use, not while pytest collects."""
    cube = trimesh.load(MESHES / "unit_cube.obj", force="mesh")
    icosphere = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    torus = trimesh.creation.torus(major_radius=0.3, minor_radius=0.1, major_sections=24, minor_sections=12)
    meshes = (
        Mesh(str(MESHES / "unit_cube.stl"), 0.4, 0.3, 0.2, resolver=RESOLVER),
        Mesh(str(MESHES / "cylinder_448.stl"), resolver=RESOLVER),
        Mesh.from_arrays(torus.vertices, torus.faces, name="torus"),
        Mesh.from_arrays(cube.vertices, cube.faces[1:], name="open-cube"),  # one face missing: unsigned
        Mesh.from_arrays(icosphere.vertices, icosphere.faces[: len(icosphere.faces) // 2], name="open-cap"),
    )
    assert [mesh.watertight for mesh in meshes] == [True, True, True, False, False]
    return meshes


# ---- the seeded cases ----------------------------------------------------------------------------------------

DYADIC = (0.125, 0.25, 0.5)  # exact ties: equal box faces, a cylinder as wide as it is half tall
EXACT_QUATERNIONS = ((0.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0))
"""Identity and half-turns keep local coordinates exact, so the points below land exactly on axes and ties."""
CUTOFFS = (0.0, 0.01, 0.1, math.inf)
POINT_KINDS = ("random", "vertex", "edge", "face", "centre", "off-vertex")


def _size(rng: np.random.Generator) -> float:
    return float(rng.choice(DYADIC)) if rng.random() < 0.5 else float(rng.uniform(0.02, 0.6))


def _shape(rng: np.random.Generator) -> Shape:
    kind = int(rng.integers(6))
    if kind == 5:
        return _meshes()[int(rng.integers(len(_meshes())))]
    sizes = [_size(rng) for _ in range(3)]
    return (Sphere(sizes[0]), Box(*sizes), Cylinder(*sizes[:2]), Ellipsoid(*sizes), Capsule(*sizes[:2]))[kind]


def _pose(rng: np.random.Generator) -> Pose:
    position = (0.0, 0.0, 0.0) if rng.random() < 0.3 else tuple(rng.uniform(-1.0, 1.0, 3))
    if rng.random() < 0.4:
        return Pose(position, EXACT_QUATERNIONS[int(rng.integers(4))])
    quaternion = rng.uniform(-1.0, 1.0, 4)
    while np.linalg.norm(quaternion) <= 0.1:
        quaternion = rng.uniform(-1.0, 1.0, 4)
    return Pose(position, quaternion)


def _local_point(rng: np.random.Generator, shape: Shape) -> np.ndarray:
    """A point in the shape's frame: random, or built from the shape's own numbers so that ties are exact."""
    extent = shape.bounding_radius()
    if isinstance(shape, Mesh):
        vertices, faces = shape.data.vertices, shape.data.faces
        a, b, c = vertices[faces[int(rng.integers(len(faces)))]]
        kind = POINT_KINDS[int(rng.integers(len(POINT_KINDS)))]
        return {
            "random": lambda: rng.uniform(-1.5 * extent, 1.5 * extent, 3),
            "vertex": lambda: a,
            "edge": lambda: 0.5 * (a + b),
            "face": lambda: (a + b + c) / 3.0,
            "centre": lambda: np.zeros(3),
            "off-vertex": lambda: a * float(rng.choice([0.5, 0.9, 1.1, 2.0])),
        }[kind]()
    sizes = [value for value in shape.packed_sizes() if value > 0.0]
    special = [0.0, *sizes, *(-s for s in sizes), *(0.5 * s for s in sizes), *(s - 0.0625 for s in sizes),
               1e-101, -1e-101, 1e-12, 2.0 * extent]
    return np.array([float(rng.choice(special)) if rng.random() < 0.5 else float(rng.uniform(-1.5 * extent,
                                                                                               1.5 * extent))
                     for _ in range(3)])


def _cases(count: int = 600) -> Iterator[tuple[list[Obstacle], np.ndarray, float]]:
    """``count`` seeded cases: two obstacles, six points about them (world frame) and a cutoff."""
    rng = np.random.default_rng(20260301)
    for _ in range(count):
        obstacles = [Obstacle(f"o{k}", _shape(rng), _pose(rng)) for k in range(2)]
        points = []
        for _ in range(6):
            obstacle = obstacles[int(rng.integers(2))]
            points.append(obstacle.pose.transform_points(_local_point(rng, obstacle.shape)[None, :])[0])
        yield obstacles, np.array(points), CUTOFFS[int(rng.integers(len(CUTOFFS)))]


def _outputs() -> Iterator[np.ndarray]:
    """The core's distances and normals on every case, exact and with the case's cutoff, in a fixed order."""
    for obstacles, points, cutoff in _cases():
        packed = pack_obstacles(obstacles)
        yield from signed_distances(packed, points)
        yield from signed_distances(packed, points, cutoff)



NUMBA_DIGEST = "2f3bb416ab745264ab8ff5b089cf78a59aaee7a8f8c3b71a7ad8d14a806dd2b0"
"""``digest(_outputs())`` when each of its values was checked equal, bit for bit, to numba's
``obstacle_signed_distance`` / ``obstacle_signed_distance_within`` (issue 32, before numba was removed)."""


def test_the_distances_are_the_numba_kernels_bit_for_bit() -> None:
    assert digest(_outputs()) == NUMBA_DIGEST


def test_the_cases_draw_every_shape_both_mesh_kinds_and_every_point_kind() -> None:
    """A guard on :func:`_cases`: it sees each shape, watertight and open meshes, exact poses and every cutoff."""
    shapes, cutoffs, exact = set(), set(), 0
    for obstacles, _, cutoff in _cases():
        cutoffs.add(cutoff)
        for obstacle in obstacles:
            shape = obstacle.shape
            shapes.add(shape.data.source if isinstance(shape, Mesh) else type(shape).__name__)
            exact += tuple(obstacle.pose.orientation) in EXACT_QUATERNIONS
    assert {"Sphere", "Box", "Cylinder", "Ellipsoid", "Capsule"} <= shapes
    assert {"memory://torus", "memory://open-cube", "memory://open-cap"} <= shapes
    assert cutoffs == set(CUTOFFS) and exact > 100


# ---- the Python faces --------------------------------------------------------------------------------------

def test_the_python_faces_are_the_batch_row_for_row() -> None:
    """obstacle_signed_distance(_within) and min_signed_distance give the batch's values, bit for bit."""
    rng = np.random.default_rng(7)
    shapes = [Sphere(0.3), Box(0.4, 0.2, 0.6), Cylinder(0.15, 0.5), Capsule(0.1, 0.3), Ellipsoid(0.3, 0.1, 0.2),
              *_meshes()]
    obstacles = [Obstacle(f"o{i}", shape, Pose(rng.uniform(-0.5, 0.5, 3), rng.normal(size=4)))
                 for i, shape in enumerate(shapes)]
    packed = pack_obstacles(obstacles)
    points = rng.uniform(-1.0, 1.0, (300, 3))
    distances, normals = signed_distances(packed, points)
    bounded, bounded_normals = signed_distances(packed, points, 0.05)
    for k in range(0, 300, 7):
        for i in range(len(obstacles)):
            assert obstacle_signed_distance(packed, i, points[k]) == (distances[k, i], *normals[k, i])
            assert obstacle_signed_distance_within(packed, i, points[k], 0.05) == (bounded[k, i],
                                                                                  *bounded_normals[k, i])
        best = int(np.argmin(distances[k]))
        assert min_signed_distance(packed, points[k]) == (distances[k, best], *normals[k, best], best)
    empty_d, empty_n = signed_distances(empty_packed(), points)
    assert empty_d.shape == (300, 0) and empty_n.shape == (300, 0, 3)
    assert min_signed_distance(empty_packed(), points[0]) == (math.inf, 0.0, 0.0, 0.0, -1)
    with pytest.raises(IndexError):
        obstacle_signed_distance(packed, len(obstacles), points[0])


# ---- oracles -----------------------------------------------------------------------------------------------

def _trimesh(mesh: Mesh) -> trimesh.Trimesh:
    return trimesh.Trimesh(mesh.data.vertices, mesh.data.faces, process=False)


@pytest.mark.parametrize("index", range(5), ids=["cube", "cylinder_448", "torus", "open-cube", "open-cap"])
def test_mesh_distances_are_trimesh_closest_points_and_signs(index: int) -> None:
    """|d| is the distance to the nearest triangle (brute force over all of them) and never more than trimesh's
    closest point's (an upper bound: trimesh's own search is approximate, 1e-7 m off inside the 448-triangle
    cylinder); the sign is trimesh's inside test on a watertight mesh (negative inside), none on an open one; the
    point p − d n lies on the surface (the normal points at the closest point)."""
    mesh = _meshes()[index]
    pose = Pose((0.2, -0.1, 0.3), (0.3, -0.2, 0.5, 0.8))
    packed = pack_obstacles([Obstacle("m", mesh, pose)])
    rng = np.random.default_rng(index)
    extent = mesh.bounding_radius()
    local = rng.uniform(-1.5 * extent, 1.5 * extent, (400, 3))
    distances, normals = signed_distances(packed, pose.transform_points(local))
    d, n = distances[:, 0], to_local(pose, normals[:, 0] + pose.position)
    reference = _trimesh(mesh)
    _, unsigned, _ = trimesh.proximity.closest_point(reference, local)
    assert np.all(np.abs(d) <= unsigned + 1e-12)
    triangles = mesh.data.vertices[mesh.data.faces]
    brute_force = [triangle_distance_reference(triangles, point) for point in local]
    np.testing.assert_allclose(np.abs(d), brute_force, rtol=0, atol=1e-12)
    if mesh.watertight:
        inside = trimesh.proximity.signed_distance(reference, local) > 1e-9  # trimesh: positive inside
        assert np.all(d[inside] < 0.0) and np.all(d[~inside] >= -1e-12)
        assert inside.any() and (~inside).any()
    else:
        assert np.all(d >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, rtol=0, atol=1e-12)
    on_surface = trimesh.proximity.closest_point(reference, local - d[:, None] * n)[1]
    np.testing.assert_allclose(on_surface, 0.0, rtol=0, atol=1e-9)


@pytest.mark.parametrize("index", range(5), ids=["cube", "cylinder_448", "torus", "open-cube", "open-cap"])
def test_mesh_normals_are_the_finite_difference_gradient(index: int) -> None:
    mesh = _meshes()[index]
    packed = pack_obstacles([Obstacle("m", mesh, Pose((0.1, 0.0, -0.2), (0.0, 0.6, 0.0, 0.8)))])
    rng = np.random.default_rng(10 + index)
    extent = mesh.bounding_radius()
    points = rng.uniform(-1.5 * extent, 1.5 * extent, (120, 3)) + np.array([0.1, 0.0, -0.2])
    _, normals = signed_distances(packed, points)
    checked = 0
    for point, normal in zip(points, normals[:, 0], strict=True):
        gradient = finite_difference_gradient(lambda x: signed_distances(packed, x)[0][0, 0], point)
        if abs(np.linalg.norm(gradient) - 1.0) > 1e-4:
            continue  # the stencil straddles the medial axis (or an open mesh's surface), where d has a kink
        checked += 1
        np.testing.assert_allclose(normal, gradient, atol=1e-5)
    assert checked > 100


def test_primitive_distances_on_the_seeded_cases_are_the_closed_forms() -> None:
    """The points of :func:`_cases` (ties, axes, the surface) against the clamp constructions of ``_helpers``."""
    references = {
        Sphere: lambda q, s: np.linalg.norm(q, axis=1) - s.radius,
        Box: lambda q, s: box_reference(q, np.array(s.packed_sizes())),
        Cylinder: lambda q, s: cylinder_reference(q, s.radius, 0.5 * s.height),
        Capsule: lambda q, s: capsule_reference(q, s.radius, 0.5 * s.height),
    }
    checked = 0
    for obstacles, points, _ in _cases(200):
        distances, _ = signed_distances(pack_obstacles(obstacles), points)
        for i, obstacle in enumerate(obstacles):
            reference = references.get(type(obstacle.shape))  # type: ignore[call-overload]
            if reference is not None:
                expected = reference(to_local(obstacle.pose, points), obstacle.shape)
                np.testing.assert_allclose(distances[:, i], expected, rtol=0, atol=1e-12)
                checked += len(points)
    assert checked > 1000


def test_hand_built_packed_sets_give_nan_or_a_value_error() -> None:
    row = np.zeros((1, 16))
    row[0, 3:12] = np.eye(3).reshape(-1)
    no_mesh = empty_packed()._replace(kinds=np.array([MESH]), rows=row)  # names mesh 0, which is not packed
    distances, normals = signed_distances(no_mesh, np.zeros((1, 3)))
    assert np.isnan(distances).all() and np.isnan(normals).all()
    cube = pack_obstacles([Obstacle("c", _meshes()[0], Pose())])
    nodes = cube.bvh_nodes.copy()
    nodes[nodes[:, 2] == 0, :2] = 0  # every inner node's children: the root, a cycle
    looping = cube._replace(bvh_nodes=nodes)
    with pytest.raises(ValueError, match="child"):
        signed_distances(looping, np.zeros((1, 3)))
    with pytest.raises(ValueError, match="differ in length"):
        signed_distances(cube._replace(kinds=np.zeros(2, np.int64)), np.zeros((1, 3)))


def _check_subtree(bvh, triangles: np.ndarray, k: int) -> tuple[int, int]:  # type: ignore[no-untyped-def]
    """(first, count) of the leaf positions under node k, after checking its box and its children."""
    left, right, leaf = (int(v) for v in bvh.nodes[k])
    if leaf:
        members = triangles[bvh.order[left:left + right]]
        assert np.all(members.min(axis=(0, 1)) == bvh.lower[k])
        assert np.all(members.max(axis=(0, 1)) == bvh.upper[k])
        return left, right
    assert k < left < right
    (first, n_left), (second, n_right) = _check_subtree(bvh, triangles, left), _check_subtree(bvh, triangles, right)
    assert second == first + n_left and n_right - n_left in (0, 1)
    assert np.all(bvh.lower[k] == np.minimum(bvh.lower[left], bvh.lower[right]))
    assert np.all(bvh.upper[k] == np.maximum(bvh.upper[left], bvh.upper[right]))
    return first, n_left + n_right


def test_mesh_bvh_is_a_median_split_over_all_triangles() -> None:
    """The core's BVH build (pfield.geometry._mesh_build.build_bvh): leaves partition the triangles in the stored
    order, every box holds its triangles and children, children follow their parent, halves differ by at most one.
    (It matched the numba build it replaced array for array on these meshes and on random ones.)"""
    from pfield.geometry._mesh_build import build_bvh

    for mesh in _meshes():
        triangles = mesh.data.vertices[mesh.data.faces]
        bvh = build_bvh(triangles)
        assert sorted(bvh.order.tolist()) == list(range(len(triangles)))
        assert _check_subtree(bvh, triangles, 0) == (0, len(triangles))


def test_the_distance_only_batches_are_signed_distances_bit_for_bit() -> None:
    """``distances`` is ``signed_distances``' first array (exact and with the case's cutoff), ``nearest_distances``
    each point's ``min_signed_distance`` d, to the bit, on every seeded case (every shape, both mesh kinds)."""
    bits = functools.partial(np.ndarray.view, dtype=np.int64)
    for obstacles, points, cutoff in _cases(200):
        packed = pack_obstacles(obstacles)
        for limit in (math.inf, cutoff):
            expected = signed_distances(packed, points, limit)[0]
            assert np.array_equal(bits(distances(packed, points, limit)), bits(expected))
        nearest = np.array([min_signed_distance(packed, point)[0] for point in points])
        assert np.array_equal(bits(nearest_distances(packed, points)), bits(nearest))


def test_the_distance_only_batches_fill_the_callers_buffer_and_refuse_a_bad_one() -> None:
    packed = pack_obstacles([Obstacle("s", Sphere(0.5), Pose()), Obstacle("b", Box(0.4, 0.4, 0.4), Pose((2, 0, 0)))])
    points = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    table, nearest = np.full((3, 2), 7.0), np.full(3, 7.0)
    assert distances(packed, points, out=table) is table
    assert nearest_distances(packed, points, out=nearest) is nearest
    # d = |p| − 0.5 to the sphere, |x − 2| − 0.2 to the box (half extents 0.2): exact in binary here
    np.testing.assert_array_equal(table, [[-0.5, 1.8], [2.5, 0.8], [0.5, 0.8]])
    np.testing.assert_array_equal(nearest, [-0.5, 0.8, 0.5])
    assert distances(packed, points[0]).shape == (1, 2)  # one (3,) point
    read_only = np.zeros((3, 2))
    read_only.setflags(write=False)
    for bad in (np.zeros((3, 3)), np.zeros((3, 2), np.float32), np.zeros((2, 3)).T, read_only, [[0.0] * 2] * 3):
        with pytest.raises(InvalidInput) as info:
            distances(packed, points, out=bad)  # type: ignore[arg-type]
        assert info.value.field == "out"
    with pytest.raises(InvalidInput) as info:
        nearest_distances(packed, points, out=np.zeros(2))
    assert info.value.field == "out"
    for call in (lambda: distances(packed, [[0.0, math.nan, 0.0]], out=table[:1]),
                 lambda: nearest_distances(packed, [[math.inf, 0.0, 0.0]], out=nearest[:1])):
        with pytest.raises(InvalidInput) as info:
            call()
        assert info.value.field == "points"
    np.testing.assert_array_equal(nearest, [-0.5, 0.8, 0.5])  # refused: the buffers are as they were
    np.testing.assert_array_equal(table, [[-0.5, 1.8], [2.5, 0.8], [0.5, 0.8]])
    assert nearest_distances(empty_packed(), points).tolist() == [math.inf] * 3
    assert distances(empty_packed(), points).shape == (3, 0)
