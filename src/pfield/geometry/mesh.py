"""Triangle-mesh obstacles: loading (.obj, .stl, .dae), scaling, caching and distance preprocessing.

A :class:`Mesh` is always loaded and valid: its constructor resolves ``mesh_resource`` through a
:class:`~pfield.geometry.resources.ResourceResolver` (the default one reads any local file the caller
names: a path relative to the current directory, an absolute path or a ``file://`` URI), reads the file
with trimesh (pycollada for COLLADA), applies ``scale_x/y/z`` and builds the BVH and pseudo-normals the compiled
distance query needs. Bad input raises before any Mesh exists.

Files are cached by (resolved path, modification time); prepared meshes additionally by scale.
Distances are signed only for watertight meshes (every edge shared by exactly two consistently
oriented faces); others get the unsigned distance and a logged warning.
"""

from __future__ import annotations

import functools
import logging
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._validation import as_vector, positive
from pfield.errors import InvalidInput, ResourceNotFound
from pfield.geometry._mesh_build import build_bvh, orient_components_outward, orient_consistently, pseudo_normals
from pfield.geometry.resources import ResourceResolver

__all__ = ["MESH_SUFFIXES", "Mesh", "MeshData", "load_mesh_arrays", "read_mesh_file"]

logger = logging.getLogger(__name__)

MESH_SUFFIXES = (".obj", ".stl", ".dae")
_MIN_AREA = 1e-20  # m²; faces below are degenerate (no normal) and dropped


@dataclass(frozen=True, eq=False)
class MeshData:
    """A prepared mesh in the obstacle's local, scaled frame (read-only arrays).

    ``triangles`` and ``normals`` are stored in the BVH's leaf order; BVH indices are local (root 0).
    """

    source: str
    vertices: NDArray[np.float64]  # (V, 3) m, scaled
    faces: NDArray[np.int64]  # (F, 3)
    watertight: bool
    triangles: NDArray[np.float64]  # (F, 3, 3)
    normals: NDArray[np.float64]  # (F, 7, 3) pseudo-normals: face, edges ab/bc/ca, vertices a/b/c
    bvh_lower: NDArray[np.float64]
    bvh_upper: NDArray[np.float64]
    bvh_nodes: NDArray[np.int64]


def _read_with_trimesh(path: Path) -> Any:
    import trimesh

    try:
        loaded = trimesh.load(str(path), force="mesh", process=True)
    except Exception as exc:  # trimesh/pycollada raise many types for malformed files
        raise InvalidInput("mesh_resource", str(path), f"unreadable mesh file ({type(exc).__name__}: {exc})") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise InvalidInput("mesh_resource", str(path), "the file contains no triangles")
    return loaded


def _orient_outward(mesh: Any) -> bool:
    """Make a closed mesh's winding consistent and outward (pseudo-normals need it); True if watertight."""
    if not mesh.is_watertight:
        return False
    if not mesh.is_winding_consistent:  # closed but sloppily exported: re-wind the faces
        faces = orient_consistently(mesh.faces)
        if faces is None:
            return False
        mesh.faces = faces
    # Each closed component must face outward on its own (a mesh may hold several bodies).
    mesh.faces = orient_components_outward(np.asarray(mesh.vertices), np.asarray(mesh.faces), mesh.face_adjacency)
    return True


@functools.lru_cache(maxsize=64)
def _read_cached(path: str, mtime_ns: int) -> tuple[NDArray[np.float64], NDArray[np.int64], bool]:
    mesh = _read_with_trimesh(Path(path))
    keep = mesh.area_faces > _MIN_AREA
    if not np.all(keep):
        mesh.update_faces(keep)
        mesh.remove_unreferenced_vertices()
    watertight = _orient_outward(mesh)
    vertices = np.array(mesh.vertices, dtype=np.float64)
    faces = np.array(mesh.faces, dtype=np.int64)
    if not np.all(np.isfinite(vertices)):
        raise InvalidInput("mesh_resource", path, "the mesh has non-finite vertex coordinates")
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces, watertight


def read_mesh_file(path: Path) -> tuple[NDArray[np.float64], NDArray[np.int64], bool]:
    """``(vertices (V,3), faces (F,3), watertight)`` of a .obj/.stl/.dae file, cached by (path, mtime).

    Degenerate (zero-area) faces are dropped; a watertight mesh is oriented outward.
    Raises :class:`ResourceNotFound` for a missing file and :class:`InvalidInput` for another suffix,
    an empty or unreadable file.
    """
    path = Path(path)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise InvalidInput("mesh_resource", str(path), f"not a mesh file; expected one of {', '.join(MESH_SUFFIXES)}")
    try:
        stat = path.stat()
    except OSError as exc:
        raise ResourceNotFound(f"{path}: cannot read mesh ({exc.strerror})") from exc
    if stat.st_size == 0:
        raise InvalidInput("mesh_resource", str(path), "the file is empty")
    return _read_cached(str(path.resolve()), stat.st_mtime_ns)


def load_mesh_arrays(
    resource: str | Path, resolver: ResourceResolver | None = None, scale: ArrayLike = (1.0, 1.0, 1.0)
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Vertices (V, 3, m, multiplied by ``scale`` per axis) and faces (F, 3) of a mesh URI or path.

    ``resource`` goes through ``resolver`` (default: :meth:`ResourceResolver.default`). Meant for link
    meshes of robot models and other users that need raw arrays.
    """
    factors = np.array(_scales(as_vector("scale", scale, 3)))
    path = (resolver or ResourceResolver.default()).resolve(str(resource))
    vertices, faces, _ = read_mesh_file(path)
    return vertices * factors, np.array(faces)


def _prepare(source: str, vertices: NDArray[np.float64], faces: NDArray[np.int64], watertight: bool) -> MeshData:
    triangles = vertices[faces]
    normals = pseudo_normals(vertices, faces)
    bvh = build_bvh(triangles)
    if not watertight:
        logger.warning("mesh %s is not watertight: its distance is unsigned (never negative: a point inside reads as "
                       "outside); close its surface if it bounds a solid obstacle (a robot link's mesh needs nothing: "
                       "the link's fit covers its surface)", source)
    return MeshData(
        source, _frozen(vertices, np.float64), _frozen(faces, np.int64), watertight,
        _frozen(triangles[bvh.order], np.float64), _frozen(normals[bvh.order], np.float64),
        _frozen(bvh.lower, np.float64), _frozen(bvh.upper, np.float64), _frozen(bvh.nodes, np.int64),
    )


def _scales(scale: Iterable[Any]) -> tuple[float, float, float]:
    """``(scale_x, scale_y, scale_z)``, each a finite float > 0."""
    x, y, z = (positive(name, value) for name, value in zip(("scale_x", "scale_y", "scale_z"), scale, strict=True))
    return x, y, z


def _frozen(array: NDArray[Any], dtype: type) -> NDArray[Any]:
    out: NDArray[Any] = np.ascontiguousarray(array, dtype=dtype)
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=64)
def _prepared_file(path: str, mtime_ns: int, scale: tuple[float, float, float]) -> MeshData:
    vertices, faces, watertight = read_mesh_file(Path(path))
    return _prepare(path, vertices * np.array(scale), faces, watertight)


@dataclass(frozen=True, init=False)
class Mesh:
    """A triangle-mesh shape: ``mesh_resource`` URI and per-axis ``scale_x/y/z`` (> 0), loaded on construction.

    ``Mesh("../models/wedge.obj")``, ``Mesh("/abs/wedge.stl")``, ``Mesh("file:///abs/wedge.stl")`` or
    ``Mesh("package://my_robot_description/meshes/obstacle.dae", resolver=ResourceResolver(
    package_paths={"my_robot_description": Path("…")}))``; a ``pathlib.Path`` is taken as its text.
    Vertices are in the obstacle's local frame, multiplied by the scales. ``data`` holds the prepared arrays
    (:class:`MeshData`); equality compares
    the URI, the scales and the resolved source.
    """

    mesh_resource: str
    scale_x: float
    scale_y: float
    scale_z: float
    data: MeshData = field(repr=False, compare=False)
    source: str = field(repr=False)
    type_name: ClassVar[str] = "Mesh"

    def __init__(self, mesh_resource: str | os.PathLike[str], scale_x: float = 1.0, scale_y: float = 1.0,
                 scale_z: float = 1.0, *, resolver: ResourceResolver | None = None) -> None:
        if isinstance(mesh_resource, os.PathLike):
            mesh_resource = os.fspath(mesh_resource)
        path = (resolver or ResourceResolver.default()).resolve(mesh_resource)  # a missing file is said first
        scale = _scales((scale_x, scale_y, scale_z))
        try:
            read_mesh_file(path)  # validates suffix, emptiness and content with clear errors
        except InvalidInput as exc:
            raise InvalidInput("mesh_resource", mesh_resource, f"{exc.reason} ({path})") from None
        data = _prepared_file(str(path), path.stat().st_mtime_ns, scale)
        self._set(mesh_resource, scale, data, str(path))

    @classmethod
    def from_arrays(cls, vertices: ArrayLike, faces: ArrayLike, name: str = "mesh",
                    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> Mesh:
        """A mesh from vertex (V, 3, m) and face (F, 3) arrays; ``mesh_resource`` becomes ``memory://<name>``."""
        import trimesh

        factors = _scales(scale)
        try:
            mesh = trimesh.Trimesh(np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int64), process=True)
        except (ValueError, IndexError) as exc:
            raise InvalidInput("faces", "array", f"not a triangle mesh ({exc})") from exc
        mesh.update_faces(mesh.area_faces > _MIN_AREA)
        if len(mesh.faces) == 0 or not np.all(np.isfinite(mesh.vertices)):
            raise InvalidInput("vertices", "array", "the mesh has no valid triangles or non-finite vertices")
        watertight = _orient_outward(mesh)
        data = _prepare(f"memory://{name}", np.array(mesh.vertices) * np.array(factors),
                        np.array(mesh.faces, dtype=np.int64), watertight)
        instance = cls.__new__(cls)
        instance._set(f"memory://{name}", factors, data, data.source)
        return instance

    def _set(self, resource: str, scale: tuple[float, float, float], data: MeshData, source: str) -> None:
        for name, value in (("mesh_resource", resource), ("scale_x", scale[0]), ("scale_y", scale[1]),
                            ("scale_z", scale[2]), ("data", data), ("source", source)):
            object.__setattr__(self, name, value)

    def packed_sizes(self) -> tuple[float, float, float]:
        return (self.scale_x, self.scale_y, self.scale_z)

    def bounding_radius(self) -> float:
        """Radius (m) of the smallest origin-centred sphere containing every (scaled) vertex."""
        return float(np.max(np.linalg.norm(self.data.vertices, axis=1)))

    @property
    def watertight(self) -> bool:
        """True when distances are signed (closed, consistently oriented mesh)."""
        return self.data.watertight
