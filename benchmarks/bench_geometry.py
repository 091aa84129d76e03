"""Signed-distance speed per point, in the compiled core's batch, for meshes and every primitive shape.

:func:`pfield.geometry.distances` (distances alone, into a buffer reused from call to call) evaluates a few thousand
query points against the obstacles in one call (the core's loop, outside the GIL), the way the field's and the
planners' loops query the core; "nearest of 10" is :func:`pfield.geometry.nearest_distances` (each point's
minimum, as ``min_signed_distance``). The numba engine's rows timed the same: a compiled loop summing each point's
distance (or minimum); neither side writes normals. The time per point is the call's median over the points.
Query points fill a cube three times the obstacle's size around it, so about a quarter are near the surface and
some are inside. C++ figures (REFERENCE.md §3) are whole wrench evaluations (distance + repulsion + attraction) of
the named scene, the closest comparable figure.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from benchmarks._common import BenchRow, median_time
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
    nearest_distances,
    pack_obstacles,
)
from pfield.geometry.packed import PackedObstacles
from pfield.planning.scenes import evaluation_scene
from pfield.spatial import Pose, quaternion_exp

SECTION = "geometry: signed distance per point (compiled loop)"
MESHES = Path(__file__).resolve().parents[1] / "tests" / "data" / "meshes"


def _per_point_us(packed: PackedObstacles, points: np.ndarray, quick: bool, cutoff: float = math.inf) -> float:
    out = np.empty((len(points), len(packed.kinds)))
    seconds = median_time(lambda: distances(packed, points, cutoff, out), repeat=3 if quick else 9,
                          number=1 if quick else 3)
    return seconds / len(points) * 1e6


def _points(rng: np.random.Generator, centre: np.ndarray, half_extent: float, count: int) -> np.ndarray:
    return np.ascontiguousarray(centre + rng.uniform(-half_extent, half_extent, (count, 3)))


# name: (shape, rotation axis of the single obstacle, C++ wrench µs for the 10-obstacle scene)
SCENES: dict[str, tuple[Shape, tuple[float, float, float], float]] = {
    "spheres": (Sphere(0.03), (0.0, 0.0, 1.0), 0.64),
    "boxes": (Box(0.06, 0.04, 0.08), (0.0, 0.0, 1.0), 0.78),
    "cylinders": (Cylinder(0.03, 0.10), (1.0, 0.0, 0.0), 0.84),
    "ellipsoids": (Ellipsoid(0.03, 0.04, 0.05), (0.0, 1.0, 0.0), 0.79),
    "capsules": (Capsule(0.02, 0.08), (1.0, 0.0, 0.0), 0.78),
}


def _mesh_rows(rng: np.random.Generator, quick: bool) -> list[BenchRow]:
    resolver = ResourceResolver(allowed_roots=[MESHES])
    rows = []
    for file_name, label, reference, target in (("cylinder_448.stl", "mesh, 448 triangles", 8.2, 8.0),
                                                  ("unit_cube.stl", "mesh, 12 triangles (unit cube)", 3.4, 3.4)):
        mesh = Mesh(str(MESHES / file_name), resolver=resolver)
        packed = pack_obstacles([Obstacle("m", mesh, Pose((1.0, 0.0, 0.5)))])
        points = _points(rng, np.array([1.0, 0.0, 0.5]), 1.5 * mesh.bounding_radius(), 2000 if quick else 20000)
        value = _per_point_us(packed, points, quick)
        rows.append(BenchRow(SECTION, label, value, "µs/point", reference, target,
                             note="C++ figure: one wrench with this mesh"))
    return rows


def _primitive_rows(rng: np.random.Generator, quick: bool) -> list[BenchRow]:
    rows = []
    count = 5000 if quick else 50000
    for name, (shape, axis, reference) in SCENES.items():
        single = pack_obstacles([Obstacle("o", shape, Pose((0.0, 0.0, 0.0), quaternion_exp(np.multiply(axis, 0.3))))])
        points = _points(rng, np.zeros(3), 1.5 * shape.bounding_radius(), count)
        label = "box" if name == "boxes" else name[:-1]
        rows.append(BenchRow(SECTION, f"one {label}", _per_point_us(single, points, quick) * 1e3, "ns/point"))
        ten = pack_obstacles(evaluation_scene(f"{name}_10"))  # the REFERENCE §2 scene
        scene_points = _points(rng, np.array([0.45, 0.15, 0.40]), 0.4, count // 5)
        out = np.empty(len(scene_points))
        nearest = median_time(lambda: nearest_distances(ten, scene_points, out),  # noqa: B023
                              repeat=3 if quick else 9, number=1 if quick else 3) / len(scene_points) * 1e6
        rows.append(BenchRow(SECTION, f"{name}_10: nearest of 10", nearest, "µs/point", reference, None,
                             note="each point's minimum (nearest_distances); C++ figure: whole wrench of the scene"))
        within = _per_point_us(ten, scene_points, quick, 0.1)
        rows.append(BenchRow(SECTION, f"{name}_10: all 10, cutoff 0.1 m", within, "µs/point", reference, None,
                             note="exact up to the influence distance (a lower bound beyond, as the field needs)"))
    return rows


def run(quick: bool) -> list[BenchRow]:
    """Rows for ``make bench`` (see :mod:`benchmarks.run`)."""
    rng = np.random.default_rng(7)
    return _mesh_rows(rng, quick) + _primitive_rows(rng, quick)
