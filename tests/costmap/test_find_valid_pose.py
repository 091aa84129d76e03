"""FindValidPose: hand-made maps for each rule, and a brute-force oracle on 200 random maps."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from pfield.costmap import (
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
    Footprint,
    PoseState,
    costs_from_occupancy,
    find_valid_pose,
    inflate,
    pose_state,
)
from pfield.errors import InvalidInput
from pfield.spatial import Pose

SQUARE = Footprint.from_points([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]])


def _oracle_cells(costmap: Costmap2D, footprint: Footprint, x: float, y: float, yaw: float) -> list[tuple[int, int]]:
    """Covered cells by shapely (closed polygon ∩ closed cell; equal to the half-open rule in general position)."""
    polygon = Polygon(footprint.posed(x, y, yaw))
    res, ox, oy = costmap.resolution, costmap.origin_x, costmap.origin_y
    x0, y0, x1, y1 = polygon.bounds
    ms, ns = np.meshgrid(np.arange(math.floor((x0 - ox) / res), math.floor((x1 - ox) / res) + 1),
                         np.arange(math.floor((y0 - oy) / res), math.floor((y1 - oy) / res) + 1))
    ms, ns = ms.ravel(), ns.ravel()
    boxes = shapely.box(ox + ms * res, oy + ns * res, ox + (ms + 1) * res, oy + (ns + 1) * res)
    hit = shapely.intersects(polygon, boxes)
    return list(zip(ms[hit].tolist(), ns[hit].tolist(), strict=True))


def _oracle_state(costmap: Costmap2D, footprint: Footprint, x: float, y: float, yaw: float) -> tuple[int, int]:
    cells = _oracle_cells(costmap, footprint, x, y, yaw)
    inside = [(m, n) for m, n in cells if 0 <= m < costmap.size_x and 0 <= n < costmap.size_y]
    values = [int(costmap.costs[n, m]) for m, n in inside]
    cost = sum(values)
    if len(inside) < len(cells):
        return PoseState.OUTSIDE, cost
    for value, state in ((254, PoseState.LETHAL), (255, PoseState.UNKNOWN), (253, PoseState.INSCRIBED)):
        if value in values:
            return state, cost
    return PoseState.FREE, cost


def _oracle(costmap: Costmap2D, footprint: Footprint, x: float, y: float, yaw: float, dist_tol: float,
            angle_tol: float, step: float) -> tuple[PoseState, float, float, float, float]:
    """Every lattice cell within dist_tol and every yaw step within angle_tol, then the answer rule."""
    res = costmap.resolution
    reach = int(dist_tol / res) + 1
    deltas = [0.0]
    k = 1
    while k * step <= min(angle_tol, math.pi) + 1e-12:
        deltas += [k * step] + ([-k * step] if k * step < math.pi - 1e-12 else [])
        k += 1
    candidates = []
    for i in range(-reach, reach + 1):
        for j in range(-reach, reach + 1):
            if res * math.hypot(i, j) > dist_tol * (1 + 1e-9) + 1e-12:
                continue
            for delta in deltas:
                state, _ = _oracle_state(costmap, footprint, x + i * res, y + j * res, yaw + delta)
                polar = math.atan2(j, i) % (2 * math.pi)
                key = (i * i + j * j, abs(delta), delta < 0, polar)
                candidates.append((key, state, i, j, delta))
    candidates.sort(key=lambda c: c[0])
    good = [c for c in candidates if c[1] in (PoseState.FREE, PoseState.INSCRIBED)]
    if good:
        nearest = good[0][0][0]
        ring = [c for c in good if c[0][0] == nearest]
        best = next((c for c in ring if c[1] == PoseState.FREE), ring[0])
    else:
        best = next((c for c in candidates if c[1] == PoseState.UNKNOWN),
                    next((c for c in candidates if c[1] == PoseState.OUTSIDE), None))
    if best is None:
        return PoseState.LETHAL, math.nan, math.nan, math.nan, math.nan
    _, state, i, j, delta = best
    return state, res * math.hypot(i, j), x + i * res, y + j * res, delta


def _random_case(rng: np.random.Generator) -> tuple[Costmap2D, Footprint, Pose, float, float]:
    size = int(rng.integers(8, 15))
    data = rng.choice(np.array([0, 100, -1], dtype=np.int8), size=(size, size), p=[0.8, 0.12, 0.08])
    res = 0.1
    costs = inflate(costs_from_occupancy(data), res, 0.1, 0.25, 5.0)
    costmap = Costmap2D(costs, res, origin_x=-0.3, origin_y=0.2)
    shapes = [
        [[0.2, 0.1], [-0.2, 0.1], [-0.2, -0.1], [0.2, -0.1]],
        [[0.15, 0.0], [-0.1, 0.12], [-0.1, -0.12]],
        [[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.0, -0.05], [0.2, -0.2]],  # concave
    ]
    choice = int(rng.integers(0, 4))
    # the 16-gon's inscribed disc fills most of it: the lethal-distance prefilter works at its limit
    footprint = Footprint.from_radius(0.22) if choice == 3 else Footprint.from_points(shapes[choice])
    x = rng.uniform(-0.5, -0.3 + size * res + 0.2)
    y = rng.uniform(0.0, 0.2 + size * res + 0.2)
    pose = Pose.planar(x, y, rng.uniform(-math.pi, math.pi))
    return costmap, footprint, pose, float(rng.uniform(0.0, 0.35)), float(rng.uniform(0.0, 3.5))


def test_matches_brute_force_oracle_on_200_random_maps() -> None:
    rng = np.random.default_rng(2024)
    step = 0.4
    seen = set()
    for _ in range(200):
        costmap, footprint, pose, dist_tol, angle_tol = _random_case(rng)
        result = find_valid_pose(costmap, footprint, pose, dist_tolerance=dist_tol, angle_tolerance=angle_tol,
                                 angle_increment=step)
        x, y, yaw = float(pose.position[0]), float(pose.position[1]), pose.yaw
        state, distance, ox, oy, delta = _oracle(costmap, footprint, x, y, yaw, dist_tol, angle_tol, step)
        seen.add(state)
        assert result.state == state
        if state == PoseState.LETHAL:
            assert result.pose is None
            continue
        assert result.pose is not None and result.distance is not None
        assert result.distance == pytest.approx(distance, abs=1e-9)
        assert result.pose.position[:2] == pytest.approx([ox, oy], abs=1e-9)
        assert result.yaw_offset == pytest.approx(delta, abs=1e-12)
        # the returned pose really has the returned state and cost
        got_state, got_cost = _oracle_state(costmap, footprint, ox, oy, result.pose.yaw)
        assert (got_state, got_cost) == (result.state, result.cost)
    assert seen == set(PoseState)  # every answer kind was exercised


def _corridor(width_cells: int, length_cells: int = 20) -> Costmap2D:
    """A vertical corridor ``width_cells`` wide between lethal walls, open (free) at both ends."""
    costs = np.zeros((length_cells, width_cells + 2), dtype=np.uint8)
    costs[:, 0] = costs[:, -1] = LETHAL_OBSTACLE
    return Costmap2D(costs, 0.1)


def test_free_pose_returned_unchanged_with_cost_sum() -> None:
    costs = np.zeros((10, 10), dtype=np.uint8)
    costs[4:7, 4:7] = np.arange(9, dtype=np.uint8).reshape(3, 3) * 10
    costmap = Costmap2D(costs, 0.1)
    pose = Pose((0.53, 0.57, 0.0), (0.0, 0.0, math.sin(0.2), math.cos(0.2)))
    result = find_valid_pose(costmap, SQUARE, pose, dist_tolerance=0.5, angle_tolerance=1.0)
    assert result.state == PoseState.FREE and result.pose is pose
    cells = SQUARE.cells(0.53, 0.57, 0.4, (0.0, 0.0), 0.1)
    assert result.cost == sum(int(costs[n, m]) for m, n in cells.tolist()) > 0
    assert result.distance == 0.0 and result.yaw_offset == 0.0 and result.trace.evaluated == 1


def test_lethal_goal_moves_to_closest_free_pose() -> None:
    costs = np.zeros((12, 12), dtype=np.uint8)
    costs[5, 5] = LETHAL_OBSTACLE
    costmap = Costmap2D(costs, 0.1)
    pose = Pose.planar(0.55, 0.55, 0.0)
    result = find_valid_pose(costmap, SQUARE, pose, dist_tolerance=0.5, angle_tolerance=0.0)
    assert result.state == PoseState.FREE and result.pose is not None
    # the 0.2 m square at a cell centre covers 3×3 cells: it must move two cells off the obstacle
    assert result.distance == pytest.approx(0.2)
    assert pose_state(costmap, SQUARE, *result.pose.position[:2], 0.0)[0] == PoseState.FREE


def test_rotation_only_answer_in_narrow_corridor() -> None:
    costmap = _corridor(4)  # free x ∈ [0.1, 0.5)
    long_robot = Footprint.from_points([[0.5, 0.15], [-0.5, 0.15], [-0.5, -0.15], [0.5, -0.15]])
    pose = Pose.planar(0.3, 1.0, 0.0)  # lying across the corridor: hits both walls
    result = find_valid_pose(costmap, long_robot, pose, dist_tolerance=0.0, angle_tolerance=math.pi)
    assert result.state == PoseState.FREE and result.pose is not None
    assert result.distance == 0.0
    # x extent at yaw ψ: 1.0·|cos ψ| + 0.3·|sin ψ| < 0.4 first holds at ψ = 85° (0.386 m; 80° gives 0.469 m)
    assert result.yaw_offset == pytest.approx(math.radians(85))
    np.testing.assert_allclose(result.pose.position, pose.position)


def test_unknown_chosen_over_closer_outside() -> None:
    costs = np.zeros((10, 10), dtype=np.uint8)
    costs[:, :] = LETHAL_OBSTACLE
    costs[:, 6:] = NO_INFORMATION  # unknown strip, 0.6 m ≤ x < 1.0
    costmap = Costmap2D(costs, 0.1)
    pose = Pose.planar(0.55, 0.95, 0.0)  # top edge: OUTSIDE right here, UNKNOWN a little lower
    result = find_valid_pose(costmap, SQUARE, pose, dist_tolerance=0.5)
    assert result.state == PoseState.UNKNOWN and result.distance is not None and result.distance > 0.0
    first = find_valid_pose(costmap, SQUARE, pose)
    assert first.state == PoseState.OUTSIDE and first.pose is pose


def test_lethal_with_no_pose_when_nothing_fits() -> None:
    costs = np.full((20, 10), LETHAL_OBSTACLE, dtype=np.uint8)
    costs[:, 4] = 0  # a corridor one cell wide: the 0.2 m square fits nowhere, and never sticks out
    costmap = Costmap2D(costs, 0.1)
    result = find_valid_pose(costmap, SQUARE, Pose.planar(0.45, 1.0, 0.0), dist_tolerance=0.3,
                             angle_tolerance=math.pi)
    assert result.state == PoseState.LETHAL and result.pose is None and result.cost == 0
    assert result.trace.evaluated == result.trace.states.size


def test_concave_footprint_with_obstacle_in_notch_is_free() -> None:
    costs = np.zeros((10, 10), dtype=np.uint8)
    costs[5, 4] = LETHAL_OBSTACLE  # cell x ∈ [0.4, 0.5), y ∈ [0.5, 0.6)
    costmap = Costmap2D(costs, 0.1)
    u_shape = Footprint.from_points([[0.25, -0.25], [0.25, 0.25], [0.07, 0.25], [0.07, 0.0], [-0.07, 0.0],
                                     [-0.07, 0.25], [-0.25, 0.25], [-0.25, -0.25]])
    pose = Pose.planar(0.45, 0.39, 0.0)  # notch x ∈ (0.38, 0.52), y > 0.39 holds the obstacle cell
    state, _ = pose_state(costmap, u_shape, 0.45, 0.39, 0.0)
    assert state == PoseState.FREE
    result = find_valid_pose(costmap, u_shape, pose)
    assert result.state == PoseState.FREE and result.pose is pose
    rotated = find_valid_pose(costmap, u_shape, Pose.planar(0.45, 0.39, math.pi / 2))
    assert rotated.state == PoseState.LETHAL


def test_yaw_tolerance_across_pi() -> None:
    # horizontal corridor 0.4 m wide: a 1.0 × 0.2 m robot fits only within ~0.2 rad of the corridor axis
    costs = np.zeros((6, 30), dtype=np.uint8)
    costs[0, :] = costs[5, :] = LETHAL_OBSTACLE
    costmap = Costmap2D(costs, 0.1)
    robot = Footprint.from_points([[0.5, 0.1], [-0.5, 0.1], [-0.5, -0.1], [0.5, -0.1]])
    pose = Pose.planar(1.5, 0.3, 2.9)  # 0.24 rad off the axis: lethal
    assert find_valid_pose(costmap, robot, pose).state == PoseState.LETHAL
    result = find_valid_pose(costmap, robot, pose, angle_tolerance=0.5, angle_increment=0.3)
    assert result.state == PoseState.FREE and result.pose is not None
    assert result.yaw_offset == pytest.approx(0.3)
    assert result.pose.yaw == pytest.approx(3.2 - 2 * math.pi)  # crossed +π into negative yaws
    assert find_valid_pose(costmap, robot, pose, angle_tolerance=0.25, angle_increment=0.3).state == PoseState.LETHAL
    mirrored = find_valid_pose(costmap, robot, Pose.planar(1.5, 0.3, -2.9), angle_tolerance=0.5, angle_increment=0.3)
    assert mirrored.yaw_offset == pytest.approx(-0.3) and mirrored.pose is not None
    assert mirrored.pose.yaw == pytest.approx(2 * math.pi - 3.2)


def test_zero_tolerances_answer_for_the_pose_itself() -> None:
    costs = np.zeros((10, 10), dtype=np.uint8)
    costs[5, 5] = LETHAL_OBSTACLE
    costmap = Costmap2D(costs, 0.1)
    free = find_valid_pose(costmap, SQUARE, Pose.planar(0.2, 0.2, 0.3))
    assert free.state == PoseState.FREE and free.trace.states.shape == (1, 1)
    lethal = find_valid_pose(costmap, SQUARE, Pose.planar(0.52, 0.55, 0.3))
    assert lethal.state == PoseState.LETHAL and lethal.pose is None and lethal.trace.evaluated == 1


def test_inscribed_answer_and_free_preferred_at_equal_distance() -> None:
    costs = np.zeros((9, 9), dtype=np.uint8)
    costs[4, 4] = LETHAL_OBSTACLE
    costs[4, 2] = 253  # left of the obstacle: inscribed; right side stays free
    costmap = Costmap2D(costs, 0.1)
    result = find_valid_pose(costmap, SQUARE, Pose.planar(0.45, 0.45, 0.0), dist_tolerance=0.2)
    # ring at 0.2 m: (+2, 0) is FREE, (-2, 0) INSCRIBED and first in polar order would be (+2, 0) anyway;
    # the INSCRIBED (0, ±2) / (-2, 0) must lose against FREE ones of the same ring
    assert result.state == PoseState.FREE and result.distance == pytest.approx(0.2)
    only_inscribed = np.full((9, 9), 253, dtype=np.uint8)
    only_inscribed[4, 4] = LETHAL_OBSTACLE
    result = find_valid_pose(Costmap2D(only_inscribed, 0.1), SQUARE, Pose.planar(0.45, 0.45, 0.0),
                             dist_tolerance=0.3)
    assert result.state == PoseState.INSCRIBED and result.distance == pytest.approx(0.2)
    assert result.cost == 9 * 253


def test_safety_dist_pads_the_footprint() -> None:
    costs = np.zeros((10, 10), dtype=np.uint8)
    costs[5, 7] = LETHAL_OBSTACLE  # x ∈ [0.7, 0.8)
    costmap = Costmap2D(costs, 0.1)
    pose = Pose.planar(0.45, 0.55, 0.0)  # square spans x ∈ [0.35, 0.55]
    assert find_valid_pose(costmap, SQUARE, pose).state == PoseState.FREE
    assert find_valid_pose(costmap, SQUARE, pose, safety_dist=0.2).state == PoseState.LETHAL


def test_far_away_pose_is_outside_and_huge_tolerance_is_bounded() -> None:
    costmap = Costmap2D(np.full((5, 5), LETHAL_OBSTACLE, dtype=np.uint8), 0.1)
    result = find_valid_pose(costmap, SQUARE, Pose.planar(50.0, 50.0, 0.0), dist_tolerance=1.0)
    assert result.state == PoseState.OUTSIDE and result.distance == 0.0
    result = find_valid_pose(costmap, SQUARE, Pose.planar(0.25, 0.25, 0.0), dist_tolerance=1e4)
    assert result.state == PoseState.OUTSIDE and result.distance == pytest.approx(0.2)  # first to stick out


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"dist_tolerance": -0.1}, "dist_tolerance"), ({"angle_tolerance": -1.0}, "angle_tolerance"),
     ({"safety_dist": -0.01}, "safety_dist"), ({"dist_tolerance": math.nan}, "dist_tolerance"),
     ({"angle_tolerance": math.inf}, "angle_tolerance"), ({"angle_increment": 0.0}, "angle_increment")],
)
def test_bad_arguments_rejected(kwargs: dict[str, float], field: str) -> None:
    costmap = Costmap2D(np.zeros((5, 5), dtype=np.uint8), 0.1)
    with pytest.raises(InvalidInput) as info:
        find_valid_pose(costmap, SQUARE, Pose.planar(0.25, 0.25, 0.0), **kwargs)  # type: ignore[arg-type]
    assert info.value.field == field
