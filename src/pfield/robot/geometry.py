"""Link geometry: spheres and capsules fitted to each link's URDF collision surface, and self-collision pairs.

A capsule is a segment ``a–b`` (in the frame of the joint that carries the link) swept by a sphere of
radius ``r``: it covers a point x when ``dist(x, [a, b]) ≤ r``; a sphere is a capsule with ``a == b``.
Each link gets as many primitives as its shape needs (:mod:`pfield.robot._fit`: the link's triangles are
split into groups, each covered by one capsule, the count chosen by the mean gap to the real surface), so
the union covers every triangle of the collision geometry (meshes as loaded by pinocchio/coal, boxes by
their faces, other primitives by inflated surface samples). One capsule covering a point set
(:func:`fit_capsule`):

1. axis ``u`` — each principal axis of the points is tried and the smallest-volume capsule is kept;
2. radius — the smallest circle enclosing the points projected on the plane ⟂ u (Bădoiu–Clarkson
   iterations, "Optimal core-sets for balls", 2008), so ``r = max ρ_i``;
3. ends — the shortest segment that still covers every point: with ``t_i`` the axial coordinate and
   ``h_i = √(r² − ρ_i²)``, ``t_b = max(t_i − h_i)`` and ``t_a = min(t_i + h_i)``.

The fit is reported per link (:class:`LinkFitReport`, :func:`fit_table`): counts, mean and max gap
(fitted surface → collision surface) and the volume ratio.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from pfield._core.robot_distance import segment_segment_distance
from pfield.errors import InvalidInput
from pfield.robot._fit import TARGET_GAP, LinkFit, LinkSurface, cached_fit, fit_single_capsule, measure

if TYPE_CHECKING:
    import pinocchio as pin

    from pfield.robot.model import RobotModel

__all__ = ["LinkCapsule", "LinkFitReport", "RobotGeometry", "fit_capsule", "fit_robot_geometry", "fit_table"]

_LOG = logging.getLogger(__name__)
_CIRCLE_SAMPLES = 48


@dataclass(frozen=True, eq=False)
class LinkCapsule:
    """One covering primitive of a link: segment ``a``–``b`` and ``radius`` in the frame of joint ``joint``.

    ``joint`` is the index into ``RobotModel.joint_names`` of the joint moving the link (−1: fixed base);
    ``a == b`` makes it a sphere. ``volume_ratio`` and ``mean_gap`` describe this primitive alone against the
    points it was fitted to (:func:`fit_capsule`); the link's fit is in :attr:`RobotGeometry.fits`.
    """

    link: str
    joint: int
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    radius: float
    volume_ratio: float = math.nan
    mean_gap: float = math.nan

    @property
    def is_sphere(self) -> bool:
        return bool(np.all(self.a == self.b))


@dataclass(frozen=True)
class LinkFitReport:
    """How one link is modelled: ``spheres`` + ``capsules`` primitives, the mean and max gap (m) from the
    fitted surface to the collision surface, and the union volume / collision volume (see :mod:`._fit`)."""

    link: str
    joint: int
    spheres: int
    capsules: int
    mean_gap: float
    max_gap: float
    volume_ratio: float


@dataclass(frozen=True, eq=False)
class RobotGeometry:
    """The link model, packed for the kernels, at two levels.

    * ``capsules`` — one bounding capsule per link (index l), in the joint frame: ``joints``, ``a``, ``b``,
      ``radii`` (L,); it contains the link's collision geometry and all of its fitted primitives;
    * ``primitives`` — the fitted spheres/capsules (index p), grouped by link: those of link l are
      ``link_start[l]:link_start[l + 1]``, with ends ``prim_a``, ``prim_b`` and radii ``prim_r`` in the frame
      of joint ``prim_joint[p]`` (= ``joints[l]``);
    * ``self_pairs`` — the link index pairs (P, 2) checked for self-collision, on the covering capsules (the
      bounding capsules before growing: radii ``self_radii``); ``fits`` — the per-link fit report.
    """

    capsules: tuple[LinkCapsule, ...]
    self_pairs: NDArray[np.int64]  # (P, 2) indices into capsules (links)
    joints: NDArray[np.int64]  # (L,)
    a: NDArray[np.float64]  # (L, 3)
    b: NDArray[np.float64]  # (L, 3)
    radii: NDArray[np.float64]  # (L,)
    primitives: tuple[LinkCapsule, ...] = ()
    link_start: NDArray[np.int64] = field(default_factory=lambda: np.zeros(1, dtype=np.int64))  # (L + 1,)
    prim_joint: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # (Np,)
    prim_a: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))  # (Np, 3)
    prim_b: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))  # (Np, 3)
    prim_r: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))  # (Np,)
    fits: tuple[LinkFitReport, ...] = ()
    self_radii: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))  # (L,) ungrown covering capsules

    @property
    def link_names(self) -> tuple[str, ...]:
        """The link of every bounding capsule (one per link, in ``capsules`` order)."""
        return tuple(c.link for c in self.capsules)


def fit_capsule(points: NDArray[np.float64], link: str = "", joint: int = -1) -> LinkCapsule:
    """Smallest-volume capsule (over the principal axes) covering ``points`` (N, 3); see the module doc."""
    a, b, r, ratio, gap = fit_single_capsule(points)
    return LinkCapsule(link, joint, a, b, r, ratio, gap)


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


def _corners(triangle: object) -> tuple[int, int, int]:
    return triangle[0], triangle[1], triangle[2]  # type: ignore[index]


def _element_surface(obj: pin.GeometryObject) -> tuple[NDArray[np.float64], NDArray[np.int64], float]:
    """Vertices (element frame), triangles and volume of one collision element."""
    shape = obj.geometry
    if hasattr(shape, "vertices"):
        vertices = np.asarray(shape.vertices(), dtype=np.float64).reshape(-1, 3)
        triangles = np.array([_corners(shape.tri_indices(i)) for i in range(shape.num_tris)],  # one call each
                             dtype=np.int64).reshape(-1, 3)
        corners = vertices[triangles]
        volume = abs(float(np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])).sum())) / 6
        return vertices, triangles, volume
    from scipy.spatial import ConvexHull  # primitives' surfaces only: importing it costs ≈ 0.3 s at start-up

    points = _primitive_points(shape)
    hull = ConvexHull(points)
    return points, np.asarray(hull.simplices, dtype=np.int64), float(hull.volume)


def _unfittable(link: str, source: str, cause: Exception) -> InvalidInput:
    """The error of a link whose collision geometry cannot be fitted, naming the link and its geometry (the
    cause alone names an array or a qhull option)."""
    why = f"{cause.field}: {cause.reason}" if isinstance(cause, InvalidInput) else \
        " ".join(str(cause).split()).split(". ")[0][:160] or type(cause).__name__
    return InvalidInput(f"link {link}", source, f"its collision geometry cannot be fitted ({why}); check the link's "
                                               "<collision> shapes and meshes (a shape of no volume, a mesh of no "
                                               "triangles)")


def _link_surfaces(robot: RobotModel) -> dict[str, tuple[int, pin.SE3, LinkSurface]]:
    """Per link: (joint index, the link frame in its joint frame, the collision surface in the link frame)."""
    model = robot.pinocchio_model
    parts: dict[str, tuple[int, pin.SE3, list[tuple[NDArray[np.float64], NDArray[np.int64], float, str]]]] = {}
    for obj in robot.collision_model.geometryObjects:
        frame = model.frames[obj.parentFrame]
        entry = parts.setdefault(frame.name, (int(obj.parentJoint) - 1, frame.placement, []))
        source = str(obj.meshPath) if hasattr(obj.geometry, "vertices") else type(obj.geometry).__name__.lower()
        try:
            vertices, triangles, volume = _element_surface(obj)
        except (InvalidInput, ValueError, RuntimeError) as exc:  # qhull on a shape without volume: named by its link
            raise _unfittable(frame.name, source, exc) from exc
        in_link = entry[1].inverse() * obj.placement
        entry[2].append((vertices @ np.asarray(in_link.rotation).T + np.asarray(in_link.translation), triangles,
                         volume, source))
    surfaces = {}
    for link, (joint, placement, elements) in parts.items():
        offsets = np.cumsum([0] + [len(e[0]) for e in elements])
        surfaces[link] = (joint, placement, LinkSurface(
            np.concatenate([e[0] for e in elements]),
            np.concatenate([e[1] + offsets[i] for i, e in enumerate(elements)]),
            float(sum(e[2] for e in elements)), link, tuple(dict.fromkeys(e[3] for e in elements))))
    return surfaces


def adjacent_joints(parents: NDArray[np.int64], ja: int, jb: int) -> bool:
    """Whether links carried by joints ``ja`` and ``jb`` (−1: the base) are on one body or neighbours."""
    return ja == jb or (jb >= 0 and parents[jb] == ja) or (ja >= 0 and parents[ja] == jb)


def _self_pairs(robot: RobotModel, capsules: list[LinkCapsule], covering: list[float]) -> NDArray[np.int64]:
    """Link pairs checked for self-collision: the SRDF's enabled pairs, else all non-adjacent pairs.

    Pairs on one rigid body are always skipped; so are pairs whose covering capsules (radii ``covering``)
    already touch in the mid-range configuration (they over-approximate, and such links are close by design).
    """
    rotations, origins = robot.joint_frames(robot.mid_configuration)
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
            gap = segment_segment_distance(*world[i], *world[j]) - covering[i] - covering[j]
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


def fit_robot_geometry(robot: RobotModel, target_gap: float = TARGET_GAP, *,
                       one_capsule: bool = False) -> RobotGeometry:
    """Fit each link of ``robot`` (bounding capsule and spheres/capsules, see :mod:`pfield.robot._fit`) and
    choose the self-collision pairs. The fitted primitives are cached per collision surface.

    ``one_capsule=True`` models each link by its single covering capsule alone (no spheres/capsules fit,
    ``fits`` reports that capsule): the coarse model, for comparisons."""
    capsules, primitives, reports, starts, covering = [], [], [], [0], []
    surfaces = _link_surfaces(robot)
    for index, (link, (joint, placement, surface)) in enumerate(surfaces.items(), 1):
        rotation, translation = np.asarray(placement.rotation), np.asarray(placement.translation)
        try:
            fit = cached_fit(surface, target_gap, progress=f"{index}/{len(surfaces)}")
        except (InvalidInput, ValueError, RuntimeError) as exc:
            raise _unfittable(link, ", ".join(surface.sources) or link, exc) from exc
        if one_capsule:
            fit = LinkFit(fit.bound, *measure(surface, fit.bound), fit.bound, fit.bound_volume_ratio,
                          fit.bound_mean_gap)
        prims = fit.primitives.transformed(rotation, translation)
        bound = fit.bound.transformed(rotation, translation)
        # the covering capsule contains the surface and every primitive lies within target_gap of it: grown by
        # target_gap it bounds the primitives (the one-capsule model is its own bound)
        margin = 0.0 if one_capsule else target_gap + 1e-9
        covering.append(float(bound.radii[0]))
        capsules.append(LinkCapsule(link, joint, bound.a[0], bound.b[0], float(bound.radii[0]) + margin,
                                    fit.bound_volume_ratio, fit.bound_mean_gap))
        for j in range(len(prims)):
            primitives.append(LinkCapsule(link, joint, prims.a[j], prims.b[j], float(prims.radii[j])))
        starts.append(len(primitives))
        reports.append(LinkFitReport(link, joint, fit.primitives.spheres, len(prims) - fit.primitives.spheres,
                                     fit.mean_gap, fit.max_gap, fit.volume_ratio))
        _LOG.debug("link %s: %d primitives, mean gap %.4f m, max gap %.4f m, volume ratio %.2f", link, len(prims),
                   fit.mean_gap, fit.max_gap, fit.volume_ratio)
    pairs = _self_pairs(robot, capsules, covering)
    return RobotGeometry(
        tuple(capsules), pairs,
        np.array([c.joint for c in capsules], dtype=np.int64),
        np.array([c.a for c in capsules], dtype=np.float64).reshape(-1, 3),
        np.array([c.b for c in capsules], dtype=np.float64).reshape(-1, 3),
        np.array([c.radius for c in capsules], dtype=np.float64),
        tuple(primitives), np.array(starts, dtype=np.int64), np.array([p.joint for p in primitives], dtype=np.int64),
        np.array([p.a for p in primitives], dtype=np.float64).reshape(-1, 3),
        np.array([p.b for p in primitives], dtype=np.float64).reshape(-1, 3),
        np.array([p.radius for p in primitives], dtype=np.float64),
        tuple(reports),
        np.array(covering, dtype=np.float64),
    )


def fit_table(geometry: RobotGeometry) -> str:
    """The fitted model as a Markdown table (one row per link), as in ``docs/robots.md``."""
    lines = ["| link | spheres | capsules | mean gap (cm) | max gap (cm) | volume ratio |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in geometry.fits:
        lines.append(f"| {r.link} | {r.spheres} | {r.capsules} | {r.mean_gap * 100:.2f} | {r.max_gap * 100:.2f} | "
                     f"{r.volume_ratio:.2f} |")
    return "\n".join(lines)
