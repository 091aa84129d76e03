"""The field over many poses on every core: the same bits as the plain loop, one pose's value to rounding."""

from __future__ import annotations

import numpy as np

from pfield.field import PotentialField
from pfield.field import _batch_parallel as batch
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
