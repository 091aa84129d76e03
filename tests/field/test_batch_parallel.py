"""The field over many poses on every core gives the serial kernels' values bit for bit."""

from __future__ import annotations

import numpy as np

from pfield.field import PotentialField
from pfield.field import _batch_parallel as parallel
from pfield.field import _evaluate as serial
from pfield.planning.scenes import BENCH_GOAL, DEFAULT_PARAMS, evaluation_scene


def test_parallel_batches_equal_the_serial_kernels_bit_for_bit() -> None:
    field = PotentialField(DEFAULT_PARAMS, BENCH_GOAL, evaluation_scene("boxes_10"))
    count = parallel.SERIAL_BELOW + parallel.CHUNK // 2 + 1  # above the threshold, with a partial last chunk
    rng = np.random.default_rng(3)
    quats = rng.normal(size=(count, 4))
    points, unit = field._batch(rng.uniform((0.0, -0.3, 0.0), (1.0, 0.7, 1.0), (count, 3)), quats)
    goal, params, packed, aux = field._arrays
    expected_twists = serial.batch_twists(points, unit, goal, params, aux, np.zeros(6), *packed)
    expected_wrenches = serial.batch_wrenches(points, unit, goal, params, aux, *packed)
    np.testing.assert_array_equal(field.twists(points, quats), expected_twists)
    np.testing.assert_array_equal(field.wrenches(points, quats), expected_wrenches)
    np.testing.assert_array_equal(field.twists(points[:5], quats[:5]), expected_twists[:5])  # the serial path
    assert np.all(np.isfinite(expected_twists)) and np.any(expected_twists != 0.0)
