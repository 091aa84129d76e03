"""The field's batches in the core (``src/core/field/batch.cpp``) give each pose's one-pose value, bit for bit.

``PotentialField.twists`` / ``wrenches`` evaluate several poses side by side in SIMD instructions and on every core;
each row must still be what the one-pose core (``twist`` / ``wrench``, ``src/core/field/evaluate.cpp``) gives at that
position and unit quaternion, whatever the batch size, the thread count, the obstacle kinds or the orientation runs
(the batch reuses a rotation term while rows repeat a quaternion). Compared with ``np.array_equal`` and the signs of
zeros, on random scenes of all six kinds, at sphere centres and between spheres (where several dampers bind and the
later sweeps run), and beyond the batch's kept geometry (4096 obstacles). Rows are checked inside the core: the first
invalid one is named, as ``numba`` named it before (positions first, then the quaternion: finite, norm ≥ 1e-9).
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from numpy.typing import NDArray

from pfield._core import field as core_field
from pfield.errors import InvalidInput
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, ResourceResolver, Sphere
from pfield.planning.scenes import BENCH_GOAL, DEFAULT_PARAMS, evaluation_scene
from pfield.spatial import Pose

MESHES = Path(__file__).resolve().parents[1] / "data" / "meshes"


@functools.cache
def _meshes() -> tuple[Mesh, ...]:
    cap = trimesh.creation.icosphere(subdivisions=1, radius=0.1)
    return (Mesh(str(MESHES / "unit_cube.stl"), 0.2, 0.15, 0.1, resolver=ResourceResolver(allowed_roots=[MESHES])),
            Mesh.from_arrays(cap.vertices, cap.faces[: len(cap.faces) // 2], name="open-cap"))  # unsigned


def _quaternions(rng: np.random.Generator, count: int) -> NDArray[np.float64]:
    """Not normalised, of three magnitudes; runs of equal rows (the rotation reuse) and signed zeros."""
    quats = rng.normal(size=(count, 4)) * rng.choice([1.0, 1e-3, 30.0], size=(count, 1))
    quats[1::3] = quats[0:-1:3][: quats[1::3].shape[0]]
    if count > 7:
        quats[5:8] = ((-0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), (-0.0, 0.0, 0.0, 1.0))
    return quats


def _scene(rng: np.random.Generator, count: int) -> list[Obstacle]:
    size = lambda: float(rng.uniform(0.02, 0.15))  # noqa: E731
    makers = (lambda: Sphere(size()), lambda: Box(size(), size(), size()), lambda: Cylinder(size(), size()),
              lambda: Ellipsoid(size(), size(), size()), lambda: Capsule(size(), size()),
              lambda: _meshes()[int(rng.integers(2))])
    kinds = rng.choice([0, 0, 0, 1, 2, 3, 4, 5], size=count)  # spheres take the side-by-side path: more of them
    return [Obstacle(f"o{i}", makers[kind](), Pose(rng.uniform((0.0, -0.3, 0.0), (1.0, 0.7, 1.0)),
                                                    rng.normal(size=4)))
            for i, kind in enumerate(kinds)]


def _config(rng: np.random.Generator) -> FieldConfig:
    influence = float(rng.uniform(0.1, 1.0))
    return FieldConfig(attractive_gain=float(rng.uniform(0.5, 3.0)),
                       rotational_attractive_gain=float(rng.uniform(0.1, 1.0)),
                       repulsive_gain=float(rng.uniform(0.05, 0.5)), max_linear_velocity=float(rng.uniform(0.05, 5.0)),
                       influence_distance=influence, safety_distance=float(rng.uniform(0.0, 0.5 * influence)),
                       damper_gain=float(rng.uniform(0.2, 2.0)), circulation_gain=float(rng.uniform(0.0, 2.0)),
                       max_linear_acceleration=float(rng.uniform(0.1, 3.0)))


def _positions(rng: np.random.Generator, obstacles: list[Obstacle], count: int) -> NDArray[np.float64]:
    """Random points, points near the obstacles, between two of them and exactly at centres."""
    centres = np.array([o.pose.position for o in obstacles]) if obstacles else np.zeros((1, 3))
    pairs = rng.integers(len(centres), size=(count // 8, 2))
    points = np.concatenate([rng.uniform((0.0, -0.3, 0.0), (1.0, 0.7, 1.0), (count, 3)),
                             centres[rng.integers(len(centres), size=count // 8)]
                             + rng.normal(scale=0.05, size=(count // 8, 3)),
                             (centres[pairs[:, 0]] + centres[pairs[:, 1]]) / 2.0,
                             centres[:4]])
    return np.ascontiguousarray(rng.permutation(points))


def _unit(quats: NDArray[np.float64]) -> NDArray[np.float64]:
    """The batch's normalisation, q · (1/‖q‖) with the norm summed in its order: NumPy's scalar operations round as
    the core's do."""
    x, y, z, w = quats.T
    return np.ascontiguousarray(quats * (1.0 / np.sqrt(((x * x + y * y) + z * z) + w * w))[:, None])


def _one_pose(field: PotentialField, positions: NDArray[np.float64],
              quats: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    units = _unit(quats)
    twists = np.array([np.concatenate(field.compiled.twist(p, q)[:2]) for p, q in zip(positions, units, strict=True)])
    wrenches = np.array([np.concatenate(field.compiled.wrench(p, q)) for p, q in zip(positions, units, strict=True)])
    return twists, wrenches


def _assert_same_bits(actual: NDArray[np.float64], expected: NDArray[np.float64]) -> None:
    assert np.array_equal(actual, expected)
    assert np.array_equal(np.signbit(actual), np.signbit(expected))  # array_equal takes -0.0 == 0.0


@pytest.mark.parametrize("seed", range(24))
def test_each_row_is_the_one_pose_value_among_random_obstacles_of_every_kind(seed: int) -> None:
    rng = np.random.default_rng(seed)
    obstacles = _scene(rng, int(rng.integers(0, 14)))
    field = PotentialField(_config(rng), Pose(rng.uniform(0.0, 1.0, 3), rng.normal(size=4)), obstacles)
    positions = _positions(rng, obstacles, int(rng.integers(1, 200)))
    quats = _quaternions(rng, positions.shape[0])
    twists, wrenches = _one_pose(field, positions, quats)
    _assert_same_bits(field.twists(positions, quats), twists)
    _assert_same_bits(field.wrenches(positions, quats), wrenches)


def test_threads_and_batch_sizes_do_not_change_a_bit() -> None:
    rng = np.random.default_rng(1)
    obstacles = evaluation_scene("spheres_10") + evaluation_scene("boxes_10")[:2] + _scene(rng, 4)
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, obstacles)
    count = 2 * core_field.PARALLEL_FROM + core_field.CHUNK // 2 + 3  # a partial chunk and a partial block of lanes
    positions = _positions(rng, obstacles, count)
    quats = _quaternions(rng, positions.shape[0])
    plain_twists, plain_wrenches = (field.compiled.twists(positions, quats, threads=1)[0],
                                    field.compiled.wrenches(positions, quats, threads=1)[0])
    for threads in (0, 2, 3):
        _assert_same_bits(field.compiled.twists(positions, quats, threads=threads)[0], plain_twists)
        _assert_same_bits(field.compiled.wrenches(positions, quats, threads=threads)[0], plain_wrenches)
    _assert_same_bits(field.twists(positions, quats), plain_twists)
    pieces = [slice(start, start + 1000) for start in range(0, positions.shape[0], 1000)]
    _assert_same_bits(np.concatenate([field.twists(positions[s], quats[s]) for s in pieces]), plain_twists)
    _assert_same_bits(np.concatenate([field.wrenches(positions[s], quats[s]) for s in pieces]), plain_wrenches)
    picked = rng.choice(positions.shape[0], size=300, replace=False)
    twists, wrenches = _one_pose(field, positions[picked], quats[picked])
    _assert_same_bits(plain_twists[picked], twists)
    _assert_same_bits(plain_wrenches[picked], wrenches)


def test_crowded_dampers_and_more_obstacles_than_the_kept_geometry() -> None:
    """Clustered spheres with a wide influence (dampers bind together: the later sweeps), then 4200 obstacles (the
    later sweeps recompute instead of reading sweep 0's kept geometry)."""
    rng = np.random.default_rng(2)
    config = FieldConfig(influence_distance=0.5, safety_distance=0.1, max_linear_velocity=1.0, damper_gain=2.0,
                         max_linear_acceleration=3.0)
    cluster = [Obstacle(f"s{i}", Sphere(0.05), Pose(rng.uniform(0.3, 0.7, 3))) for i in range(30)] + _scene(rng, 6)
    crowded = PotentialField(config, Pose((0.5, 0.5, 0.5)), cluster)
    many = PotentialField(FieldConfig(influence_distance=0.05, safety_distance=0.01), Pose((0.5, 0.5, 0.5)),
                          [Obstacle(f"s{i}", Sphere(0.01), Pose(rng.uniform(0.0, 1.0, 3))) for i in range(4200)]
                          + _scene(rng, 3))
    for field, count in ((crowded, 1500), (many, 40)):
        positions = np.ascontiguousarray(rng.uniform(0.2, 0.8, (count, 3)))
        quats = _quaternions(rng, count)
        twists, wrenches = _one_pose(field, positions, quats)
        _assert_same_bits(field.twists(positions, quats), twists)
        _assert_same_bits(field.wrenches(positions, quats), wrenches)


def test_rows_with_exact_unit_quaternions_equal_the_public_one_pose_calls() -> None:
    """With quaternions that normalise exactly (Pose's q/‖q‖ and the batch's q·(1/‖q‖) agree), the batch equals
    PotentialField.twist / wrench at each pose."""
    rng = np.random.default_rng(3)
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("spheres_10") + _scene(rng, 5))
    positions = np.ascontiguousarray(rng.uniform((0.0, -0.3, 0.0), (1.0, 0.7, 1.0), (300, 3)))
    exact = np.array([(0.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), (0.5, 0.5, 0.5, 0.5), (0.0, -1.0, 0.0, 0.0)])
    quats = exact[rng.integers(len(exact), size=300)]
    twists, wrenches = field.twists(positions, quats), field.wrenches(positions, quats)
    for k in range(0, 300, 7):
        pose = Pose(positions[k], quats[k])
        _assert_same_bits(twists[k], field.twist(pose).as_array())
        _assert_same_bits(wrenches[k], field.wrench(pose).as_array())
    _assert_same_bits(field.twists(positions), field.twists(positions, BENCH_GOAL.orientation))  # the default


@pytest.mark.parametrize("count", [5, 3000, 2 * core_field.PARALLEL_FROM + 17])
def test_the_first_invalid_row_is_named(count: int) -> None:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("spheres_10"))
    positions = np.full((count, 3), 0.5)
    quats = np.tile((0.0, 0.0, 0.0, 2.0), (count, 1))  # not unit: normalised by the core
    bad_quats = [(0.0, 0.0, 0.0, 0.0), (math.nan, 0.0, 0.0, 1.0), (0.0, math.inf, 0.0, 1.0), (1e-10, 0.0, 0.0, 0.0)]
    rows = sorted({count - 1, count // 2, count // 3, 1})
    for evaluate in (field.twists, field.wrenches):
        for bad in bad_quats:
            broken = quats.copy()
            broken[rows] = bad
            with pytest.raises(InvalidInput) as info:
                evaluate(positions, broken)
            assert info.value.field == f"orientations[{rows[0]}]"
        for point_row, quat_row in ((rows[-1], rows[-2]), (rows[-2], rows[-1]), (rows[-1], rows[-1])):
            broken_points, broken_quats = positions.copy(), quats.copy()
            broken_points[point_row, 2] = -math.inf
            broken_quats[quat_row] = 0.0
            with pytest.raises(InvalidInput) as info:
                evaluate(broken_points, broken_quats)
            name = "positions" if point_row <= quat_row else "orientations"  # a row's position is checked first
            assert info.value.field == f"{name}[{min(point_row, quat_row)}]"
        with pytest.raises(InvalidInput) as info:
            evaluate(positions, (0.0, 0.0, 0.0, 0.0))  # one orientation for every row
        assert info.value.field == "orientations[0]"
    assert np.all(np.isfinite(field.twists(positions, (1e-9, 0.0, 0.0, 0.0))))  # the smallest norm accepted
    # a quaternion whose squared norm overflows is scaled first, as a Pose scales it: accepted, the same rotation
    huge = (1e200, 0.0, 0.0, 1e200)
    _assert_same_bits(field.twists(positions[:1], huge)[0], field.twist(Pose(positions[0], huge)).as_array())
    _assert_same_bits(field.wrenches(positions[:1], huge)[0], field.wrench(Pose(positions[0], huge)).as_array())


def test_empty_batches_and_array_layouts() -> None:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("spheres_10"))
    assert field.twists(np.zeros((0, 3))).shape == (0, 6)
    assert field.wrenches(np.zeros((0, 3)), np.zeros((0, 4))).shape == (0, 6)
    grid = np.random.default_rng(4).uniform(0.0, 1.0, (40, 3))
    quats = np.random.default_rng(5).normal(size=(40, 8))[:, ::2]  # not contiguous
    readonly = grid.copy()
    readonly.setflags(write=False)
    _assert_same_bits(field.twists(readonly, quats), field.twists(grid, np.ascontiguousarray(quats)))
    _assert_same_bits(field.wrenches(grid.astype(np.float32)), field.wrenches(grid.astype(np.float32).astype(float)))
