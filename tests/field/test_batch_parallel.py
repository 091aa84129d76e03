"""The field over many poses on every core: the same bits as the plain loop, one pose's value to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from pfield._core import field as batch
from pfield.errors import InvalidInput
from pfield.field import PotentialField
from pfield.planning.scenes import BENCH_GOAL, DEFAULT_PARAMS, evaluation_scene
from pfield.spatial import Pose


def test_threaded_batches_equal_the_plain_loop_bit_for_bit_and_one_pose_to_rounding() -> None:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("boxes_10"))
    count = batch.PARALLEL_FROM + batch.CHUNK // 2 + 1  # threaded, with a partial last chunk
    rng = np.random.default_rng(3)
    points = rng.uniform((0.0, -0.3, 0.0), (1.0, 0.7, 1.0), (count, 3))
    quats = rng.normal(size=(count, 4))
    twists, wrenches = field.twists(points, quats), field.wrenches(points, quats)
    pieces = range(0, count, batch.PARALLEL_FROM // 2)  # each piece below the threshold: the plain loop
    plain_twists = np.concatenate([field.twists(points[i:i + batch.PARALLEL_FROM // 2],
                                                quats[i:i + batch.PARALLEL_FROM // 2]) for i in pieces])
    plain_wrenches = np.concatenate([field.wrenches(points[i:i + batch.PARALLEL_FROM // 2],
                                                    quats[i:i + batch.PARALLEL_FROM // 2]) for i in pieces])
    np.testing.assert_array_equal(twists, plain_twists)
    np.testing.assert_array_equal(wrenches, plain_wrenches)
    for k in np.linspace(0, count - 1, 40).astype(int):  # spread over every chunk
        pose = Pose(points[k], quats[k])
        np.testing.assert_allclose(twists[k], field.twist(pose).as_array(), rtol=0, atol=1e-14)
        np.testing.assert_allclose(wrenches[k], field.wrench(pose).as_array(), rtol=0, atol=1e-13)
    assert np.all(np.isfinite(twists)) and np.any(twists != 0.0)


def test_the_first_refused_row_is_named_in_threaded_and_plain_batches() -> None:
    """Rows are checked inside the kernels: the error names the first bad row, whichever chunk holds it."""
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("spheres_10"))
    count = batch.PARALLEL_FROM + 3 * batch.CHUNK
    points = np.full((count, 3), 0.5)
    quats = np.tile((0.0, 0.0, 0.0, 2.0), (count, 1))  # not unit: normalised by the kernel
    points[count - 5, 1] = np.nan
    points[batch.CHUNK + 7, 0] = np.inf
    quats[count - 9] = 0.0
    for evaluate in (field.twists, field.wrenches):
        with pytest.raises(InvalidInput) as info:
            evaluate(points, quats)
        assert info.value.field == f"positions[{batch.CHUNK + 7}]"
        with pytest.raises(InvalidInput) as info:
            evaluate(points[batch.CHUNK + 8:], quats[batch.CHUNK + 8:])
        assert info.value.field == f"orientations[{count - 9 - batch.CHUNK - 8}]"
        with pytest.raises(InvalidInput) as info:
            evaluate(points[count - 40:], quats[count - 40:])  # the plain loop
        assert info.value.field == f"orientations[{40 - 9}]"
    good = field.twists(points[:batch.CHUNK], quats[:batch.CHUNK])
    np.testing.assert_array_equal(good, field.twists(points[:batch.CHUNK], (0.0, 0.0, 0.0, 1.0)))


def test_lanes_agree_with_one_pose_near_spheres_at_centres_and_with_mixed_shapes() -> None:
    """The lane-wise sweep (spheres side by side, the cached later sweeps, the exact path at a centre and for
    other shapes) gives one pose's twist to rounding, also where several dampers bind."""
    obstacles = evaluation_scene("spheres_10") + evaluation_scene("boxes_10")[:3]
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, obstacles)
    rng = np.random.default_rng(11)
    centres = np.array([o.pose.position for o in obstacles[:10]])
    midpoints = (centres[:, None, :] + centres[None, :, :]).reshape(-1, 3) / 2.0  # between two spheres
    points = np.concatenate([rng.uniform((0.0, -0.3, 0.0), (1.0, 0.7, 1.0), (3000, 3)), midpoints,
                             centres + rng.normal(scale=0.04, size=centres.shape), centres[:3]])
    quats = rng.normal(size=(points.shape[0], 4))
    twists = field.twists(points, quats)
    for k in range(points.shape[0]):
        np.testing.assert_allclose(twists[k], field.twist(Pose(points[k], quats[k])).as_array(), rtol=0, atol=1e-13)
