"""Costmaps: nav2 cost values, the inflation rule, costmap_2d coordinates, local windows, parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfield.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
    CostmapParams,
    OccupancyMap,
    build_costmap,
    costs_from_occupancy,
    inflate,
    local_window,
)
from pfield.errors import InvalidInput


def test_static_layer_interpretation() -> None:
    data = np.array([[0, 50, 99, 100, -1]], dtype=np.int8)
    assert costs_from_occupancy(data).tolist() == [[0, 0, 0, 254, 255]]
    assert costs_from_occupancy(data, trinary_costmap=False).tolist() == [[0, 127, 251, 254, 255]]
    assert costs_from_occupancy(data, track_unknown_space=False).tolist() == [[0, 0, 0, 254, 0]]


def test_inflation_values_follow_nav2_rule() -> None:
    res, inscribed, radius, k = 0.1, 0.15, 0.45, 3.0
    costs = np.zeros((21, 21), dtype=np.uint8)
    costs[10, 10] = LETHAL_OBSTACLE
    out = inflate(costs, res, inscribed, radius, k)
    for (row, col), value in np.ndenumerate(out):
        d = math.hypot(row - 10, col - 10)
        if d == 0:
            expected = 254
        elif d * res <= inscribed:
            expected = 253
        elif d <= math.ceil(radius / res):
            expected = int(252 * math.exp(-k * (d * res - inscribed)))
        else:
            expected = 0
        assert value == expected, (row, col)
    assert out[10, 11] == 253 and out[10, 12] == int(252 * math.exp(-k * 0.05)) and out[10, 15] > 0 and out[10, 16] == 0


def test_inflation_keeps_unknown_unless_inscribed() -> None:
    costs = np.full((1, 8), NO_INFORMATION, dtype=np.uint8)
    costs[0, 0] = LETHAL_OBSTACLE
    out = inflate(costs, 0.1, 0.15, 1.0, 1.0)
    assert out[0].tolist() == [254, 253, 255, 255, 255, 255, 255, 255]


def test_world_map_coordinates_as_costmap_2d() -> None:
    cm = Costmap2D(np.zeros((4, 5), dtype=np.uint8), 0.5, origin_x=-1.0, origin_y=2.0)
    assert cm.world_to_map(-1.0, 2.0) == (0, 0)
    assert cm.world_to_map(-0.5000001, 2.4999) == (0, 0)
    assert cm.world_to_map(-0.5, 2.5) == (1, 1)
    assert cm.world_to_map(1.4999, 3.9999) == (4, 3)
    assert cm.world_to_map(1.5, 3.0) is None  # mx = 5 = size_x
    assert cm.world_to_map(-1.0000001, 3.0) is None
    assert cm.map_to_world(1, 2) == (-0.25, 3.25)


def test_build_costmap_uses_padded_inscribed_radius() -> None:
    data = np.zeros((11, 11), dtype=np.int8)
    data[5, 5] = 100
    data[0, 0] = -1
    params = CostmapParams(robot_radius=0.2, footprint_padding=0.05, inflation_radius=0.5, cost_scaling_factor=2.0)
    cm = build_costmap(OccupancyMap(data, 0.1, (1.0, 2.0, 0.0)), params)
    inscribed = params.padded_footprint().inscribed_radius
    assert 0.2 < inscribed < 0.25
    assert cm.costs[5, 5] == 254 and cm.costs[5, 7] == 253  # 0.2 m away, inside the padded inscribed radius
    assert cm.costs[5, 8] == int(252 * math.exp(-2.0 * (0.3 - inscribed)))
    assert cm.costs[0, 0] == NO_INFORMATION and (cm.origin_x, cm.origin_y) == (1.0, 2.0)


def test_lethal_distance_is_exact_euclidean() -> None:
    costs = np.zeros((5, 7), dtype=np.uint8)
    costs[1, 1] = LETHAL_OBSTACLE
    cm = Costmap2D(costs, 0.1)
    assert cm.lethal_distance[4, 5] == pytest.approx(5.0)
    assert cm.lethal_distance[1, 1] == 0.0


def test_local_window_same_resolution_is_a_slice() -> None:
    rng = np.random.default_rng(3)
    data = rng.choice(np.array([0, 100, -1], dtype=np.int8), size=(60, 80), p=[0.8, 0.1, 0.1])
    occ = OccupancyMap(data, 0.05, (-1.0, -1.0, 0.0))
    params = CostmapParams(local_window_size=1.0, resolution=0.05, inflation_radius=0.0)
    window = local_window(occ, 0.52, 0.31, params)
    assert window.costs.shape == (20, 20)
    col0 = round((window.origin_x + 1.0) / 0.05)
    row0 = round((window.origin_y + 1.0) / 0.05)
    assert (col0, row0) == (20, 16)  # centre − 0.5 m, snapped down to the global grid
    expected = costs_from_occupancy(data[row0:row0 + 20, col0:col0 + 20])
    np.testing.assert_array_equal(window.costs, expected)


def test_local_window_coarser_and_beyond_the_map() -> None:
    data = np.zeros((10, 10), dtype=np.int8)
    data[4, 4] = 100
    occ = OccupancyMap(data, 0.1)
    params = CostmapParams(local_window_size=2.0, resolution=0.2, inflation_radius=0.0)
    window = local_window(occ, 1.0, 1.0, params)  # window [0, 2) m: half of it beyond the 1 m map
    assert window.costs.shape == (10, 10)
    assert window.costs[2, 2] == LETHAL_OBSTACLE  # global cell (4, 4) falls in window cell (2, 2)
    assert window.costs[7, 7] == NO_INFORMATION and window.costs[0, 0] == 0
    assert int(np.count_nonzero(window.costs == LETHAL_OBSTACLE)) == 1


@pytest.mark.parametrize(
    ("field", "value"),
    [("robot_radius", -0.1), ("inflation_radius", float("nan")), ("resolution", 0.0),
     ("local_window_size", -1.0), ("cost_scaling_factor", -1.0), ("footprint", "[[0, 0], [1, 1]]"),
     ("global_frame", ""), ("angle_increment", 0.0), ("footprint_padding", float("inf"))],
)
def test_bad_params_rejected(field: str, value: object) -> None:
    with pytest.raises(InvalidInput) as info:
        CostmapParams(**{field: value})  # type: ignore[arg-type]
    assert info.value.field == field


def test_footprint_parameter_accepts_a_list_of_pairs() -> None:
    params = CostmapParams(footprint=[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25]])  # type: ignore[arg-type]
    assert params.footprint == "[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25]]"
    assert CostmapParams(footprint=[]).footprint == "[]"  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="footprint"):
        CostmapParams(footprint=[[0, 0], [1, 1]])  # type: ignore[arg-type]


def test_inscribed_value_constant() -> None:
    assert INSCRIBED_INFLATED_OBSTACLE == 253
