"""Collision checks of a robot configuration: fast (link capsules, compiled) and exact (coal on the meshes).

* :func:`capsule_clearances` — signed clearance (m) of every link's fitted model to every obstacle and of
  every self-collision link pair, from the compiled kernels the planner uses (conservative: the fitted
  spheres/capsules cover the links' collision surfaces).
* :class:`CollisionChecker` — the robot's own URDF collision geometry (pinocchio ``GeometryModel``; link
  meshes through their convex hulls, which contain them, so "no collision" stays true) against
  the obstacles' exact shapes with coal (Pan et al., "FCL", ICRA 2012, coal is its successor); self
  collisions over the SRDF's enabled pairs (or all non-adjacent links). ``check(q, margin)`` reports
  whether any distance is below ``margin`` (m) and which pair.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from pfield._core import robot as _robot_core
from pfield._core import robot_distance as _distance
from pfield._validation import nonnegative
from pfield.geometry import Box, Capsule, Cylinder, Ellipsoid, Mesh, Obstacle, Sphere, empty_packed, pack_obstacles
from pfield.robot.geometry import adjacent_joints
from pfield.robot.model import RobotModel

__all__ = ["CapsuleClearances", "CollisionChecker", "CollisionReport", "capsule_clearances"]


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


def _coal_geometry(obstacle: Obstacle) -> coal.CollisionGeometry:
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
    assert isinstance(shape, Mesh)
    model = coal.BVHModelOBBRSS()
    model.beginModel(len(shape.data.faces), len(shape.data.vertices))
    model.addVertices(np.asarray(shape.data.vertices, dtype=np.float64))
    model.addTriangles(np.asarray(shape.data.faces, dtype=np.int64))
    model.endModel()
    return model


def _convex_hull(shape: coal.CollisionGeometry) -> coal.CollisionGeometry:
    """The convex hull of a link mesh (GJK on it is fast; it contains the mesh, so the check stays safe)."""
    if isinstance(shape, coal.BVHModelBase):
        shape.buildConvexRepresentation(False)
        return shape.convex
    return shape


@functools.lru_cache(maxsize=8)
def _convex_hulls(robot: RobotModel) -> list[coal.CollisionGeometry]:
    return [_convex_hull(obj.geometry.clone()) for obj in robot.collision_model.geometryObjects]


def _transform(obstacle: Obstacle) -> coal.Transform3s:
    return coal.Transform3s(np.asarray(obstacle.pose.rotation), np.asarray(obstacle.pose.position))


class CollisionChecker:
    """Exact distances between the robot's URDF collision geometry and obstacles (coal), and self-distances."""

    def __init__(self, robot: RobotModel, obstacles: Sequence[Obstacle] = ()) -> None:
        self.robot = robot
        self._geometry = robot.collision_model.copy()
        self._model = robot.pinocchio_model
        self._data = self._model.createData()
        self._geometry_data = pin.GeometryData(self._geometry)
        self._obstacles = [(o.id, _coal_geometry(o), _transform(o)) for o in obstacles]
        self._shapes = _convex_hulls(robot)
        self._pairs = self._self_pairs()

    def _self_pairs(self) -> list[tuple[int, int]]:
        objects = self._geometry.geometryObjects
        disabled = self.robot.disabled_pairs
        parents = self.robot.kinematics.parents
        pairs = []
        for i in range(len(objects)):
            for j in range(i + 1, len(objects)):
                a, b = objects[i], objects[j]
                ja, jb = int(a.parentJoint) - 1, int(b.parentJoint) - 1
                links = frozenset((self._model.frames[a.parentFrame].name, self._model.frames[b.parentFrame].name))
                if ja == jb or len(links) == 1:
                    continue
                if disabled is not None:
                    if links in disabled:
                        continue
                elif adjacent_joints(parents, ja, jb):
                    continue
                pairs.append((i, j))
        return pairs

    def _place(self, q: NDArray[np.float64]) -> list[coal.Transform3s]:
        pin.updateGeometryPlacements(self._model, self._data, self._geometry, self._geometry_data,
                                     self.robot.pinocchio_configuration(q))
        return [coal.Transform3s(placement.rotation, placement.translation)
                for placement in self._geometry_data.oMg]

    def distances(self, q: ArrayLike) -> tuple[float, str, float, str]:
        """(robot–obstacle distance, its pair, self distance, its pair) in m at joint angles ``q``."""
        values = self.robot.check_joint_angles(q)
        placements = self._place(values)
        objects = self._geometry.geometryObjects
        request, best, best_pair = coal.DistanceRequest(), np.inf, ""
        for g, obj in enumerate(objects):
            for name, shape, pose in self._obstacles:
                result = coal.DistanceResult()
                d = coal.distance(self._shapes[g], placements[g], shape, pose, request, result)
                if d < best:
                    best, best_pair = d, f"{obj.name}/{name}"
        own, own_pair = np.inf, ""
        for i, j in self._pairs:
            result = coal.DistanceResult()
            d = coal.distance(self._shapes[i], placements[i], self._shapes[j], placements[j], request, result)
            if d < own:
                own, own_pair = d, f"{objects[i].name}/{objects[j].name}"
        return float(best), best_pair, float(own), own_pair

    def check(self, q: ArrayLike, margin: float = 0.0) -> CollisionReport:
        """Whether the robot at ``q`` is closer than ``margin`` (m, ≥ 0) to an obstacle or to itself."""
        limit = nonnegative("margin", margin)
        distance, pair, own, own_pair = self.distances(q)
        if distance <= limit and distance <= own:
            return CollisionReport(True, distance, own, pair)
        if own <= limit:
            return CollisionReport(True, distance, own, own_pair)
        return CollisionReport(False, distance, own, "")
