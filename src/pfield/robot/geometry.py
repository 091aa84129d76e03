"""Link geometry: one capsule per link covering its URDF collision geometry, and self-collision pairs.

A capsule is a segment ``a–b`` (in the frame of the joint that carries the link) swept by a sphere of
radius ``r``: it covers a point x when ``dist(x, [a, b]) ≤ r``. Fitting (per link, all of its collision
elements together, meshes through their convex hull, primitives through surface samples):

1. axis ``u`` — each principal axis of the points is tried and the smallest-volume capsule is kept;
2. radius — the smallest circle enclosing the points projected on the plane ⟂ u (Bădoiu–Clarkson
   iterations, "Optimal core-sets for balls", 2008), so ``r = max ρ_i``;
3. ends — the shortest segment that still covers every point: with ``t_i`` the axial coordinate and
   ``h_i = √(r² − ρ_i²)``, ``t_b = max(t_i − h_i)`` and ``t_a = min(t_i + h_i)``.

The fit error is reported per link: ``volume_ratio`` (capsule volume / convex-hull volume, ≥ 1) and
``mean_gap`` (mean distance from the hull's vertices to the capsule surface, m). Coverage is exact by
construction for meshes and boxes; curved primitives are sampled densely and inflated by the chord error.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from pfield.robot._distance import segment_segment_distance

if TYPE_CHECKING:
    import pinocchio as pin

    from pfield.robot.model import RobotModel

__all__ = ["LinkCapsule", "RobotGeometry", "fit_capsule", "fit_robot_geometry"]

_LOG = logging.getLogger(__name__)
_CIRCLE_SAMPLES = 48


@dataclass(frozen=True, eq=False)
class LinkCapsule:
    """A capsule covering one link: segment ``a``–``b`` and ``radius`` in the frame of joint ``joint``.

    ``joint`` is the index into ``RobotModel.joint_names`` of the joint moving the link (−1: fixed base).
    """

    link: str
    joint: int
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    radius: float
    volume_ratio: float
    mean_gap: float


@dataclass(frozen=True, eq=False)
class RobotGeometry:
    """All link capsules plus the capsule index pairs checked for self-collision, packed for kernels."""

    capsules: tuple[LinkCapsule, ...]
    self_pairs: NDArray[np.int64]  # (P, 2) indices into capsules
    joints: NDArray[np.int64]  # (L,)
    a: NDArray[np.float64]  # (L, 3)
    b: NDArray[np.float64]  # (L, 3)
    radii: NDArray[np.float64]  # (L,)

    @property
    def link_names(self) -> tuple[str, ...]:
        return tuple(c.link for c in self.capsules)


def _enclosing_circle(points: NDArray[np.float64], iterations: int = 400) -> NDArray[np.float64]:
    """Approximate centre of the smallest circle (any dimension) enclosing ``points`` (Bădoiu–Clarkson)."""
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    for k in range(1, iterations + 1):
        far = points[np.argmax(np.linalg.norm(points - centre, axis=1))]
        centre = centre + (far - centre) / (k + 1)
    return centre


def _capsule_along(points: NDArray[np.float64], axis: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    basis = np.linalg.svd(np.eye(3) - np.outer(axis, axis))[0][:, :2]
    planar = points @ basis
    centre2 = _enclosing_circle(planar)
    rho = np.linalg.norm(planar - centre2, axis=1)
    radius = float(rho.max()) + 1e-9
    t = points @ axis
    h = np.sqrt(np.maximum(radius**2 - rho**2, 0.0))
    t_b, t_a = float(np.max(t - h)), float(np.min(t + h))
    offset = basis @ centre2
    if t_a > t_b:  # every point fits in one sphere
        t_mid = 0.5 * (t_a + t_b)
        centre = offset + t_mid * axis
        radius = float(np.linalg.norm(points - centre, axis=1).max()) + 1e-9
        return centre, centre.copy(), radius
    return offset + t_a * axis, offset + t_b * axis, radius


def _point_segment_distances(points: NDArray[np.float64], a: NDArray[np.float64],
                             b: NDArray[np.float64]) -> NDArray[np.float64]:
    d = b - a
    length2 = float(d @ d)
    t = np.zeros(len(points)) if length2 == 0.0 else np.clip((points - a) @ d / length2, 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * d), axis=1)


def fit_capsule(points: NDArray[np.float64], link: str = "", joint: int = -1) -> LinkCapsule:
    """Smallest-volume capsule (over the principal axes) covering ``points`` (N, 3); see module doc."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    try:
        hull = ConvexHull(pts)
        vertices, hull_volume = pts[hull.vertices], float(hull.volume)
    except (QhullError, ValueError):
        vertices, hull_volume = pts, 0.0
    axes = np.linalg.svd(vertices - vertices.mean(axis=0), full_matrices=False)[2]
    best = None
    for axis in axes:
        a, b, r = _capsule_along(vertices, axis / np.linalg.norm(axis))
        volume = math.pi * r * r * (float(np.linalg.norm(b - a)) + 4.0 * r / 3.0)
        if best is None or volume < best[3]:
            best = (a, b, r, volume)
    assert best is not None
    a, b, r, volume = best
    gaps = r - _point_segment_distances(vertices, a, b)
    ratio = volume / hull_volume if hull_volume > 0 else math.inf
    return LinkCapsule(link, joint, a, b, r, ratio, float(gaps.mean()))


def _primitive_points(shape: object) -> NDArray[np.float64]:
    """Surface samples (shape frame) of a coal primitive, inflated so the hull covers the shape."""
    kind = type(shape).__name__
    angles = np.linspace(0.0, 2 * np.pi, _CIRCLE_SAMPLES, endpoint=False)
    chord = 1.0 / math.cos(math.pi / _CIRCLE_SAMPLES)  # polygon circumscribing the circle
    circle = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1) * chord
    if kind == "Box":
        half = np.asarray(shape.halfSide)  # type: ignore[attr-defined]
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    if kind == "Cylinder":
        r, h = float(shape.radius), float(shape.halfLength)  # type: ignore[attr-defined]
        return np.concatenate([circle * r + (0, 0, h), circle * r - (0, 0, h)])
    if kind in ("Sphere", "Capsule"):
        r = float(shape.radius)  # type: ignore[attr-defined]
        h = float(getattr(shape, "halfLength", 0.0))
        ring_chord = 1.0 / math.cos(math.pi / 24)  # 13 latitude rings 15° apart
        rings = [circle * r * math.cos(lat) * ring_chord + (0, 0, r * math.sin(lat) * ring_chord)
                 for lat in np.linspace(-np.pi / 2, np.pi / 2, 13)]
        ball = np.concatenate(rings)
        shift = np.array([0.0, 0.0, h])
        return np.concatenate([ball + shift, ball - shift])
    raise NotImplementedError(f"collision shape {kind} is not supported for capsule fitting")


def _geometry_points(obj: pin.GeometryObject) -> NDArray[np.float64]:
    """Points (frame of the parent joint) whose convex hull covers one collision element."""
    shape = obj.geometry
    if hasattr(shape, "vertices"):
        local = np.asarray(shape.vertices(), dtype=np.float64).reshape(-1, 3)
    else:
        local = _primitive_points(shape)
    placement = obj.placement
    return local @ np.asarray(placement.rotation).T + np.asarray(placement.translation)


def _link_groups(robot: RobotModel) -> dict[str, tuple[int, list[NDArray[np.float64]]]]:
    model = robot.pinocchio_model
    groups: dict[str, tuple[int, list[NDArray[np.float64]]]] = {}
    for obj in robot.collision_model.geometryObjects:
        link = model.frames[obj.parentFrame].name
        joint = int(obj.parentJoint) - 1
        groups.setdefault(link, (joint, []))[1].append(_geometry_points(obj))
    return groups


def adjacent_joints(parents: NDArray[np.int64], ja: int, jb: int) -> bool:
    """Whether links carried by joints ``ja`` and ``jb`` (−1: the base) are on one body or neighbours."""
    return ja == jb or (jb >= 0 and parents[jb] == ja) or (ja >= 0 and parents[ja] == jb)


def _self_pairs(robot: RobotModel, capsules: list[LinkCapsule]) -> NDArray[np.int64]:
    """Capsule pairs checked for self-collision: the SRDF's enabled pairs, else all non-adjacent pairs.

    Pairs on one rigid body are always skipped; so are pairs whose capsules already touch in the mid-range
    configuration (the capsules over-approximate, and such links are close by design).
    """
    reference = np.where(np.isfinite(robot.lower_limits + robot.upper_limits),
                         0.5 * (robot.lower_limits + robot.upper_limits), 0.0)
    rotations, origins = robot.joint_frames(reference)
    world = [world_segment(c, rotations, origins) for c in capsules]
    pairs = []
    for i in range(len(capsules)):
        for j in range(i + 1, len(capsules)):
            ci, cj = capsules[i], capsules[j]
            if ci.joint == cj.joint:
                continue
            if robot.disabled_pairs is not None:
                if frozenset((ci.link, cj.link)) in robot.disabled_pairs:
                    continue
            elif adjacent_joints(robot.kinematics.parents, ci.joint, cj.joint):
                continue
            gap = segment_segment_distance(*world[i], *world[j]) - ci.radius - cj.radius
            if gap <= 0.0:
                _LOG.info("self-collision pair %s/%s skipped: capsules overlap at mid-range", ci.link, cj.link)
                continue
            pairs.append((i, j))
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


def world_segment(capsule: LinkCapsule, rotations: NDArray[np.float64],
                  origins: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World ends (a, b) of ``capsule``'s segment, given the joint frames of :meth:`RobotModel.joint_frames`."""
    if capsule.joint < 0:
        return capsule.a, capsule.b
    r, o = rotations[capsule.joint], origins[capsule.joint]
    return r @ capsule.a + o, r @ capsule.b + o


def fit_robot_geometry(robot: RobotModel) -> RobotGeometry:
    """Fit one capsule per link of ``robot`` and choose the self-collision pairs."""
    capsules = []
    for link, (joint, parts) in _link_groups(robot).items():
        capsule = fit_capsule(np.concatenate(parts), link, joint)
        _LOG.debug("capsule %s: r=%.4f len=%.4f volume ratio %.2f mean gap %.4f m", link, capsule.radius,
                   np.linalg.norm(capsule.b - capsule.a), capsule.volume_ratio, capsule.mean_gap)
        capsules.append(capsule)
    pairs = _self_pairs(robot, capsules)
    return RobotGeometry(
        tuple(capsules), pairs,
        np.array([c.joint for c in capsules], dtype=np.int64),
        np.array([c.a for c in capsules], dtype=np.float64).reshape(-1, 3),
        np.array([c.b for c in capsules], dtype=np.float64).reshape(-1, 3),
        np.array([c.radius for c in capsules], dtype=np.float64),
    )
