"""Collision checks of a robot configuration: fast (link capsules, compiled) and exact (coal on the meshes).

* :func:`capsule_clearances` — signed clearance (m) of every link's fitted model to every obstacle and of
  every self-collision link pair, from the compiled kernels the planner uses (conservative: the fitted
  spheres/capsules cover the links' collision surfaces).
* :class:`CollisionChecker` — the robot's own URDF collision geometry (pinocchio ``GeometryModel``; link
  meshes through their convex hulls, which contain them, so "no collision" stays true; where two hulls touch,
  the meshes themselves decide) against
  the obstacles' exact shapes with coal (Pan et al., "FCL", ICRA 2012, coal is its successor); self
  collisions over the link pairs that are neither adjacent (one joint apart) nor disabled by the SRDF.
  ``check(q, margin)`` reports whether any distance is below ``margin`` (m) and which pair, ``contact(q, margin)``
  the same verdict from coal on the few pairs whose cheap bound can decide it;
  :meth:`CollisionChecker.pair_distances` gives the distance of chosen pairs and
  :attr:`CollisionChecker.motion_weights` how far a joint motion can bring each pair closer (the bound of the
  trajectory certificate, :mod:`pfield.planning.certify`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from pfield._core import robot as _robot_core
from pfield._core import robot_distance as _distance
from pfield._validation import nonnegative
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, Sphere, empty_packed, pack_obstacles
from pfield.robot._fit import segment_distances
from pfield.robot.geometry import adjacent_joints
from pfield.robot.model import RobotModel
from pfield.spatial import Pose

__all__ = ["DISTANCE_TOLERANCE", "UNBOUNDED_WEIGHT", "CapsuleClearances", "CollisionChecker", "CollisionReport",
           "capsule_clearances", "coal_geometry", "motion_bounds", "self_pair_weights"]

DISTANCE_TOLERANCE = 1e-6
"""(m) how far coal's distance may be from the exact one (its GJK tolerance): a lower bound of a pair's distance
decides nothing closer than this (:meth:`CollisionChecker.distances`, the certificate's advancement)."""


@dataclass(frozen=True)
class CollisionReport:
    """Result of :meth:`CollisionChecker.check`: ``in_collision`` when a distance is below the margin.

    ``distance`` (m) is the smallest robot–obstacle distance (``inf`` without obstacles), ``self_distance``
    the smallest distance between checked link pairs; ``pair`` names the closest offending pair ("" if none).
    """

    in_collision: bool
    distance: float
    self_distance: float
    pair: str


@dataclass(frozen=True, eq=False)
class CapsuleClearances:
    """Clearances (m) of the fitted link model at one configuration, with the names of what they are between.

    ``obstacle[c, i]`` is the signed clearance of link c (``links[c]``, in ``robot.geometry.capsules``
    order) to obstacle i (``obstacle_ids[i]``); ``self_pairs[k]`` that of the self-collision pair
    ``pair_links[k]``.
    """

    obstacle: NDArray[np.float64]  # (L, M)
    self_pairs: NDArray[np.float64]  # (P,)
    links: tuple[str, ...]
    obstacle_ids: tuple[str, ...]
    pair_links: tuple[tuple[str, str], ...]

    def between(self, link: str, obstacle_id: str) -> float:
        """Clearance (m) of ``link`` to obstacle ``obstacle_id``."""
        return float(self.obstacle[self.links.index(link), self.obstacle_ids.index(obstacle_id)])

    def nearest(self) -> tuple[str, str, float]:
        """(link, obstacle id, clearance in m) of the closest link–obstacle pair (("", "", inf) without)."""
        if self.obstacle.size == 0:
            return "", "", float("inf")
        c, i = np.unravel_index(int(np.argmin(self.obstacle)), self.obstacle.shape)
        return self.links[int(c)], self.obstacle_ids[int(i)], float(self.obstacle[c, i])


def capsule_clearances(robot: RobotModel, q: ArrayLike, obstacles: Sequence[Obstacle]) -> CapsuleClearances:
    """Clearances (m) of the fitted link model at joint angles ``q``: every link × obstacle and every
    self-collision pair (the compiled distances the planner uses)."""
    values = robot.check_joint_angles(q)
    packed = pack_obstacles(list(obstacles)) if obstacles else empty_packed()
    g = robot.geometry
    # exact values everywhere: infinite bounding radii never cull a pair
    centres, bounds = np.ascontiguousarray(packed.rows[:, 0:3]), np.full(len(packed.kinds), np.inf)
    # the robot with its link model, in RobotArrays' order (the planners bind theirs with their own limits)
    bound = _robot_core.Robot(*robot.kinematics, g.joints, g.a, g.b, g.radii, g.self_pairs, robot.lower_limits,
                              robot.upper_limits, robot.velocity_limits, robot.acceleration_limits, g.link_start,
                              g.prim_joint, g.prim_a, g.prim_b, g.prim_r, g.self_radii)
    clearances = _distance.clearances_at(bound, values, _robot_core.Obstacles(*packed, centres, bounds))
    obstacle, own = clearances.obstacle, clearances.own
    links = robot.geometry.link_names
    pairs = tuple((links[int(a)], links[int(b)]) for a, b in robot.geometry.self_pairs)
    return CapsuleClearances(obstacle, own, links, tuple(o.id for o in obstacles), pairs)


def coal_geometry(obstacle: Obstacle) -> coal.CollisionGeometry:
    """The coal geometry of ``obstacle``'s shape in its local frame (the exact checks of plans and of the benchmarks'
    claims); a shape it does not know is refused by name (``TypeError``)."""
    shape = obstacle.shape
    if isinstance(shape, Sphere):
        return coal.Sphere(shape.radius)
    if isinstance(shape, Box):
        return coal.Box(shape.length, shape.width, shape.height)
    if isinstance(shape, Cylinder):
        return coal.Cylinder(shape.radius, shape.height)
    if isinstance(shape, Capsule):
        return coal.Capsule(shape.radius, shape.height)
    if isinstance(shape, Ellipsoid):
        return coal.Ellipsoid(shape.semi_x, shape.semi_y, shape.semi_z)
    if not isinstance(shape, Mesh):
        raise TypeError(f"no coal geometry for obstacle shape {type(shape).__name__}")
    model = coal.BVHModelOBBRSS()
    model.beginModel(len(shape.data.faces), len(shape.data.vertices))
    model.addVertices(np.asarray(shape.data.vertices, dtype=np.float64))
    model.addTriangles(np.asarray(shape.data.faces, dtype=np.int64))
    model.endModel()
    return model


def _convex_hull(shape: coal.CollisionGeometry) -> coal.CollisionGeometry:
    """The convex hull of a link mesh (qhull through coal; GJK on it is fast, and it contains the mesh, so its
    distance is a lower bound of the mesh's).

    Not ``buildConvexRepresentation``: that takes the mesh's own vertices and faces *as* a convex polytope, and on
    a concave link mesh GJK's hill-climbing support search stops at local maxima: distances up to 0.42 m too large
    on the UR5's links (a box 15 cm around each link, 200 poses: 51–180 of 200 too far on every arm link), so
    contacts went unseen (issue 34)."""
    if isinstance(shape, coal.BVHModelBase):
        shape.buildConvexHull(True, "Qt")
        return shape.convex
    return shape


@functools.lru_cache(maxsize=8)
def _convex_hulls(robot: RobotModel) -> list[coal.CollisionGeometry]:
    return [_convex_hull(obj.geometry.clone()) for obj in robot.collision_model.geometryObjects]


UNBOUNDED_WEIGHT = 1e9
"""(m/rad or m/m) what :attr:`CollisionChecker.motion_weights` of an unlimited prismatic joint (inf) counts as."""

_HULLS_ONLY = float(np.nextafter(0.0, 1.0))
"""The distance :meth:`CollisionChecker.pair_distances` gives a pair whose convex hulls touch but whose meshes do
not: not a contact, and no clearance either."""


def _transform(obstacle: Obstacle) -> coal.Transform3s:
    return coal.Transform3s(np.asarray(obstacle.pose.rotation), np.asarray(obstacle.pose.position))


class CollisionChecker:
    """Exact distances between the robot's URDF collision geometry and obstacles (coal), and self-distances.

    The checked pairs, in one table (:attr:`pair_names`): every collision object × every obstacle first, then
    the self pairs — collision objects on different bodies whose links are neither adjacent (one joint apart)
    nor disabled by the SRDF's ``disable_collisions``. Which pairs is a function of the robot description.
    """

    def __init__(self, robot: RobotModel, obstacles: Sequence[Obstacle] = ()) -> None:
        self.robot = robot
        self._obstacles = [(o.id, coal_geometry(o), _transform(o)) for o in obstacles]
        self._obstacle_list = tuple(obstacles)
        self._shapes = _convex_hulls(robot)
        self._tables = tables = _robot_tables(robot)
        self._meshes, self._triangles, self._local = tables.meshes, tables.triangles, tables.local
        self._pairs = tables.pairs
        n_objects, n_obstacles = len(tables.names), len(self._obstacles)
        # pair table: (first object, second object or obstacle, second is an obstacle)
        first = [g for g in range(n_objects) for _ in range(n_obstacles)] + [i for i, _ in self._pairs]
        second = [i for _ in range(n_objects) for i in range(n_obstacles)] + [j for _, j in self._pairs]
        self._first, self._second = np.array(first, dtype=np.int64), np.array(second, dtype=np.int64)
        self._obstacle_pair = np.arange(len(first)) < n_objects * n_obstacles
        self._classes = (np.flatnonzero(self._obstacle_pair), np.flatnonzero(~self._obstacle_pair))
        """The robot–obstacle pairs' indices and the self pairs' (each class answered on its own by distances)."""
        self._records = list(zip(first, second, self._obstacle_pair.tolist(), strict=True))
        self._request, self._result = coal.DistanceRequest(), coal.DistanceResult()
        self.pair_names: tuple[str, ...] = tuple(
            f"{name}/{obstacle[0]}" for name in tables.names for obstacle in self._obstacles) + tables.pair_names
        """``link object/obstacle id`` or ``object/object`` of every checked pair, in table order."""

    @property
    def self_pair(self) -> NDArray[np.bool_]:
        """(P,) whether each pair of :attr:`pair_names` is between two of the robot's collision objects."""
        return ~self._obstacle_pair

    @functools.cached_property
    def motion_weights(self) -> NDArray[np.float64]:
        """(P, n) weights w_pj (m/rad or m/m): a joint motion Δq brings pair p at most Σ_j w_pj |Δq_j| closer.

        The bound of Schwarzer, Saha & Latombe ("Adaptive dynamic collision checking for single and multiple
        articulated robots in complex environments", IEEE T-RO 21(3), 2005, §III): a revolute joint j turning by
        Δθ moves every point of a body it carries by at most r·|Δθ| (an arc of radius r, the point's distance
        from the axis); a prismatic joint by |Δq|; over a straight joint-space motion the displacements add up.
        r_gj bounds the distance of object g from joint j's axis at *every* configuration: the distance from
        joint j's origin (on its axis) ≤ Σ |joint origin offsets| down the chain to g's joint + the largest
        travel of the prismatic joints between + the largest distance of g's convex hull (or bounding box) from
        its joint's origin, or where smaller, its distance from a line or point of the axis fixed in g's frame
        (:func:`_axis_bounds`: a joint's own axis; the wrist 1 axis, which meets wrist 2's). Obstacle pairs:
        w = r of the object (obstacles are static). Self pairs: the joints that carry both objects move them
        rigidly together, so only the joints of one object's chain and not the other's count, each with the
        smaller of its own object's r and the other object's distance from the joint's axis
        (:func:`_axis_bounds` again, where one is known): at the closest points p_a, p_b (d > 0) the distance
        changes at the rate n·(v_b − v_a), n = (p_b − p_a)/d, and a rotation ω about axis j (through o_j) that
        moves b alone adds n·(ω × (p_b − o_j)) = n·(ω × (p_a − o_j)), since n·(ω × (p_b − p_a)) = 0: its rate is
        bounded by either point's distance from the axis. (The UR5's base and upper arm: the shoulder pan turns
        the upper arm, 0.51 m from its axis at most, about the base, 0.11 m from it.)
        """
        tables = self._tables
        first, second, obstacle = self._first, self._second, self._obstacle_pair
        weights = np.zeros((len(self.pair_names), self.robot.n_joints))
        weights[obstacle] = tables.bounds[first[obstacle]]  # 0 where j does not move the object
        weights[~obstacle] = self_pair_weights(tables.bounds, tables.supports, tables.cross, first[~obstacle],
                                               second[~obstacle])
        return weights

    @functools.cached_property
    def _covering(self) -> tuple[_robot_core.Robot, _robot_core.Obstacles, NDArray[np.float64]]:
        """The compiled covering capsules of the collision objects (:meth:`covering_distances`): the robot bound
        with one capsule per object, the obstacles, and the slack (P,) taken off each pair's value."""
        covering, axis_length = _covering_capsules(self.robot)
        proxies = [_covering_proxy(o) for o in self._obstacle_list]
        packed = pack_obstacles(proxies) if proxies else empty_packed()
        obstacles = _robot_core.Obstacles(*packed, np.ascontiguousarray(packed.rows[:, 0:3]),
                                          np.full(len(packed.kinds), np.inf))
        # segment_obstacle_distance is the exact minimum for spheres, capsules and boxes (the proxies of ellipsoids
        # and meshes among them); within |b - a| 2^-24 of it for cylinders (bisection)
        per_obstacle = np.array([2.0 ** -20 if isinstance(o.shape, Cylinder) else 0.0 for o in proxies])
        slack = (axis_length[:, None] * per_obstacle.reshape(1, -1)).reshape(-1)
        return covering, obstacles, np.concatenate([slack, np.zeros(len(self._pairs))])

    def covering_distances(self, qs: NDArray[np.float64]) -> NDArray[np.float64]:
        """(P, N) lower bounds (m) of every pair's distance (:attr:`pair_names` order) at the validated
        configurations ``qs`` (N, n), from covering capsules, in one compiled call.

        Each collision object g gets its link's covering capsule axis (:attr:`RobotGeometry.a`/``b``, joint frame)
        with the radius ρ_g = the largest distance of g's checked shape from that axis (the convex hull's vertices,
        else the corners of the shape's local bounding box): a capsule that contains the hull and so the mesh
        (ρ_g ≤ the link's covering radius). A pair's bound is the capsules' distance (capsule–obstacle: the axis's
        exact signed distance less ρ; self pairs: segment–segment less both radii), never more than the exact
        distance coal computes. Against an ellipsoid or a mesh, the capsule's distance to a box that contains it
        (:func:`_covering_proxy`)."""
        bound, obstacles, slack = self._covering
        obstacle, own = _distance.covering_clearances(bound, np.ascontiguousarray(qs, dtype=np.float64), obstacles)
        n = len(qs)
        every = np.concatenate([np.asarray(obstacle).reshape(n, -1), np.asarray(own).reshape(n, -1)], axis=1).T
        return every - slack[:, None]

    def covering_needed(self, qs: NDArray[np.float64], travel: NDArray[np.float64],
                        tolerance: float) -> NDArray[np.bool_]:
        """(P, N): where the covering capsules cannot clear pair p at configuration k of the validated path
        ``qs`` (N, n), in one compiled call. ``travel`` (N, n) is the joint travel Σ|Δq_j| accumulated from
        ``qs[0]``; pair p closes by at most reach_p = :attr:`motion_weights` · travel (m) along it. Walking each pair
        along the path: at k the bound b = :meth:`covering_distances` − ``tolerance`` (m); b > 0 clears k and every
        k' after it with reach_p[k'] − reach_p[k] < b, which are skipped; b ≤ 0 marks k."""
        bound, obstacles, slack = self._covering
        weights = np.ascontiguousarray(np.minimum(self.motion_weights, UNBOUNDED_WEIGHT))
        mask = _distance.covering_needed(bound, np.ascontiguousarray(qs, dtype=np.float64), obstacles,
                                         np.ascontiguousarray(travel, dtype=np.float64), weights, slack + tolerance)
        return np.asarray(mask, dtype=bool)

    def _placements(self, q: NDArray[np.float64], objects: Iterable[int]) -> dict[int, coal.Transform3s]:
        """coal placements in the world of the collision objects ``objects`` at validated ``q`` (float64, (n,),
        within the limits: the core's joint frames are read without checking it again)."""
        rotations, origins = self.robot._core_kinematics.joint_frames(q)
        placed = {}
        for g in objects:  # one object at a time: the calls see a few objects, where vectorising costs more
            joint, local = self._local[g]
            # coal composes the joint's frame with the object's (2.5 us for two objects, where numpy's products
            # and a new transform took 6); an object on the root gets a copy of its placement, not the shared one
            placed[g] = coal.Transform3s(local) if joint < 0 else \
                coal.Transform3s(rotations[joint], origins[joint]) * local
        return placed

    def pair_distances(self, q: ArrayLike, pairs: NDArray[np.int64] | Sequence[int],
                       refine: float = 0.0, lower: bool = False) -> NDArray[np.float64]:
        """Distances (m) of the pairs ``pairs`` (indices into :attr:`pair_names`) at joint angles ``q`` (checked:
        ``InvalidInput`` naming ``q``):
        of the link meshes' convex hulls (a lower bound of the meshes' distance); where that is below ``refine``
        (m), of the meshes themselves (coal's BVH distance, never smaller: the hull contains the mesh). ≤ 0 only
        when coal's collision test finds the meshes in contact; the smallest positive float when they are not
        but their distance is not positive.

        ``lower``: where two links' hulls touch, a positive lower bound is answer enough (the certificate's
        conservative advancement): one link's mesh against the other's hull first (the hull of the one with fewer
        triangles, then the other way), the meshes only where both are not positive. Why (issue 34): the
        tails of the UR5's MotionBenchMaker plans went to coal's mesh-mesh distances of forearm_link/wrist_2_link
        and base_link_inertia/upper_arm_link, whose hulls always overlap: 132 and 259 µs per call where the
        first one-sided distance took 76 and 69 µs and was positive wherever the meshes' was (2325 calls of two
        bookshelf plans), and as tight (median 16.0 against 16.3 mm)."""
        records = [self._records[int(p)] for p in pairs]
        values = self.robot.check_joint_angles(q, "q")
        placed = self._placements(values, {g for a, b, obstacle in records for g in ((a,) if obstacle else (a, b))})
        request, result = self._request, self._result  # one result, cleared before each call (coal keeps minima)
        out = np.empty(len(records))
        for k, (a, b, obstacle) in enumerate(records):
            if obstacle:
                shape, pose, exact = self._obstacles[b][1], self._obstacles[b][2], self._obstacles[b][1]
            else:
                shape, pose, exact = self._shapes[b], placed[b], self._meshes[b]
            result.clear()
            d = coal.distance(self._shapes[a], placed[a], shape, pose, request, result)
            if lower and d <= 0.0 and not obstacle:
                one_sided = self._one_sided(a, b, placed)
                if one_sided > 0.0:
                    out[k] = one_sided
                    continue
            # where hulls touch, the meshes' own distance (a BVH traversal). For that value (not ``lower``), one
            # link's hull against the other's mesh first is 3-4 times cheaper where it clears the pair (the UR5's base
            # and upper arm) but a call more where it does not: on 140 UR5 and 136 Panda MBM plans, alternated in
            # one process, no faster
            if d < refine or d <= 0.0:
                result.clear()
                mesh = coal.distance(self._meshes[a], placed[a], exact, pose, request, result)
                if mesh <= 0.0:
                    contact = coal.CollisionResult()
                    coal.collide(self._meshes[a], placed[a], exact, pose, coal.CollisionRequest(), contact)
                    mesh = min(d, mesh) if contact.isCollision() else _HULLS_ONLY
                d = max(d, mesh) if d > 0.0 else mesh
            out[k] = d
        return out

    def _one_sided(self, a: int, b: int, placed: dict[int, coal.Transform3s]) -> float:
        """A positive lower bound of objects a and b's mesh distance: the first positive distance of one object's
        mesh against the other's convex hull (which contains the other's mesh), the hull of the object with fewer
        triangles first; else 0."""
        count_a, count_b = self._triangles[a], self._triangles[b]
        if count_a is None or count_b is None:
            return 0.0  # a primitive's hull is itself: the meshes' distance is as cheap
        request, result = self._request, self._result
        for hull, mesh in ((a, b), (b, a)) if count_a <= count_b else ((b, a), (a, b)):
            result.clear()
            d = coal.distance(self._shapes[hull], placed[hull], self._meshes[mesh], placed[mesh], request, result)
            if d > 0.0:
                return float(d)
        return 0.0

    def distances(self, q: ArrayLike) -> tuple[float, str, float, str]:
        """(robot–obstacle distance, its pair, self distance, its pair) in m at joint angles ``q``: of each class
        of pairs the smallest :meth:`pair_distances` value, the first pair in :attr:`pair_names` order on a tie
        (``inf`` and "" for a class without pairs).

        Branch and bound on the covering capsules' lower bounds (:meth:`covering_distances`, one compiled call):
        coal computes each class's pair of smallest bound, then every pair whose bound is within
        :data:`DISTANCE_TOLERANCE` of that class's best (or of 0 while the best is a contact, where a deeper pair
        could hide under its bound); no other pair can come below the best, so the answer is that of coal on every
        pair, from a few calls: on the xArm7 among 5 spheres, 2–7 of its 51 pairs at clear configurations."""
        return self._distances(self.robot.check_joint_angles(q))

    def check(self, q: ArrayLike, margin: float = 0.0) -> CollisionReport:
        """Whether the robot at ``q`` is closer than ``margin`` (m, ≥ 0) to an obstacle or to itself, with the
        smallest distances (:meth:`contact` when only the verdict is wanted)."""
        limit = nonnegative("margin", margin)
        return self._report(self._distances(self.robot.check_joint_angles(q)), limit)

    def contact(self, q: ArrayLike, margin: float = 0.0) -> CollisionReport | None:
        """:meth:`check`'s report when the robot at ``q`` is closer than ``margin`` (m, ≥ 0) to an obstacle or to
        itself, else None: decided by coal on the pairs whose covering-capsule bound comes within ``margin`` (all
        others are farther), so a clear configuration costs those calls alone: at MotionBenchMaker starts, 0.1 of
        the Panda's ~250 pairs on average (0.014 ms) where :meth:`check` needs 8 (0.088 ms), 1.1 of the UR5's."""
        limit = nonnegative("margin", margin)
        values = self.robot.check_joint_angles(q)
        if not self.pair_names:
            return None
        bounds = self._bounds(values)
        near = np.flatnonzero(~(bounds > limit))  # a NaN bound asks coal
        found = self.pair_distances(values, near)
        if not len(near) or found.min() > limit:
            return None
        return self._report(self._distances(values, bounds, dict(zip(near.tolist(), found.tolist(), strict=True))),
                            limit)

    def _bounds(self, values: NDArray[np.float64]) -> NDArray[np.float64]:
        """Each pair's covering-capsule bound at validated joint angles, less :data:`DISTANCE_TOLERANCE`: what a
        pair's coal distance is not below."""
        return self.covering_distances(values[None])[:, 0] - DISTANCE_TOLERANCE

    def _distances(self, values: NDArray[np.float64], bounds: NDArray[np.float64] | None = None,
                   known: dict[int, float] | None = None) -> tuple[float, str, float, str]:
        """:meth:`distances` at validated joint angles; ``bounds``: :meth:`_bounds` there, ``known``: coal's values
        of some pairs there (pair index → distance), when the caller has them."""
        classes = [c for c in self._classes if len(c)]
        if not classes:
            return math.inf, "", math.inf, ""
        bounds = self._bounds(values) if bounds is None else bounds
        known = {} if known is None else known
        leaders = [int(c[np.argmin(bounds[c])]) for c in classes]
        asked = [lead for lead in leaders if lead not in known]
        known.update(zip(asked, self.pair_distances(values, asked).tolist(), strict=True))
        # (written as "not above", so that a NaN bound or a NaN best asks coal rather than skips)
        rest = [int(p) for c, lead in zip(classes, leaders, strict=True)
                for p in c[~(bounds[c] > max(known[lead], 0.0))] if int(p) not in known]
        known.update(zip(rest, self.pair_distances(values, rest).tolist(), strict=True))

        def nearest(pairs: NDArray[np.int64]) -> tuple[float, str]:
            computed = [int(p) for p in pairs if int(p) in known]  # in index order
            if not computed:
                return math.inf, ""
            found = np.array([known[p] for p in computed])
            first = int(np.argmin(found))  # the first of equal minima (or the first NaN), as over every pair
            return float(found[first]), self.pair_names[computed[first]]

        return (*nearest(self._classes[0]), *nearest(self._classes[1]))

    @staticmethod
    def _report(distances: tuple[float, str, float, str], limit: float) -> CollisionReport:
        distance, pair, own, own_pair = distances
        if distance <= limit and distance <= own:
            return CollisionReport(True, distance, own, pair)
        if own <= limit:
            return CollisionReport(True, distance, own, own_pair)
        return CollisionReport(False, distance, own, "")


@dataclass(frozen=True, eq=False)
class _RobotTables:
    """What :class:`CollisionChecker` needs of a robot alone, computed once per robot (:func:`_robot_tables`)."""

    pairs: tuple[tuple[int, int], ...]  # the checked self pairs of collision objects
    object_joint: NDArray[np.int64]  # (G,) each object's joint (−1: the base)
    bounds: NDArray[np.float64]  # (G, n) r_gj of CollisionChecker.motion_weights (0 where j does not move g)
    supports: NDArray[np.bool_]  # (G, n) whether joint j moves object g
    cross: NDArray[np.float64]  # (G, n) g's distance from the axis of a joint j that does not move it (_axis_bounds)
    names: tuple[str, ...]  # (G,) each object's name
    pair_names: tuple[str, ...]  # "object/object" of each self pair
    meshes: list[coal.CollisionGeometry]  # (G,) each object's own geometry (its mesh, or a primitive shape)
    triangles: list[int | None]  # (G,) each mesh's triangle count, None for a primitive shape (_one_sided)
    local: list[tuple[int, coal.Transform3s]]  # (G,) (joint, the object's placement in its frame)
    hulls: list[NDArray[np.float64]]  # (G,) points whose hull holds the object, in its joint's frame (_local_points)


@functools.lru_cache(maxsize=8)
def _robot_tables(robot: RobotModel) -> _RobotTables:
    objects = robot.collision_model.geometryObjects
    shapes = _convex_hulls(robot)
    joints = np.array([int(obj.parentJoint) - 1 for obj in objects], dtype=np.int64)
    pairs = _self_pairs(robot)
    rotations = np.array([obj.placement.rotation for obj in objects]).reshape(-1, 3, 3)
    positions = np.array([obj.placement.translation for obj in objects]).reshape(-1, 3)
    names = tuple(str(obj.name) for obj in objects)
    meshes = [obj.geometry for obj in objects]
    hulls = [_local_points(shape, obj.placement) for shape, obj in zip(shapes, objects, strict=True)]
    bounds, supports, cross = motion_bounds(robot, joints, hulls)
    return _RobotTables(tuple(pairs), joints, bounds, supports, cross, names,
                        tuple(f"{names[a]}/{names[b]}" for a, b in pairs), meshes,
                        [int(m.num_tris) if isinstance(m, coal.BVHModelBase) else None for m in meshes],
                        [(int(j), coal.Transform3s(r, t))
                         for j, r, t in zip(joints, rotations, positions, strict=True)], hulls)


@functools.lru_cache(maxsize=8)
def _covering_capsules(robot: RobotModel) -> tuple[_robot_core.Robot, NDArray[np.float64]]:
    """One covering capsule per collision object, bound with the checked self pairs (for
    :meth:`CollisionChecker.covering_distances`), and the length (m) of each capsule's axis: the axis of the
    object's link's covering capsule (:attr:`RobotModel.geometry`, in the joint's frame), the radius reaching the
    object's hull (so the capsule contains the hull, and the hull the mesh)."""
    objects = robot.collision_model.geometryObjects
    tables = _robot_tables(robot)
    g, model = robot.geometry, robot.pinocchio_model
    links = {name: l for l, name in enumerate(g.link_names)}
    a, b, radii = np.zeros((len(objects), 3)), np.zeros((len(objects), 3)), np.zeros(len(objects))
    for k, (obj, points) in enumerate(zip(objects, tables.hulls, strict=True)):
        l = links.get(model.frames[obj.parentFrame].name)
        if l is not None and int(g.joints[l]) == tables.object_joint[k]:
            a[k], b[k] = g.a[l], g.b[l]
        # else no capsule on this body: a sphere about the object's joint origin (a = b = 0)
        radii[k] = float(segment_distances(points, a[k], b[k]).max())
    pairs = np.array(tables.pairs, dtype=np.int64).reshape(-1, 2)
    bound = _robot_core.Robot(*robot.kinematics, tables.object_joint, a, b, radii, pairs, robot.lower_limits,
                              robot.upper_limits, robot.velocity_limits, robot.acceleration_limits,
                              np.zeros(len(objects) + 1, dtype=np.int64), np.zeros(0, dtype=np.int64),
                              np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), radii)
    return bound, np.linalg.norm(b - a, axis=1)


def _covering_proxy(obstacle: Obstacle) -> Obstacle:
    """What the covering capsules measure against (:meth:`CollisionChecker.covering_distances`): the obstacle itself
    where the compiled segment distance is exact (spheres, capsules, boxes) or nearly (cylinders); for an ellipsoid
    the box of its semi-axes, for a mesh the box of its vertices in its frame. Each contains its obstacle, so a
    distance to it is a lower bound of the obstacle's."""
    shape = obstacle.shape
    if isinstance(shape, Ellipsoid):
        return Obstacle(obstacle.id, Box(2.0 * shape.semi_x, 2.0 * shape.semi_y, 2.0 * shape.semi_z), obstacle.pose)
    if isinstance(shape, Mesh):
        vertices = shape.data.vertices
        low, high = vertices.min(axis=0), vertices.max(axis=0)
        extent = np.maximum(high - low, 1e-9)  # a flat mesh gets a box as thin as Box accepts, still containing it
        centre = obstacle.pose.transform_points(0.5 * (low + high))
        return Obstacle(obstacle.id, Box(*extent.tolist()), Pose(centre.reshape(3), obstacle.pose.orientation))
    if not isinstance(shape, (Sphere, Capsule, Box, Cylinder)):
        raise TypeError(f"no covering proxy for obstacle shape {type(shape).__name__}")
    return obstacle


def _self_pairs(robot: RobotModel) -> list[tuple[int, int]]:
    """Collision-object pairs (i < j) on different links that are neither adjacent nor disabled by the SRDF."""
    objects = robot.collision_model.geometryObjects
    model = robot.pinocchio_model
    disabled = robot.disabled_pairs or frozenset()
    parents = robot.kinematics.parents
    pairs = []
    for i in range(len(objects)):
        for j in range(i + 1, len(objects)):
            a, b = objects[i], objects[j]
            ja, jb = int(a.parentJoint) - 1, int(b.parentJoint) - 1
            links = frozenset((model.frames[a.parentFrame].name, model.frames[b.parentFrame].name))
            if len(links) == 1 or links in disabled or adjacent_joints(parents, ja, jb):
                continue
            pairs.append((i, j))
    return pairs


def motion_bounds(robot: RobotModel, joints: NDArray[np.int64], hulls: Sequence[NDArray[np.float64]]
                  ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """How far a joint motion can move each of G point sets (collision objects, or a link's fitted primitives):
    ``hulls[g]`` holds points whose convex hull contains set g, in the frame of its joint ``joints[g]`` (−1: the
    base). Returns (G, n) each: ``bounds`` r_gj, the largest distance (m) of g from joint j's axis at every
    configuration (1 for a prismatic j, 0 where j does not move g: :func:`_object_bounds` walked up the chain, or
    :func:`_axis_bounds` where smaller); ``supports``, whether j moves g; ``cross``, g's distance from the axis of a
    joint that does not move it where a line or point fixed in g's frame bounds it (inf elsewhere). A motion Δq
    moves every point of g by at most Σ_j r_gj |Δq_j| (:attr:`CollisionChecker.motion_weights`)."""
    carried = robot.kinematics.support  # carried[k, j]: joint j moves the body of joint k
    supports = np.array([np.zeros(robot.n_joints, dtype=bool) if joint < 0 else carried[joint].astype(bool)
                         for joint in joints.tolist()]).reshape(len(hulls), robot.n_joints)
    walked, axis = _object_bounds(robot, joints, hulls), _axis_bounds(robot, joints, hulls)
    return np.where(supports, np.minimum(walked, axis), 0.0), supports, np.where(supports, np.inf, axis)


def self_pair_weights(bounds: NDArray[np.float64], supports: NDArray[np.bool_], cross: NDArray[np.float64],
                      a: NDArray[np.int64], b: NDArray[np.int64]) -> NDArray[np.float64]:
    """(P, n) weights w_pj (m/rad or m/m) of the pairs of point sets (a[p], b[p]) of :func:`motion_bounds`: a joint
    motion Δq changes the distance of pair p by at most Σ_j w_pj |Δq_j|. The joints that move both sets move them
    rigidly together and count 0; a joint that moves one set alone counts the smaller of that set's r and the other
    set's distance from its axis (:attr:`CollisionChecker.motion_weights` says why either bounds the rate)."""
    only_a, only_b = supports[a] & ~supports[b], supports[b] & ~supports[a]
    return (np.where(only_a, np.minimum(bounds[a], cross[b]), 0.0)
            + np.where(only_b, np.minimum(bounds[b], cross[a]), 0.0))


def _object_bounds(robot: RobotModel, joints: NDArray[np.int64], hulls: Sequence[NDArray[np.float64]]
                   ) -> NDArray[np.float64]:
    """(G, n) the walked part of r_gj (:attr:`CollisionChecker.motion_weights`, which takes the smaller of it and
    :func:`_axis_bounds`'): m; 1 for prismatic j; inf where a prismatic joint between is unbounded; 0 where j does
    not carry g. ``joints``: each object's joint; ``hulls``: points whose hull contains it, in that joint's frame
    (the largest distance from the joint's origin is at one of them: a convex function's maximum over a hull)."""
    k = robot.kinematics
    offset = np.linalg.norm(k.place_pos, axis=1)
    travel = np.where(k.kinds == 1, np.maximum(np.abs(robot.lower_limits), np.abs(robot.upper_limits)), 0.0)
    bounds = np.zeros((len(hulls), robot.n_joints))
    for g, (joint, points) in enumerate(zip(joints.tolist(), hulls, strict=True)):
        if joint < 0:
            continue
        # distance bound from joint i's origin, walking up
        length, i = float(np.linalg.norm(points, axis=1).max()), joint
        while i >= 0:
            bounds[g, i] = 1.0 if k.kinds[i] == 1 else length
            length += offset[i] + travel[i]
            i = int(k.parents[i])
    return bounds


def _axis_bounds(robot: RobotModel, joints: NDArray[np.int64], hulls: Sequence[NDArray[np.float64]]
                 ) -> NDArray[np.float64]:
    """(G, n) for object g and a revolute joint j, the largest distance (m) of g's convex hull from j's axis at every
    configuration where a line or a point fixed in g's frame bounds it (inf elsewhere), over ``hulls`` (each object's
    points, in the frame of its joint ``joints``):

    * the axis is fixed in g's frame (j is g's joint, or a child joint of it): the distance from that line;
    * j's axis meets the axis of a joint between it and g's frame (j is the parent of g's joint, or the child of a
      child of it), at a point of that joint's axis, which the joint's turning leaves in place: the distance from
      that point (the UR5's shoulder pan and lift, wrist 1 and wrist 2)."""
    k = robot.kinematics
    directions = np.einsum("nij,nj->ni", k.place_rot, k.axes)  # each joint's axis in its parent joint's frame
    bounds = np.full((len(hulls), robot.n_joints), np.inf)
    revolute = k.kinds == 0

    def from_line(points: NDArray[np.float64], origin: NDArray[np.float64], direction: NDArray[np.float64]) -> float:
        offsets = points - origin
        along = offsets @ direction
        return float(np.sqrt(np.maximum(np.einsum("ij,ij->i", offsets, offsets) - along * along, 0.0)).max())

    def from_point(points: NDArray[np.float64], where: NDArray[np.float64]) -> float:
        return float(np.linalg.norm(points - where, axis=1).max())

    for g, (own, points) in enumerate(zip(joints.tolist(), hulls, strict=True)):
        for j in np.flatnonzero(revolute).tolist():
            parent = int(k.parents[j])
            if j == own:
                bounds[g, j] = from_line(points, np.zeros(3), k.axes[j])
            elif parent == own:
                bounds[g, j] = from_line(points, k.place_pos[j], directions[j])
            elif own >= 0 and j == int(k.parents[own]) and revolute[own]:
                meet = _axes_meet(k.axes[j], k.place_pos[own], directions[own])  # in j's frame, on g's joint axis
                if meet is not None:  # in g's joint frame
                    bounds[g, j] = from_point(points, k.place_rot[own].T @ (meet - k.place_pos[own]))
            elif parent >= 0 and int(k.parents[parent]) == own and revolute[parent]:
                meet = _axes_meet(k.axes[parent], k.place_pos[j], directions[j])  # in the parent's frame, on its axis
                if meet is not None:  # in g's joint frame
                    bounds[g, j] = from_point(points, k.place_rot[parent] @ meet + k.place_pos[parent])
    return bounds


def _axes_meet(axis: NDArray[np.float64], origin: NDArray[np.float64], direction: NDArray[np.float64]
               ) -> NDArray[np.float64] | None:
    """The point where the line through 0 along unit ``axis`` meets the line through ``origin`` along unit
    ``direction``, or None when they are parallel or pass more than 1e-9 m apart."""
    normal = np.cross(axis, direction)
    size = float(np.linalg.norm(normal))
    if size < 1e-9 or abs(float(origin @ normal)) / size > 1e-9:
        return None
    # origin + s direction = t axis: solve by least squares (exact where they meet)
    (t, _), *_ = np.linalg.lstsq(np.column_stack([axis, -direction]), origin, rcond=None)
    return np.asarray(t * axis, dtype=np.float64)


def _local_points(shape: coal.CollisionGeometry, placement: pin.SE3) -> NDArray[np.float64]:
    """Points (K, 3) whose convex hull contains ``shape``, in its joint's frame (``placement``): the convex hull's
    vertices, else the corners of the shape's local bounding box."""
    if isinstance(shape, coal.ConvexBase):
        points = np.asarray(shape.points(), dtype=np.float64).reshape(-1, 3)
    else:
        shape.computeLocalAABB()
        low, high = np.asarray(shape.aabb_local.min_), np.asarray(shape.aabb_local.max_)
        points = np.array([[(low, high)[(c >> i) & 1][i] for i in range(3)] for c in range(8)])
    return points @ np.asarray(placement.rotation).T + np.asarray(placement.translation)  # type: ignore[no-any-return]

