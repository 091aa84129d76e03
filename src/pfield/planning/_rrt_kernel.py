"""Compiled bidirectional sampling search (RRT-Connect) with compiled state and edge checks (numba).

RRT-Connect (Kuffner & LaValle, "RRT-Connect: an efficient approach to single-query path planning",
ICRA 2000): two trees grow from the start and the goal; each iteration extends one tree by at most
``step`` toward a uniform sample of the box [lower, upper] and then greedily *connects* the other tree
toward the new node; the trees swap roles every iteration. The path found is shortened by random
shortcutting (Geraerts & Overmars, "Creating high-quality paths for motion planning", IJRR 2007) and a
final greedy pass.

Two state spaces share the code, chosen by :attr:`Checker.kind`:

* ``JOINT_SPACE`` — joint angles of a robot; a state is valid when every link keeps ``margin`` from
  every obstacle and every self-collision pair keeps ``margin`` from each other, both measured on the
  whole-body planner's own link model (:mod:`pfield.robot._clearance`) minus the scene's offsets (pairs
  that start or end closer than ``margin`` may go as deep as they start or end, never deeper).
* ``POINT_SPACE`` — an end-effector position in R³ (the task-space planner's model: the end effector
  is a point); valid when its signed distance to every obstacle is at least ``margin``.

An edge is valid when every state on it, interpolated so that no coordinate moves more than
``resolution`` (rad or m) between checks, is valid. The random numbers are a xorshift64* stream
(Vigna, "An experimental exploration of Marsaglia's xorshift generators", 2016) kept in an array, so a
search is a pure function of its seed. The search runs in chunks (``budget`` state checks per call)
that keep their trees in the caller's arrays, so the object layer can stop at a wall-clock limit.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from pfield.field._unowned import unowned, unowned_int
from pfield.geometry._sdf import mesh_addresses, min_signed_distance, row_signed_distance
from pfield.planning._whole_body_kernel import _segments
from pfield.planning._whole_body_layout import (
    RobotArrays,
    Scene,
    Workspace,
    unowned_robot,
    unowned_scene,
    unowned_workspace,
)
from pfield.robot._clearance import capsule_lower_bound, link_obstacle_distance, link_pair_distance
from pfield.robot._distance import segment_row_distance
from pfield.robot._kinematics import joint_transforms

JOINT_SPACE, POINT_SPACE = 0, 1
FOUND, SEARCHING, EXHAUSTED = 0, 1, 2
"""Search outcomes: a path was found; the chunk's budget ran out (call again); the trees are full."""
TRAPPED, ADVANCED, REACHED = 0, 1, 2


class Checker(NamedTuple):
    """What the validity test of one search needs (see the module docstring)."""

    kind: int
    robot: RobotArrays
    scene: Scene
    ws: Workspace
    obstacle: NDArray[np.float64]  # (L, M) scratch for link–obstacle clearances
    own: NDArray[np.float64]  # (P,) scratch for self clearances
    margin: float
    resolution: float
    counter: NDArray[np.int64]  # (1,) states checked so far


class Trees(NamedTuple):
    """Both trees of one search: ``nodes[t, k]`` with parent ``parents[t, k]`` (−1: root), ``counts[t]``;
    ``state`` = (which tree extends next, xorshift state as int64 bits)."""

    nodes: NDArray[np.float64]  # (2, capacity, n)
    parents: NDArray[np.int64]  # (2, capacity)
    counts: NDArray[np.int64]  # (2,)
    state: NDArray[np.uint64]  # (2,)


@njit(cache=True, inline="always")
def _unowned_checker(checker):  # type: ignore[no-untyped-def]
    """``checker`` with its arrays viewed without reference counting (:func:`pfield._layout.compile_unowned`):
    every state check binds them. The search's entries call this first; the caller's ``checker`` keeps the
    memory."""
    return Checker(checker.kind, unowned_robot(checker.robot), unowned_scene(checker.scene),
                   unowned_workspace(checker.ws), unowned(checker.obstacle), unowned(checker.own), checker.margin,
                   checker.resolution, unowned_int(checker.counter))


@njit(cache=True)
def make_trees(start, goals, capacity, seed):  # type: ignore[no-untyped-def]
    """Tree 0 rooted at ``start``, tree 1 at every row of ``goals`` (G, n) (several goal configurations of one
    goal pose: whichever the search reaches first), the random stream seeded by ``seed``."""
    n = start.shape[0]
    nodes = np.empty((2, capacity, n))
    parents = np.empty((2, capacity), dtype=np.int64)  # written as nodes are added; the roots have −1
    nodes[0, 0], parents[0, 0] = start, -1
    for g in range(goals.shape[0]):
        nodes[1, g], parents[1, g] = goals[g], -1
    state = np.empty(2, dtype=np.uint64)
    state[0] = np.uint64(0)
    # splitmix64 of the seed: a well-mixed non-zero xorshift state for every seed, 0 included
    z = np.uint64(seed) + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    state[1] = z if z != np.uint64(0) else np.uint64(1)
    counts = np.ones(2, dtype=np.int64)
    counts[1] = goals.shape[0]
    return Trees(nodes, parents, counts, state)


@njit(cache=True, inline="always")
def uniform(state):  # type: ignore[no-untyped-def]
    """Next number in [0, 1) of the xorshift64* stream in ``state[1]``."""
    x = state[1]
    x ^= x >> np.uint64(12)
    x ^= x << np.uint64(25)
    x ^= x >> np.uint64(27)
    state[1] = x
    return float((x * np.uint64(0x2545F4914F6CDD1D)) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def state_valid(checker, q):  # type: ignore[no-untyped-def]
    """Whether ``q`` keeps ``checker.margin`` from every obstacle (and, in joint space, from itself)."""
    checker.counter[0] += 1
    margin = checker.margin
    if checker.kind == POINT_SPACE:
        return min_signed_distance(checker.scene.packed, q)[0] >= margin
    return capsules_valid(q, checker.robot, checker.scene, checker.ws, margin)


@njit(cache=True)
def capsules_valid(q, robot, scene, ws, margin):  # type: ignore[no-untyped-def]
    """Every link–obstacle and self pair at least ``margin`` + its offset apart, measured on the same
    two-level link model as the planners and :func:`pfield.planning._whole_body_loop.pair_distances`
    (the fitted primitives of :func:`pfield.robot._clearance.link_obstacle_distance`; self pairs on the
    covering capsules), stopping at the first pair that is not.

    Most pairs are decided by exact lower bounds before the fitted primitives are looked at, cheapest first:
    the obstacle's bounding sphere against the link's covering capsule, the signed distance d(m) at the
    capsule axis's midpoint minus half its length (d is 1-Lipschitz), the covering capsule's own distance."""
    joint_transforms(q, robot.parents, robot.place_rot, robot.place_pos, robot.axes, robot.kinds, ws.rotations,
                     ws.origins)
    _segments(robot, ws)
    # hoisted out of the loops: numba reference-counts tuple members on every access (see _distance)
    seg_a, seg_b, cap_r, self_r, scratch = ws.seg_a, ws.seg_b, robot.cap_r, robot.self_r, ws.scratch
    link_start, prim_a, prim_b, prim_r = robot.link_start, ws.prim_seg_a, ws.prim_seg_b, robot.prim_r
    packed, centres, bounds, offsets = scene.packed, scene.centres, scene.bounds, scene.obstacle_offsets
    rows, kinds, meshes = packed.rows, packed.kinds, mesh_addresses(packed)
    for c in range(seg_a.shape[0]):
        a, b, radius = seg_a[c], seg_b[c], cap_r[c]
        mx, my, mz = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])
        half = 0.0
        for k in range(3):
            half += (b[k] - a[k]) ** 2
        half = 0.5 * math.sqrt(half)
        for i in range(bounds.shape[0]):
            need = margin + offsets[c, i]
            if capsule_lower_bound(centres, bounds, i, seg_a, seg_b, cap_r, c) >= need:
                continue
            # the packed arrays' hoisted forms: no reference-counted argument per pair
            if row_signed_distance(kinds, rows, meshes, i, mx, my, mz, math.inf)[0] - half - radius >= need:
                continue
            d = segment_row_distance(kinds, rows, meshes, i, a, b, scratch)[0]
            if d - radius >= need:
                continue
            d = link_obstacle_distance(c, i, kinds, rows, meshes, centres, bounds, seg_a, seg_b, cap_r, link_start,
                                       prim_a, prim_b, prim_r, scratch, need)[0]
            if d < need:
                return False
    pairs, self_offsets = robot.self_pairs, scene.self_offsets
    for k in range(pairs.shape[0]):
        if link_pair_distance(pairs[k, 0], pairs[k, 1], seg_a, seg_b, self_r)[0] - self_offsets[k] < margin:
            return False
    return True


@njit(cache=True)
def edge_valid(checker, a, b, point):  # type: ignore[no-untyped-def]
    """Whether the straight edge a → b is valid (``a`` itself is assumed valid); ``point`` is scratch.

    The states are checked in a coarse-to-fine order (every 8th, then every 4th, …) so that a blocked edge
    is usually refused after a few checks."""
    largest = 0.0
    for j in range(a.shape[0]):
        largest = max(largest, abs(b[j] - a[j]))
    steps = max(1, math.ceil(largest / checker.resolution))
    stride = 1
    while stride * 2 <= steps:
        stride *= 2
    done = np.zeros(steps + 1, dtype=np.bool_)
    done[0] = True
    while stride >= 1:
        for i in range(stride, steps + 1, stride):
            if done[i]:
                continue
            done[i] = True
            t = i / steps
            for j in range(a.shape[0]):
                point[j] = a[j] + t * (b[j] - a[j])
            if not state_valid(checker, point):
                return False
        stride //= 2
    if not done[steps]:
        for j in range(a.shape[0]):
            point[j] = b[j]
        return state_valid(checker, point)
    return True


@njit(cache=True, inline="always")
def _nearest(nodes, count, q):  # type: ignore[no-untyped-def]
    best, best_k = math.inf, 0
    for k in range(count):
        s = 0.0
        for j in range(q.shape[0]):
            diff = nodes[k, j] - q[j]
            s += diff * diff
        if s < best:
            best, best_k = s, k
    return best_k, math.sqrt(best)


@njit(cache=True)
def _extend(checker, trees, t, target, step, point, candidate):  # type: ignore[no-untyped-def]
    """Grow tree ``t`` by at most ``step`` toward ``target``; returns (TRAPPED | ADVANCED | REACHED, node)."""
    nodes, count = trees.nodes[t], trees.counts[t]
    if count >= nodes.shape[0]:
        return TRAPPED, -1
    near, distance = _nearest(nodes, count, target)
    reached = distance <= step
    scale = 1.0 if reached else step / distance
    for j in range(target.shape[0]):
        candidate[j] = nodes[near, j] + scale * (target[j] - nodes[near, j])
    if not edge_valid(checker, nodes[near], candidate, point):
        return TRAPPED, -1
    nodes[count] = candidate
    trees.parents[t, count] = near
    trees.counts[t] = count + 1
    return (REACHED if reached else ADVANCED), count


@njit(cache=True)
def _branch(trees, t, k):  # type: ignore[no-untyped-def]
    """Nodes from the root of tree ``t`` to node ``k``."""
    length, j = 0, k
    while j >= 0:
        length += 1
        j = trees.parents[t, j]
    out = np.empty((length, trees.nodes.shape[2]))
    j = k
    for i in range(length - 1, -1, -1):
        out[i] = trees.nodes[t, j]
        j = trees.parents[t, j]
    return out


@njit(cache=True)
def rrt_connect(checker, trees, lower, upper, step, budget):  # type: ignore[no-untyped-def]
    """Run RRT-Connect on ``trees`` for at most ``budget`` more state checks.

    Returns (FOUND, path (k, n) from start to goal) or (SEARCHING | EXHAUSTED, empty path)."""
    checker = _unowned_checker(checker)
    n = lower.shape[0]
    sample, point, candidate = np.empty(n), np.empty(n), np.empty(n)
    stop = checker.counter[0] + budget
    state = trees.state
    while checker.counter[0] < stop:
        if trees.counts[0] >= trees.nodes.shape[1] or trees.counts[1] >= trees.nodes.shape[1]:
            return EXHAUSTED, np.empty((0, n))
        a = np.int64(state[0])  # int64, not the state's uint64: _extend and _branch compile for one index type
        b = 1 - a
        state[0] = np.uint64(b)
        for j in range(n):
            sample[j] = lower[j] + uniform(state) * (upper[j] - lower[j])
        outcome, new = _extend(checker, trees, a, sample, step, point, candidate)
        if outcome == TRAPPED:
            continue
        target = trees.nodes[a, new].copy()
        outcome, other = ADVANCED, -1
        while outcome == ADVANCED:
            outcome, reached_node = _extend(checker, trees, b, target, step, point, candidate)
            if outcome != TRAPPED:
                other = reached_node
        if outcome == REACHED:
            from_a, from_b = _branch(trees, a, new), _branch(trees, b, other)
            first, second = (from_a, from_b) if a == 0 else (from_b, from_a)
            path = np.empty((first.shape[0] + second.shape[0] - 1, n))
            path[:first.shape[0]] = first
            for i in range(second.shape[0] - 1):  # the goal tree's branch reversed, the shared node once
                path[first.shape[0] + i] = second[second.shape[0] - 2 - i]
            return FOUND, path
    return SEARCHING, np.empty((0, n))


@njit(cache=True)
def shortcut(checker, path, attempts, state):  # type: ignore[no-untyped-def]
    """Shorter valid path through a subset of ``path``'s vertices: ``attempts`` random shortcuts i → j,
    then a greedy pass joining each kept vertex to the farthest later one it sees."""
    checker = _unowned_checker(checker)
    n = path.shape[1]
    keep = np.ones(path.shape[0], dtype=np.bool_)
    point = np.empty(n)
    index = np.arange(path.shape[0])
    count = path.shape[0]
    for _ in range(attempts):
        if count <= 2:
            break
        i = int(uniform(state) * count)
        j = int(uniform(state) * count)
        if i > j:
            i, j = j, i
        if j - i < 2:
            continue
        if edge_valid(checker, path[index[i]], path[index[j]], point):
            for k in range(i + 1, j):
                keep[index[k]] = False
            count = 0
            for k in range(path.shape[0]):
                if keep[k]:
                    index[count] = k
                    count += 1
    out = np.empty((count, n))
    out[0] = path[index[0]]
    size, i = 1, 0
    while i < count - 1:
        j = count - 1
        while j > i + 1 and not edge_valid(checker, path[index[i]], path[index[j]], point):
            j -= 1
        out[size] = path[index[j]]
        size += 1
        i = j
    return out[:size]
