"""Fitting spheres and capsules to one link's collision surface, conservatively, and measuring the fit.

A link's collision elements (meshes with their triangles as pinocchio/coal load them; boxes and other
primitives through their corners or inflated surface samples and the triangles of their hull) are
expressed in the link's own frame. The union of the fitted primitives contains every vertex and a dense
area sample of that surface, and every primitive stays within ``target_gap`` of the solid
(:func:`fit_primitives`): the primitives hug the surface from inside instead of wrapping it.

Measures, reported per link (:class:`LinkFit`):

* **gap** — for area-uniform samples on the *exposed* surface of the union (points of a primitive's
  surface that no other primitive of the link contains), the distance (m) to the nearest point of the
  link's collision surface (the exact mesh distance of :mod:`pfield.geometry`). ``mean_gap`` and
  ``max_gap`` are its mean and maximum: how far the fitted model's surface stands off the real one
  (``max_gap`` ≤ ``target_gap`` by construction, up to sampling);
* **volume ratio** — union volume (Monte Carlo, fixed seed) / volume of the collision elements (closed
  meshes by the divergence theorem, boxes exactly; overlapping elements are counted twice).

Fits are cached in memory and on disk (:func:`cached_fit`), in ``robot-fits`` under pfield's cache directory
(:func:`cache_root`: ``$PFIELD_CACHE_DIR``, else ``$XDG_CACHE_HOME/pfield`` or ``~/.cache/pfield``). The fits of
the built-in robots' links ship with pfield (:data:`SHIPPED_DIRECTORY`, written by ``python -m
pfield.robot._shipped_fits``) and are read, under the same key, when the user's cache has none: a new install plans
with the xArm7 or the Panda without fitting. Each fit is filed under :meth:`LinkSurface.key`, a hash of everything
the fit depends on (the surface, the stand-off bound, :func:`fit_parameters` and :data:`FIT_VERSION`), so a fit made
for another mesh, other settings or another fitting rule is never read.
"""

from __future__ import annotations

import hashlib
import logging
import math
import os
import time
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from pfield.robot._cover import cell_side, coverage, enclosing_circle, greedy_cover, min_depth
from pfield.robot._solid import SignedDistance, mesh_distance, signed_distance_of, surface_obstacle

if TYPE_CHECKING:
    from pfield.geometry import Obstacle

_LOG = logging.getLogger(__name__)

FIT_VERSION = 3  # bump when the fitting rule changes (invalidates the disk cache and the shipped fits)
TARGET_GAP = 0.014  # m, the stand-off bound of every primitive (mean gaps come out at ~0.6 of it)
_GAP_SAMPLES = 600  # surface samples per primitive for the gap
_VOLUME_SAMPLES = 60_000
_COVER_SAMPLES = 2500  # area samples covered besides the vertices
_INTERIOR_TRIES, _INTERIOR_CANDIDATES = 8000, 1200
_PAIR_TRIES, _PAIR_REACH = 4000, 0.2
_INTERIOR_CHUNK = 1000  # interior tries asked of the solid at a time
_SEGMENT_ORDER = (0.5, 0.25, 0.75, 0.125, 0.375, 0.625, 0.875, 1.0)  # a pair capsule's depth samples, as asked
_CIRCLE_ITERATIONS = 400  # Bădoiu–Clarkson steps for a capsule's radius
_FIT_SEED, _MEASURE_SEED = 7, 12  # the random generators' seeds of the fit and of its measures


def fit_parameters() -> tuple[object, ...]:
    """Every setting a fit depends on besides its surface and stand-off bound: this module's, the cover's and the
    solid's constants, read when a key is made (:meth:`LinkSurface.key`), so that changing one makes new keys.
    A change of the fitting code itself is :data:`FIT_VERSION`'s to say."""
    from pfield.robot import _cover, _solid

    return (_FIT_SEED, _MEASURE_SEED, _GAP_SAMPLES, _VOLUME_SAMPLES, _COVER_SAMPLES, _INTERIOR_TRIES,
            _INTERIOR_CANDIDATES, _PAIR_TRIES, _PAIR_REACH, _INTERIOR_CHUNK, _SEGMENT_ORDER, _CIRCLE_ITERATIONS,
            _cover._GRID_CELLS, _solid._HULL_TOLERANCE, _solid._INNER_HULL_VERTICES)


@dataclass(frozen=True)
class LinkSurface:
    """A link's collision surface in the link frame: ``vertices`` (V, 3), ``triangles`` (T, 3) and volume;
    ``link`` and ``sources`` (its elements' mesh files, or shape kinds) name it in messages, not in the cache key."""

    vertices: NDArray[np.float64]
    triangles: NDArray[np.int64]
    volume: float
    link: str = "link"
    sources: tuple[str, ...] = field(default=())

    @property
    def label(self) -> str:
        """``link (file, …)``: how log messages and the mesh built from this surface name it."""
        return f"{self.link} ({', '.join(self.sources)})" if self.sources else self.link

    def key(self, target_gap: float) -> str:
        """The fit's cache key (32 hex digits): SHA-256 of :data:`FIT_VERSION`, ``target_gap``,
        :func:`fit_parameters` and the vertices (float64) and triangles (int64) as bytes. The user's cache and the
        shipped fits (:data:`SHIPPED_DIRECTORY`) file a fit under it alike."""
        digest = hashlib.sha256()
        digest.update(f"{FIT_VERSION}:{target_gap!r}:{fit_parameters()!r}".encode())
        digest.update(np.ascontiguousarray(self.vertices, dtype=np.float64).tobytes())
        digest.update(np.ascontiguousarray(self.triangles, dtype=np.int64).tobytes())
        return digest.hexdigest()[:32]


@dataclass(frozen=True)
class Primitives:
    """k capsules in one frame: ends ``a``, ``b`` (k, 3) and radii (k,); a == b is a sphere."""

    a: NDArray[np.float64]
    b: NDArray[np.float64]
    radii: NDArray[np.float64]

    def __len__(self) -> int:
        return len(self.radii)

    @property
    def spheres(self) -> int:
        return int(np.count_nonzero(np.linalg.norm(self.b - self.a, axis=1) == 0.0))

    def transformed(self, rotation: NDArray[np.float64], translation: NDArray[np.float64]) -> Primitives:
        return Primitives(self.a @ rotation.T + translation, self.b @ rotation.T + translation, self.radii.copy())


@dataclass(frozen=True)
class LinkFit:
    """The fitted primitives of one link (link frame), the fit's measures (see the module docstring) and the
    single covering capsule (:func:`fit_single_capsule`, link frame) with its volume ratio and mean gap."""

    primitives: Primitives
    mean_gap: float
    max_gap: float
    volume_ratio: float
    bound: Primitives
    bound_volume_ratio: float
    bound_mean_gap: float


def segment_distances(points: NDArray[np.float64], a: NDArray[np.float64],
                      b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (N,) of every point to the segment a–b."""
    d = b - a
    length2 = float(d @ d)
    t = np.zeros(len(points)) if length2 == 0.0 else np.clip((points - a) @ d / length2, 0.0, 1.0)
    return np.asarray(np.linalg.norm(points - (a + t[:, None] * d), axis=1))


def depth_outside(points: NDArray[np.float64], prims: Primitives) -> NDArray[np.float64]:
    """(N, k): how far each point lies outside each primitive (≤ 0: inside)."""
    return np.stack([segment_distances(points, prims.a[j], prims.b[j]) - prims.radii[j]
                     for j in range(len(prims))], axis=1)


def _surface_samples(surface: LinkSurface, count: int, rng: np.random.Generator) -> NDArray[np.float64]:
    corners = surface.vertices[surface.triangles]
    areas = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    pick = rng.choice(len(corners), count, p=areas / areas.sum())
    u = rng.random((count, 2))
    flip = u.sum(axis=1) > 1.0
    u[flip] = 1.0 - u[flip]
    tri = corners[pick]
    return np.asarray(tri[:, 0] + u[:, :1] * (tri[:, 1] - tri[:, 0]) + u[:, 1:] * (tri[:, 2] - tri[:, 0]))


def _candidates(surface: LinkSurface, solid: SignedDistance, samples: NDArray[np.float64], gap: float,
                rng: np.random.Generator) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Candidate spheres and capsules whose every point lies within ``gap`` of the solid (module docstring)."""
    lower, upper = surface.vertices.min(axis=0), surface.vertices.max(axis=0)
    centres, depth = _interior(solid, lower + rng.random((_INTERIOR_TRIES, 3)) * (upper - lower))
    a, b, r = [centres, samples], [centres, samples], [depth + gap, np.full(len(samples), gap)]
    if len(centres) > 1:
        i = rng.integers(0, len(centres), _PAIR_TRIES)
        j = rng.integers(0, len(centres), _PAIR_TRIES)
        keep = (i != j) & (np.linalg.norm(centres[i] - centres[j], axis=1) < _PAIR_REACH)
        i, j = i[keep], j[keep]
        radius = _least_depth_along(solid, centres[i], centres[j], depth[i])
        keep = radius > 0.0
        a.append(centres[i][keep])
        b.append(centres[j][keep])
        r.append(radius[keep] + gap)
    return np.concatenate(a), np.concatenate(b), np.concatenate(r)


def _interior(solid: SignedDistance, tries: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The first :data:`_INTERIOR_CANDIDATES` of ``tries`` that lie inside the solid, and their depths. The
    solid is asked in chunks until enough are found (a third of the tries on most links)."""
    centres, depths, found = [], [], 0
    for start in range(0, len(tries), _INTERIOR_CHUNK):
        chunk = tries[start:start + _INTERIOR_CHUNK]
        depth = -solid(chunk)
        inside = depth > 0.0
        centres.append(chunk[inside])
        depths.append(depth[inside])
        found += int(np.count_nonzero(inside))
        if found >= _INTERIOR_CANDIDATES:
            break
    return np.concatenate(centres)[:_INTERIOR_CANDIDATES], np.concatenate(depths)[:_INTERIOR_CANDIDATES]


def _least_depth_along(solid: SignedDistance, a: NDArray[np.float64], b: NDArray[np.float64],
                       depth_a: NDArray[np.float64]) -> NDArray[np.float64]:
    """(P,): the least depth of the solid at 9 evenly spaced points of each segment a_p–b_p (t = 0: a_p, whose
    depth ``depth_a`` is known), or a value ≤ 0 once some point is outside. The points are asked middle first,
    and a segment stops being asked at its first point outside: the caller keeps only positive values."""
    least = depth_a.copy()
    alive = np.flatnonzero(least > 0.0)
    for t in _SEGMENT_ORDER:
        if len(alive) == 0:
            break
        along = a[alive] + t * (b[alive] - a[alive])
        least[alive] = np.minimum(least[alive], -solid(along))
        alive = alive[least[alive] > 0.0]
    return least


def fit_primitives(surface: LinkSurface, gap: float, solid: SignedDistance | None = None) -> Primitives:
    """Spheres/capsules whose union covers every vertex of ``surface`` and stands off it by at most ``gap``.

    Candidates: a sphere of radius d(c) + gap at an interior point c at depth d(c) lies within ``gap`` of the
    ball of radius d(c) ⊂ solid; a capsule between two interior points with radius (least depth along the
    segment, 9 samples) + gap likewise; a sphere of radius ``gap`` at every surface point covers it alone.
    Greedy set cover (Chvátal 1979, compiled: :func:`pfield.robot._cover.greedy_cover`) of the vertices and
    area samples, then redundant picks are dropped, smallest first. ``solid``: the surface's signed distance
    (:func:`signed_distance_of`), when the caller has it already.
    """
    rng = np.random.default_rng(_FIT_SEED)
    targets = np.concatenate([surface.vertices, _surface_samples(surface, _COVER_SAMPLES, rng)])
    a, b, radii = _candidates(surface, solid or signed_distance_of(surface), targets, gap, rng)
    picked = greedy_cover(a, b, radii, targets, cell_side(targets, gap))
    covered = coverage(a[picked], b[picked], radii[picked], targets)  # (picks, targets)
    counts = covered.sum(axis=0)
    keep = np.ones(len(picked), dtype=bool)
    for p in sorted(range(len(picked)), key=lambda p: int(covered[p].sum())):
        if np.all(counts[covered[p]] > 1):
            keep[p] = False
            counts -= covered[p]
    order = picked[keep]
    return Primitives(a[order].copy(), b[order].copy(), radii[order].copy())


def _sample_capsule_surface(a: NDArray[np.float64], b: NDArray[np.float64], r: float, count: int,
                            rng: np.random.Generator) -> NDArray[np.float64]:
    """Area-uniform points on the surface of capsule (a, b, r)."""
    axis = b - a
    length = float(np.linalg.norm(axis))
    sphere = rng.normal(size=(count, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    if length == 0.0:
        return np.asarray(a + r * sphere)
    u = axis / length
    side = 2 * math.pi * r * length / (2 * math.pi * r * length + 4 * math.pi * r * r)
    on_side = rng.random(count) < side
    # side points: the sphere direction projected ⟂ u, at a uniform axial position
    radial = sphere - np.outer(sphere @ u, u)
    norms = np.linalg.norm(radial, axis=1, keepdims=True)
    radial = np.where(norms > 1e-9, radial / np.maximum(norms, 1e-12), np.cross(u, [1.0, 0.0, 0.0]))
    t = rng.random(count)[:, None]
    side_points = a + t * axis + r * radial
    caps = np.where((sphere @ u)[:, None] >= 0.0, b + r * sphere, a + r * sphere)
    return np.asarray(np.where(on_side[:, None], side_points, caps))


def union_volume(prims: Primitives, rng: np.random.Generator, samples: int = _VOLUME_SAMPLES) -> float:
    """Monte Carlo volume (m³) of the union of ``prims``."""
    lower = np.minimum(prims.a, prims.b).min(axis=0) - prims.radii.max()
    upper = np.maximum(prims.a, prims.b).max(axis=0) + prims.radii.max()
    points = lower + rng.random((samples, 3)) * (upper - lower)
    inside = min_depth(prims.a, prims.b, prims.radii, points, -1) <= 0.0
    return float(np.prod(upper - lower) * np.count_nonzero(inside) / samples)


def measure(surface: LinkSurface, prims: Primitives, mesh: Obstacle | None = None) -> tuple[float, float, float]:
    """(mean gap, max gap, volume ratio) of ``prims`` for ``surface`` (module docstring); ``mesh``: the
    surface as an obstacle, when the caller has it already."""
    rng = np.random.default_rng(_MEASURE_SEED)
    exposed = []
    for j in range(len(prims)):
        points = _sample_capsule_surface(prims.a[j], prims.b[j], float(prims.radii[j]), _GAP_SAMPLES, rng)
        exposed.append(points[min_depth(prims.a, prims.b, prims.radii, points, j) > -1e-9])
    samples = np.concatenate(exposed)
    gaps = np.abs(mesh_distance(mesh or surface_obstacle(surface), samples))
    ratio = union_volume(prims, rng) / surface.volume if surface.volume > 0 else math.inf
    return float(gaps.mean()), float(gaps.max()), ratio


def fit_link(surface: LinkSurface, target_gap: float = TARGET_GAP) -> LinkFit:
    """:func:`fit_primitives` with the stand-off bound ``target_gap`` (m), measured."""
    mesh = surface_obstacle(surface)
    prims = fit_primitives(surface, target_gap, signed_distance_of(surface, mesh))
    mean_gap, max_gap, ratio = measure(surface, prims, mesh)
    a, b, r, bound_ratio, bound_gap = fit_single_capsule(surface.vertices)
    return LinkFit(prims, mean_gap, max_gap, ratio, Primitives(a[None], b[None], np.array([r])), bound_ratio,
                   bound_gap)


def _capsule_along(points: NDArray[np.float64], axis: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    basis = np.linalg.svd(np.eye(3) - np.outer(axis, axis))[0][:, :2]
    planar = points @ basis
    centre2 = enclosing_circle(np.ascontiguousarray(planar), _CIRCLE_ITERATIONS)
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


def fit_single_capsule(
        points: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], float, float, float]:
    """Smallest-volume capsule (over the principal axes) covering ``points`` (N, 3): ``(a, b, r, volume
    ratio to the points' hull, mean distance of the hull's vertices to the capsule surface)``; the steps are
    in :mod:`pfield.robot.geometry`."""
    from scipy.spatial import ConvexHull, QhullError  # only when fitting (import costs ≈ 0.3 s)

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
    gaps = r - segment_distances(vertices, a, b)
    ratio = volume / hull_volume if hull_volume > 0 else math.inf
    return a, b, r, ratio, float(gaps.mean())


# ---- cache ---------------------------------------------------------------------------------------------
_MEMORY: dict[str, LinkFit] = {}


CACHE_ENVIRONMENT = "PFIELD_CACHE_DIR"
"""The environment variable naming pfield's cache directory (the fitted link models live in its ``robot-fits``)."""


def cache_root() -> Path:
    """pfield's cache directory: ``$PFIELD_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/pfield``, else
    ``~/.cache/pfield`` (the XDG base directory rule; a user's cache, outside the installed package)."""
    root = os.environ.get(CACHE_ENVIRONMENT)
    if root:
        return Path(root).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "pfield"


def fit_cache_directory() -> Path | None:
    """Where fits are kept on disk: ``robot-fits`` in :func:`cache_root` (created on first use); None when it
    cannot be created or written (fits are then kept in memory only)."""
    directory = cache_root() / "robot-fits"
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return directory if os.access(directory, os.W_OK) else None


SHIPPED_DIRECTORY = Path(str(resources.files("pfield") / "data" / "robot_fits"))
"""The fits of the built-in robots' links that ship with pfield (package data, read only): ``<robot>/<link>-<key>.npz``
with ``key`` = :meth:`LinkSurface.key` at :data:`TARGET_GAP`; ``python -m pfield.robot._shipped_fits`` writes them."""

_FIELDS = ("a", "b", "radii", "mean_gap", "max_gap", "volume_ratio", "bound_a", "bound_b", "bound_r",
           "bound_volume_ratio", "bound_mean_gap")


def write_fit(path: Path, fit: LinkFit, key: str, *, compressed: bool = False) -> None:
    """Write ``fit`` (filed under ``key``, which the file records) to ``path`` as a ``.npz``, atomically (a
    temporary file beside it, then renamed)."""
    tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
    save = np.savez_compressed if compressed else np.savez
    save(tmp, key=np.array(key), a=fit.primitives.a, b=fit.primitives.b, radii=fit.primitives.radii,
         mean_gap=fit.mean_gap, max_gap=fit.max_gap, volume_ratio=fit.volume_ratio, bound_a=fit.bound.a,
         bound_b=fit.bound.b, bound_r=fit.bound.radii, bound_volume_ratio=fit.bound_volume_ratio,
         bound_mean_gap=fit.bound_mean_gap)
    tmp.replace(path)


def read_fit(path: Path, key: str | None = None) -> LinkFit:
    """The fit in ``path`` (:func:`write_fit`). With ``key``, the file must record that key (a :class:`ValueError`
    otherwise): a file renamed to another key is not taken for it."""
    with np.load(path) as data:
        if key is not None and ("key" not in data.files or str(data["key"]) != key):
            raise ValueError(f"it is not the fit filed under {key}")
        return LinkFit(Primitives(data["a"], data["b"], data["radii"]), float(data["mean_gap"]),
                       float(data["max_gap"]), float(data["volume_ratio"]),
                       Primitives(data["bound_a"], data["bound_b"], data["bound_r"]),
                       float(data["bound_volume_ratio"]), float(data["bound_mean_gap"]))


@cache
def shipped_fits() -> dict[str, Path]:
    """The shipped fits (:data:`SHIPPED_DIRECTORY`) by key, listed once per process."""
    if not SHIPPED_DIRECTORY.is_dir():
        return {}
    return {path.stem.rpartition("-")[2]: path for path in sorted(SHIPPED_DIRECTORY.glob("*/*.npz"))}


def _read_shipped(key: str) -> LinkFit | None:
    path = shipped_fits().get(key)
    if path is None:
        return None
    try:
        fit = read_fit(path, key)
    except (OSError, KeyError, ValueError) as exc:
        _LOG.warning("ignoring unreadable shipped robot fit %s: %s", path, exc)
        return None
    _LOG.debug("read the shipped fit %s", path)
    return fit


def cached_fit(surface: LinkSurface, target_gap: float = TARGET_GAP, progress: str = "") -> LinkFit:
    """:func:`fit_link`, remembered in memory and on disk under the surface's key (:meth:`LinkSurface.key`).

    Looked up in memory, then in the user's cache (:func:`fit_cache_directory`), then in the fits shipped with pfield
    (:data:`SHIPPED_DIRECTORY`, read only); only a link found in none is fitted, and its fit is written to the
    user's cache. A link that is actually fitted is logged at INFO before and after (``progress``, e.g. ``"3/18"``,
    says where it stands among the robot's links), so a first fit shows which link it is on."""
    key = surface.key(target_gap)
    if key in _MEMORY:
        return _MEMORY[key]
    directory = fit_cache_directory()
    path = directory / f"{key}.npz" if directory is not None else None
    fit = None
    if path is not None and path.exists():
        try:
            fit = read_fit(path)
        except (OSError, KeyError, ValueError) as exc:
            _LOG.warning("ignoring unreadable robot fit cache %s: %s", path, exc)
    if fit is None:
        fit = _read_shipped(key)
    if fit is None:
        where = f" {progress}" if progress else ""
        _LOG.info("fitting link%s %s: %d triangles", where, surface.label, len(surface.triangles))
        began = time.perf_counter()
        fit = fit_link(surface, target_gap)
        count = len(fit.primitives)
        _LOG.info("fitted link%s %s in %.2f s: %d %s, mean gap %.2f cm", where, surface.link,
                  time.perf_counter() - began, count, "primitive" if count == 1 else "primitives", 100 * fit.mean_gap)
        if path is not None:
            try:
                write_fit(path, fit, key)
            except OSError as exc:
                _LOG.warning("cannot write robot fit cache %s: %s", path, exc)
    _MEMORY[key] = fit
    return fit
