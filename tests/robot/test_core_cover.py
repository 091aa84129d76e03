"""The compiled cover (``src/core/robot/cover``, :mod:`pfield.robot._cover`) against oracles written out in NumPy,
and against the values the numba kernels it replaced gave on the same inputs.

The oracles evaluate the same expressions elementwise in the same order (NumPy's elementwise operations round
each step as C++ does with -ffp-contract=off), so coverage and depths are compared for equality, not within a
tolerance. The greedy cover is checked for what it promises (every point covered, each capsule taken for new
points, the plain greedy's choices); the digests hold the exact outputs numba's kernels gave on many seeded
inputs before they were removed (issue 32): a fit's primitives depend on every choice of the cover and every bit
of the depths.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import numpy as np
import pytest
from scipy.spatial import Delaunay

from digests import digest
from pfield.robot import _cover
from pfield.robot._solid import _hull_facets

Capsules = tuple[np.ndarray, np.ndarray, np.ndarray]


def _capsules(rng: np.random.Generator, count: int, lattice: bool) -> Capsules:
    if lattice:  # a 1 cm lattice and whole-cm radii: equal gains, points exactly on surfaces
        a = rng.integers(0, 12, (count, 3)) * 0.01
        b = np.where(rng.random((count, 1)) < 0.4, a, rng.integers(0, 12, (count, 3)) * 0.01)
        radii = rng.integers(0, 4, count) * 0.01
    else:
        a = rng.normal(size=(count, 3)) * 0.05
        b = np.where(rng.random((count, 1)) < 0.4, a, a + rng.normal(size=(count, 3)) * 0.03)
        radii = rng.random(count) * 0.03
    return a, b, radii


def _points(rng: np.random.Generator, count: int, lattice: bool) -> np.ndarray:
    return rng.integers(0, 12, (count, 3)) * 0.01 if lattice else rng.normal(size=(count, 3)) * 0.06


def _cover_case(seed: int) -> tuple[Capsules, np.ndarray]:
    """Candidates and points where every point lies in some candidate (a small sphere at each point, shuffled in)."""
    rng = np.random.default_rng(100 + seed)
    lattice = seed % 3 != 2
    a, b, radii = _capsules(rng, int(rng.integers(1, 400)), lattice)
    points = _points(rng, int(rng.integers(1, 500)), lattice)
    a, b = np.concatenate([a, points]), np.concatenate([b, points])
    radii = np.concatenate([radii, np.full(len(points), 0.004)])
    order = rng.permutation(len(radii))
    return (np.ascontiguousarray(a[order]), np.ascontiguousarray(b[order]), radii[order].copy()), points


CELLS = (0.002, 0.005, 0.01, 0.0173, 0.03, 0.2)


def _contains(a: np.ndarray, b: np.ndarray, radii: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(K, N): the containment test of cover.hpp, |q − t d|² ≤ r², q = p − a, t = clamp(q·d / |d|², 0, 1)."""
    out = np.empty((len(radii), len(points)), dtype=bool)
    for k in range(len(radii)):
        d = b[k] - a[k]
        length2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        q = points - a[k]
        dot = q[:, 0] * d[0] + q[:, 1] * d[1] + q[:, 2] * d[2]
        t = np.zeros(len(points)) if length2 == 0.0 else np.minimum(np.maximum(dot / length2, 0.0), 1.0)
        e = q - t[:, None] * d
        out[k] = e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1] + e[:, 2] * e[:, 2] <= radii[k] * radii[k]
    return out


def _depth(a: np.ndarray, b: np.ndarray, radii: np.ndarray, points: np.ndarray, skip: int) -> np.ndarray:
    """min over k ≠ skip of |p − (a + t d)| − r, in min_depth's order (capsule by capsule, Python's min)."""
    depth = np.full(len(points), np.inf)
    for k in range(len(radii)):
        if k == skip:
            continue
        d = b[k] - a[k]
        length2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        q = points - a[k]
        dot = q[:, 0] * d[0] + q[:, 1] * d[1] + q[:, 2] * d[2]
        t = np.zeros(len(points)) if length2 == 0.0 else np.minimum(np.maximum(dot / length2, 0.0), 1.0)
        e = points - (a[k] + t[:, None] * d)
        value = np.sqrt(e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1] + e[:, 2] * e[:, 2]) - radii[k]
        depth = np.where(value < depth, value, depth)
    return depth


@pytest.mark.parametrize("seed", range(12))
def test_coverage_and_min_depth_equal_their_numpy_definitions(seed: int) -> None:
    rng = np.random.default_rng(seed)
    lattice = seed % 2 == 0
    a, b, radii = _capsules(rng, int(rng.integers(1, 60)), lattice)
    points = _points(rng, int(rng.integers(1, 400)), lattice)
    np.testing.assert_array_equal(_cover.coverage(a, b, radii, points), _contains(a, b, radii, points))
    for skip in (-1, 0, len(radii) - 1):
        assert _cover.min_depth(a, b, radii, points, skip).tobytes() == _depth(a, b, radii, points, skip).tobytes()
    assert np.all(_cover.min_depth(a[:1], b[:1], radii[:1], points, 0) == np.inf)  # no capsule left


@pytest.mark.parametrize("seed", range(24))
def test_greedy_cover_covers_every_point_each_capsule_for_new_points(seed: int) -> None:
    (a, b, radii), points = _cover_case(seed)
    covered = _contains(a, b, radii, points)
    for cell in (*CELLS, _cover.cell_side(points, 0.004)):
        picked = _cover.greedy_cover(a, b, radii, points, cell)
        assert picked.dtype == np.int64 and len(set(picked.tolist())) == len(picked)
        assert covered[picked].any(axis=0).all()
        seen = np.zeros(len(points), dtype=bool)
        gains = []
        for k in picked:
            gains.append(int(np.count_nonzero(covered[k] & ~seen)))
            seen |= covered[k]
        assert min(gains) > 0 and gains == sorted(gains, reverse=True)  # Chvátal's gains never grow


@pytest.mark.parametrize("seed", range(0, 24, 5))
def test_greedy_cover_takes_the_plain_greedy_choices_on_floats(seed: int) -> None:
    (a, b, radii), points = _cover_case(seed + 2 - seed % 3)  # the non-lattice cases: distinct gains rarer
    covered = _contains(a, b, radii, points)
    uncovered, plain = np.ones(len(points), dtype=bool), []
    while uncovered.any():
        k = int(np.argmax(covered[:, uncovered].sum(axis=1)))  # the lowest index on ties
        plain.append(k)
        uncovered &= ~covered[k]
    assert _cover.greedy_cover(a, b, radii, points, 0.01).tolist() == plain


def test_greedy_cover_stops_when_the_points_left_lie_in_no_capsule() -> None:
    rng = np.random.default_rng(3)
    a, b, radii = _capsules(rng, 50, True)
    points = _points(rng, 300, True)
    covered = _contains(a, b, radii, points)
    assert not covered.any(axis=0).all()
    for cell in (0.005, 0.02):
        picked = _cover.greedy_cover(a, b, radii, points, cell)
        np.testing.assert_array_equal(covered[picked].any(axis=0), covered.any(axis=0))


@pytest.mark.parametrize("seed", range(6))
def test_inside_hull_agrees_with_a_delaunay_triangulation(seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    directions = rng.normal(size=(int(rng.integers(300, 3000)), 3))
    vertices = directions / np.linalg.norm(directions, axis=1, keepdims=True) * (0.02 + rng.random(3) * 0.1)
    outer, inner = _hull_facets(vertices)
    points = rng.normal(size=(4000, 3)) * 0.05
    margin = (points @ outer[:, :3].T + outer[:, 3]).max(axis=1)
    clear = np.abs(margin) > 1e-9  # off the boundary, where both tests are exact
    inside = _cover.inside_hull(outer, inner, points, 1e-12)
    np.testing.assert_array_equal(inside[clear], Delaunay(vertices).find_simplex(points[clear]) >= 0)
    assert 0 < inside.sum() < len(points)
    np.testing.assert_array_equal(_cover.inside_hull(outer, inner, vertices, 1e-12), True)


def _smallest_circle(points: np.ndarray) -> float:
    """The radius of the smallest circle containing the points, by brute force over the circles through two
    points (as a diameter) and three points."""
    best = np.inf
    for i, j in itertools.combinations(range(len(points)), 2):
        centre = 0.5 * (points[i] + points[j])
        radius = np.linalg.norm(points - centre, axis=1).max()
        best = min(best, radius)
    for i, j, k in itertools.combinations(range(len(points)), 3):
        (ax, ay), (bx, by), (cx, cy) = points[i], points[j], points[k]
        d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
        if abs(d) < 1e-12:
            continue
        ux = ((ax**2 + ay**2) * (by - cy) + (bx**2 + by**2) * (cy - ay) + (cx**2 + cy**2) * (ay - by)) / d
        uy = ((ax**2 + ay**2) * (cx - bx) + (bx**2 + by**2) * (ax - cx) + (cx**2 + cy**2) * (bx - ax)) / d
        best = min(best, np.linalg.norm(points - (ux, uy), axis=1).max())
    return float(best)


@pytest.mark.parametrize("seed", range(10))
def test_the_enclosing_circle_is_within_badoiu_clarkson_bound_of_the_smallest(seed: int) -> None:
    rng = np.random.default_rng(300 + seed)
    points = rng.normal(size=(int(rng.integers(2, 12)), 2)) * rng.random(2)
    smallest = _smallest_circle(points)
    for iterations in (25, 100, 400):
        centre = _cover.enclosing_circle(points, iterations)
        radius = np.linalg.norm(points - centre, axis=1).max()
        # after k steps the centre is within r*/sqrt(k) of the optimal one (Bădoiu and Clarkson 2003)
        assert smallest - 1e-12 <= radius <= smallest * (1.0 + 1.0 / np.sqrt(iterations)) + 1e-12


def test_invalid_inputs_are_value_errors() -> None:
    a, b, radii = np.zeros((2, 3)), np.ones((2, 3)), np.full(2, 0.1)
    points = np.zeros((3, 3))
    with pytest.raises(ValueError, match="differ in length"):
        _cover.coverage(a, b, radii[:1], points)
    with pytest.raises(ValueError, match="finite"):
        _cover.greedy_cover(a, b, np.array([0.1, np.nan]), points, 0.01)
    with pytest.raises(ValueError, match="cell"):
        _cover.greedy_cover(a, b, radii, points, 0.0)
    with pytest.raises(ValueError, match="too many cells"):
        _cover.greedy_cover(a, b, radii, np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]), 1e-9)
    with pytest.raises(ValueError, match="at least one point"):
        _cover.enclosing_circle(np.zeros((0, 2)), 10)
    assert _cover.greedy_cover(a, b, radii, np.zeros((0, 3)), 0.01).tolist() == []
    np.testing.assert_array_equal(_cover.coverage(a[:, ::-1], b, radii, points[:, ::-1]),  # any layout
                                  _contains(np.ascontiguousarray(a[:, ::-1]), b, radii, points))


# ---- the numba kernels' values -------------------------------------------------------------------------------

def _outputs(kernels: object) -> Iterator[np.ndarray]:
    """Every output of ``kernels`` (a module with the five functions) on the seeded cases, in a fixed order."""
    for seed in range(40):
        rng = np.random.default_rng(seed)
        lattice = seed % 2 == 0
        a, b, radii = _capsules(rng, int(rng.integers(1, 60)), lattice)
        points = _points(rng, int(rng.integers(1, 400)), lattice)
        yield kernels.coverage(a, b, radii, points)  # type: ignore[attr-defined]
        for skip in (-1, 0, len(radii) - 1, len(radii)):
            yield kernels.min_depth(a, b, radii, points, skip)  # type: ignore[attr-defined]
    for seed in range(60):
        (a, b, radii), points = _cover_case(seed)
        for cell in (*CELLS, _cover.cell_side(points, 0.004)):
            yield kernels.greedy_cover(a, b, radii, points, cell)  # type: ignore[attr-defined]
    for seed in range(20):
        rng = np.random.default_rng(200 + seed)
        directions = rng.normal(size=(int(rng.integers(300, 3000)), 3))
        vertices = directions / np.linalg.norm(directions, axis=1, keepdims=True) * rng.random(3) * 0.1
        outer, inner = _hull_facets(vertices)
        points = np.concatenate([rng.normal(size=(3000, 3)) * 0.05, vertices])
        for tolerance in (0.0, 1e-12, 1e-3):
            yield kernels.inside_hull(outer, inner, points, tolerance)  # type: ignore[attr-defined]
    for seed in range(30):
        rng = np.random.default_rng(300 + seed)
        points = rng.normal(size=(int(rng.integers(1, 300)), int(rng.integers(1, 5))))
        if seed % 3 == 0:
            points = np.round(points, 1)  # equal distances: the first farthest point
        for iterations in (0, 1, 7, 400):
            yield kernels.enclosing_circle(points, iterations)  # type: ignore[attr-defined]



# digest(_outputs(pfield.robot._cover)) when its five functions were numba's kernels, before they were removed
NUMBA_DIGEST = "d09514e7cb5c9de8787cb7311df5bf76d254298e4a09cf44b0aca0c624b9e2f9"


def test_the_outputs_are_the_numba_kernels_bit_for_bit() -> None:
    assert digest(_outputs(_cover)) == NUMBA_DIGEST


def test_greedy_cover_takes_what_the_numba_kernel_took() -> None:
    (a, b, radii), points = _cover_case(3)  # 547 candidates, 326 points on a lattice: ties everywhere
    assert _cover.greedy_cover(a, b, radii, points, 0.0173).tolist() == [
        1, 501, 504, 429, 328, 394, 106, 321, 47, 138, 272, 41, 156, 42, 164, 207, 446, 16, 143, 232, 327, 378, 469]
