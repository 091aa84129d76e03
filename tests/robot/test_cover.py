"""The compiled covering kernels against their plain numpy definitions: the same picks, the same booleans."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from pfield.robot import _cover, _fit
from pfield.robot._solid import _hull_facets


def _plain_greedy(a: np.ndarray, b: np.ndarray, radii: np.ndarray, points: np.ndarray) -> list[int]:
    """Chvátal's greedy as written out: the dense coverage matrix, argmax of the gains (lowest index on ties)."""
    covered = _cover.coverage(a, b, radii, points)
    uncovered = np.ones(len(points), dtype=bool)
    chosen = []
    while uncovered.any():
        k = int(np.argmax(covered[:, uncovered].sum(axis=1)))
        chosen.append(k)
        uncovered &= ~covered[k]
    return chosen


@pytest.mark.parametrize("seed", range(6))
def test_the_lazy_greedy_cover_picks_what_the_plain_one_picks(seed: int) -> None:
    rng = np.random.default_rng(seed)
    # points and ends on a 1 cm lattice with radii in whole cm: many equal gains and points exactly on surfaces
    points = rng.integers(0, 12, (400, 3)) * 0.01
    count = 300
    a = rng.integers(0, 12, (count, 3)) * 0.01
    b = np.where(rng.random((count, 1)) < 0.5, a, rng.integers(0, 12, (count, 3)) * 0.01)
    radii = rng.integers(1, 4, count) * 0.01
    a, b = np.concatenate([a, points]), np.concatenate([b, points])  # every point lies in a candidate
    radii = np.concatenate([radii, np.full(len(points), 0.005)])
    for cell in (0.005, 0.01, 0.03):
        picked = _cover.greedy_cover(a, b, radii, points, cell)
        assert picked.tolist() == _plain_greedy(a, b, radii, points)


def test_inside_hull_with_an_inner_polytope_is_the_facet_test() -> None:
    rng = np.random.default_rng(4)
    directions = rng.normal(size=(2000, 3))
    vertices = directions / np.linalg.norm(directions, axis=1, keepdims=True) * (0.1, 0.05, 0.03)  # all on the hull
    outer, inner = _hull_facets(vertices)
    assert len(inner) < len(outer)
    points = rng.normal(size=(5000, 3)) * (0.06, 0.03, 0.02)
    plain = np.all(points @ outer[:, :3].T + outer[:, 3] <= 1e-12, axis=1)
    np.testing.assert_array_equal(_cover.inside_hull(outer, inner, points, 1e-12), plain)
    assert 0 < plain.sum() < len(points)
    hull = ConvexHull(vertices)
    np.testing.assert_array_equal(_cover.inside_hull(outer, outer, vertices[hull.vertices], 1e-12), True)


def test_min_depth_is_the_least_depth_outside_of_the_other_capsules() -> None:
    rng = np.random.default_rng(5)
    prims = _fit.Primitives(rng.normal(size=(7, 3)) * 0.05, rng.normal(size=(7, 3)) * 0.05, rng.random(7) * 0.03)
    points = rng.normal(size=(300, 3)) * 0.08
    depth = _fit.depth_outside(points, prims)
    np.testing.assert_allclose(_cover.min_depth(prims.a, prims.b, prims.radii, points, -1), depth.min(axis=1),
                               rtol=0, atol=1e-15)
    depth[:, 2] = np.inf
    np.testing.assert_allclose(_cover.min_depth(prims.a, prims.b, prims.radii, points, 2), depth.min(axis=1),
                               rtol=0, atol=1e-15)


def test_the_enclosing_circle_follows_badoiu_clarkson_step_by_step() -> None:
    points = np.random.default_rng(6).normal(size=(200, 2))
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    for k in range(1, 401):
        far = points[np.argmax(np.linalg.norm(points - centre, axis=1))]
        centre = centre + (far - centre) / (k + 1)
    np.testing.assert_array_equal(_cover.enclosing_circle(points, 400), centre)
