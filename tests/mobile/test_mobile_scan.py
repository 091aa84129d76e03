"""LaserScan → obstacle points: beam angles, ignored ranges, sensor pose, weightings, bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pfield.errors import InvalidInput
from pfield.interfaces.sensor_msgs import LaserScan
from pfield.mobile import VectorFieldParams, field_components
from pfield.mobile.scan import compose_pose2d, point_obstacles, scan_obstacles, scan_ranges_obstacles
from pfield.mobile.world import World2D


def test_angle_min_minus_pi_maps_beams_to_their_angles():
    scan = LaserScan(angle_min=-math.pi, angle_max=math.pi / 2, angle_increment=math.pi / 2, range_min=0.1,
                     range_max=10.0, ranges=[1.0, 2.0, 3.0, 4.0])
    points = scan_obstacles(scan, weighting="sum").points
    assert points == pytest.approx(np.array([[-1.0, 0.0], [0.0, -2.0], [3.0, 0.0], [0.0, 4.0]]), abs=1e-6)


def test_out_of_range_and_non_finite_beams_are_ignored():
    ranges = [0.05, math.inf, math.nan, 1.0, 12.0, -1.0, 2.0]
    obstacles = scan_ranges_obstacles(ranges, 0.0, 0.1, 0.1, 10.0, weighting="sum")
    expected = [[math.cos(0.3), math.sin(0.3)], [2 * math.cos(0.6), 2 * math.sin(0.6)]]
    assert obstacles.points == pytest.approx(np.array(expected))
    assert obstacles.weights.tolist() == [1.0, 1.0]


def test_sensor_pose_is_applied():
    # laser at (1, 2) facing +y: a 1 m return straight ahead lies at (1, 3)
    obstacles = scan_ranges_obstacles([1.0], 0.0, 0.0, 0.0, 5.0, sensor_pose=(1.0, 2.0, math.pi / 2),
                                      weighting="sum")
    assert obstacles.points[0] == pytest.approx([1.0, 3.0])
    # composing robot pose and mount: robot at (1, 0) facing +y, laser 0.5 m ahead
    assert compose_pose2d((1.0, 0.0, math.pi / 2), (0.5, 0.0, 0.0)) == pytest.approx([1.0, 0.5, math.pi / 2])


def _wall_repulsion(beams: int, weighting: str) -> float:
    world = World2D.build(polygons=[[(1.0, -20.0), (1.2, -20.0), (1.2, 20.0), (1.0, 20.0)]])
    angles = -math.pi + np.arange(beams) * (2 * math.pi / beams)
    ranges = world.raycast((0.0, 0.0), angles, 30.0)
    obstacles = scan_ranges_obstacles(ranges, -math.pi, 2 * math.pi / beams, 0.0, 30.0, weighting=weighting)
    params = VectorFieldParams(kr_dist=0.5, kr_height=1.0, kr_slope=5.0)
    parts = field_components([[0.0, 0.0]], None, obstacles.points, params, obstacles.weights)
    return float(np.linalg.norm(parts.repulsion[0]))


@pytest.mark.parametrize("weighting", ["sector", "arc_length"])
def test_default_weightings_do_not_depend_on_lidar_resolution(weighting):
    coarse, fine = _wall_repulsion(360, weighting), _wall_repulsion(1440, weighting)
    assert fine == pytest.approx(coarse, rel=0.05)


def test_original_sum_grows_with_resolution():
    assert _wall_repulsion(1440, "sum") / _wall_repulsion(360, "sum") == pytest.approx(4.0, rel=0.05)


def test_sector_keeps_the_nearest_return_per_sector_and_arc_length_weights():
    ranges = [3.0, 2.0, 2.5]  # all inside one 5° sector around 0 rad
    sector = scan_ranges_obstacles(ranges, 0.001, 0.001, 0.0, 10.0)
    assert sector.points.shape == (1, 2)
    assert np.hypot(*sector.points[0]) == pytest.approx(2.0)
    arc = scan_ranges_obstacles(ranges, 0.001, 0.001, 0.0, 10.0, weighting="arc_length")
    assert arc.weights == pytest.approx(np.array(ranges) * 0.001)


@pytest.mark.parametrize(("field", "kwargs"), [
    ("angle_increment", {"angle_increment": 0.0}),
    ("range_max", {"range_min": 2.0, "range_max": 1.0}),
    ("range_min", {"range_min": -1.0}),
    ("angle_min", {"angle_min": math.nan}),
    ("scan_weighting", {"weighting": "mean"}),
    ("scan_sector_angle", {"sector_angle": 0.0}),
    ("sensor_pose", {"sensor_pose": (0.0, math.inf, 0.0)}),
])
def test_bad_scans_are_rejected_by_name(field, kwargs):
    args = {"ranges": [1.0, 2.0], "angle_min": 0.0, "angle_increment": 0.1, "range_min": 0.0, "range_max": 5.0}
    args |= kwargs
    with pytest.raises(InvalidInput) as info:
        scan_ranges_obstacles(**args)
    assert info.value.field == field


def test_laser_scan_model_round_trips_inf_through_json():
    scan = LaserScan(angle_min=-math.pi, angle_increment=0.5, range_max=5.0, ranges=[1.0, math.inf, math.nan])
    again = LaserScan.model_validate(json.loads(scan.model_dump_json()))
    assert again.ranges[0] == 1.0 and math.isinf(again.ranges[1]) and math.isnan(again.ranges[2])
    assert set(LaserScan.model_fields) == {"header", "angle_min", "angle_max", "angle_increment", "time_increment",
                                           "scan_time", "range_min", "range_max", "ranges", "intensities"}


def test_point_obstacles_validate():
    assert point_obstacles([[1.0, 2.0]]).weights.tolist() == [1.0]
    assert point_obstacles(None).points.shape == (0, 2)
    with pytest.raises(InvalidInput, match="obstacles"):
        point_obstacles([[1.0, 2.0, 3.0]])
