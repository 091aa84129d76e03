"""Footprints: nav2 parsing, padding and radii, and the exact rasterisation rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from pfield.costmap import Footprint
from pfield.errors import InvalidInput

RECT = [[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25], [0.4, -0.25]]


def test_parse_nav2_string_and_back() -> None:
    fp = Footprint.from_string("[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25], [0.4, -0.25]]")
    np.testing.assert_array_equal(fp.points, RECT)
    assert Footprint.from_string(fp.to_string()).points.tolist() == RECT


def test_radius_footprint_is_nav2_16_gon() -> None:
    fp = Footprint.from_parameters("[]", 0.3)
    assert fp.points.shape == (16, 2)
    np.testing.assert_allclose(fp.points[4], [0.0, 0.3], atol=1e-15)
    assert fp.circumscribed_radius == pytest.approx(0.3)
    assert fp.inscribed_radius == pytest.approx(0.3 * math.cos(math.pi / 16))


def test_padding_moves_vertices_by_coordinate_sign() -> None:
    fp = Footprint.from_points([[0.5, 0.0], [0.0, 0.3], [-0.2, -0.1]]).padded(0.1)
    np.testing.assert_allclose(fp.points, [[0.6, 0.0], [0.0, 0.4], [-0.3, -0.2]])


def test_radii_of_rectangle() -> None:
    fp = Footprint.from_points(RECT)
    assert fp.inscribed_radius == pytest.approx(0.25)
    assert fp.circumscribed_radius == pytest.approx(math.hypot(0.4, 0.25))
    assert fp.contains_center


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("[[0, 0], [1, 0]]", "footprint"),
        ("[[0, 0], [1, 1], [1, 0], [0, 1]]", "footprint"),  # bow tie
        ("[[0, 0], [1, 0], [2, 0]]", "footprint"),  # zero area
        ("[[0, 0], [1, 0], [nan, 1]]", "footprint"),
        ("[[0, 0], [1, 0, 3], [0, 1]]", "footprint"),
        ("not a list", "footprint"),
        ("[[0, 0], [1, 0]", "footprint"),
        (f"[[{10**400}, 0], [1, 0], [0, 1]]", "footprint"),  # beyond a double: was an OverflowError
    ],
)
def test_bad_footprints_rejected(text: str, field: str) -> None:
    with pytest.raises(InvalidInput) as info:
        Footprint.from_string(text)
    assert info.value.field == field


def test_points_beyond_a_double_are_rejected() -> None:
    with pytest.raises(InvalidInput) as info:
        Footprint.from_points([[10**400, 0], [1, 0], [0, 1]])
    assert info.value.field == "footprint"


def test_bad_radius_and_padding_rejected() -> None:
    with pytest.raises(InvalidInput, match="robot_radius"):
        Footprint.from_parameters("[]", 0.0)
    with pytest.raises(InvalidInput, match="footprint_padding"):
        Footprint.from_points(RECT).padded(-0.1)


def test_rasterisation_closed_polygon_half_open_cells() -> None:
    # x ∈ [0.5, 1.5] touches the grid lines 0.5 and 1.5 exactly (resolution 0.25 is exact in binary):
    # cells [0.5, 0.75) … [1.25, 1.5) and [1.5, 1.75) (which contains x = 1.5) are covered, [0.25, 0.5) not.
    fp = Footprint.from_points([[0.5, 0.25], [-0.5, 0.25], [-0.5, -0.25], [0.5, -0.25]])
    cells = fp.cells(1.0, 1.0, 0.0, (0.0, 0.0), 0.25)
    assert sorted(set(cells[:, 0].tolist())) == [2, 3, 4, 5, 6]
    assert sorted(set(cells[:, 1].tolist())) == [3, 4, 5]
    assert len(cells) == 15


def test_rasterisation_vertex_touching_cell_corner() -> None:
    # a diamond whose right vertex is exactly the point (1, 0.5) in cell units
    fp = Footprint.from_points([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    cells = {tuple(c) for c in fp.cells(0.0, 0.5, 0.0, (0.0, 0.0), 1.0).tolist()}
    assert (1, 0) in cells  # the vertex (1, 0.5) lies in cell [1, 2) × [0, 1)
    assert cells == {(-1, 0), (0, 0), (1, 0), (-1, -1), (0, -1), (0, 1), (-1, 1)}


def test_concave_notch_not_covered() -> None:
    # a U shape whose notch is x ∈ (2.5, 4.5), y > 2.5: cells (3, 3..6) lie in the notch
    u_shape = [[0, 0], [6, 0], [6, 6], [4, 6], [4, 2], [2, 2], [2, 6], [0, 6]]
    fp = Footprint.from_points(np.array(u_shape, dtype=float) + 0.5)
    cells = {tuple(c) for c in fp.cells(0.0, 0.0, 0.0, (0.0, 0.0), 1.0).tolist()}
    assert not {(3, 3), (3, 4), (3, 5), (3, 6)} & cells
    assert {(3, 2), (2, 4), (4, 4), (6, 6), (0, 0)} <= cells
    assert len(cells) == 49 - 4


def _shapely_cells(polygon: Polygon) -> set[tuple[int, int]]:
    x0, y0, x1, y1 = polygon.bounds
    ms, ns = np.meshgrid(np.arange(math.floor(x0), math.floor(x1) + 1), np.arange(math.floor(y0), math.floor(y1) + 1))
    boxes = shapely.box(ms.ravel(), ns.ravel(), ms.ravel() + 1, ns.ravel() + 1)
    hit = shapely.intersects(polygon, boxes)
    return set(zip(ms.ravel()[hit].tolist(), ns.ravel()[hit].tolist(), strict=True))


def test_rasterisation_matches_shapely_on_random_polygons() -> None:
    rng = np.random.default_rng(7)
    checked = 0
    while checked < 60:
        count = int(rng.integers(3, 9))
        angles = np.sort(rng.uniform(0, 2 * math.pi, count))
        radii = rng.uniform(0.3, 3.0, count)  # star-shaped about the origin: simple, often concave
        points = np.column_stack((radii * np.cos(angles), radii * np.sin(angles)))
        try:
            fp = Footprint.from_points(points)
        except InvalidInput:
            continue
        x, y, yaw = rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-math.pi, math.pi)
        ours = {tuple(c) for c in fp.cells(x, y, yaw, (0.0, 0.0), 1.0).tolist()}
        assert ours == _shapely_cells(Polygon(fp.posed(x, y, yaw)))
        checked += 1


def test_rasterisation_shifts_with_whole_cells() -> None:
    """Moving the pose by whole cells moves the covered cells by the same amount (what FindValidPose's
    per-yaw kernels rely on). Seeded random poses plus the axis-aligned yaws; resolution 0.25."""
    fp = Footprint.from_points([[0.4, 0.25], [-0.4, 0.25], [-0.1, 0.0], [-0.4, -0.25], [0.4, -0.25]])
    res = 0.25
    rng = np.random.default_rng(11)
    yaws = [0.0, math.pi / 2, math.pi, -math.pi / 2, *rng.uniform(-math.pi, math.pi, 100).tolist()]
    for yaw in yaws:
        x, y = rng.integers(-192, 192, 2) / 64.0
        shift = rng.integers(-20, 21, 2)
        base = fp.cells(x, y, yaw, (0.0, 0.0), res)
        moved = fp.cells(x + shift[0] * res, y + shift[1] * res, yaw, (0.0, 0.0), res)
        assert {tuple(c) for c in (base + shift).tolist()} == {tuple(c) for c in moved.tolist()}, yaw
        vertices = np.floor(fp.posed(x, y, yaw) / res).astype(int)
        assert {tuple(v) for v in vertices.tolist()} <= {tuple(c) for c in base.tolist()}


@pytest.mark.parametrize(("pose", "resolution", "field"), [
    ((1e300, 0.0, 0.0), 0.05, "position"),  # over 2^40 cells from the origin
    ((0.0, math.nan, 0.0), 0.05, "position"),
    ((0.0, 0.0, math.inf), 0.05, "position"),
    ((0.0, 0.0, 0.0), 1e-6, "resolution"),  # a 0.4 m footprint over ~1.6e11 cells
])
def test_rasterisation_refuses_poses_and_grids_it_cannot_place(pose: tuple[float, float, float], resolution: float,
                                                                field: str) -> None:
    with pytest.raises(InvalidInput) as info:
        Footprint.from_radius(0.2).cells(*pose, (0.0, 0.0), resolution)
    assert info.value.field == field
