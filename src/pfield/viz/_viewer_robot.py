"""The robot of the 3D viewer: its URDF's visual meshes, read through the robot model's own resolver.

The viewer reads the files the model was loaded with (:meth:`RobotModel.resolve_mesh`: the model's package
paths, made absolute when it was loaded, and the URDF's folder for relative paths), never a second guess of
where packages are. A visual mesh that cannot be read (missing, empty, not a mesh) raises a pfield error
naming the file and the link instead of trimesh's or pycollada's traceback.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from pfield.errors import InvalidInput, PfieldError, ResourceNotAllowed, ResourceNotFound

__all__ = ["load_visual_urdf"]

MESH_FORMATS = "STL, DAE, OBJ, PLY, GLB"


def load_visual_urdf(robot: Any) -> Any:
    """A ``yourdfpy.URDF`` of ``robot`` (a :class:`~pfield.robot.RobotModel`) with its visual meshes loaded.

    Raises :class:`~pfield.errors.ResourceNotFound` / :class:`~pfield.errors.ResourceNotAllowed` for a mesh
    the model's resolver cannot find or may not read, and :class:`~pfield.errors.InvalidInput` for one that
    is not a readable mesh; each names the link, the URI and the file.
    """
    import yourdfpy

    urdf_path = Path(robot.urdf_path)
    parsed = yourdfpy.URDF.load(str(urdf_path), build_scene_graph=False, build_collision_scene_graph=False,
                                load_meshes=False, load_collision_meshes=False)
    owners = {id(visual.geometry): link.name for link in parsed.robot.links for visual in link.visuals
              if visual.geometry is not None}
    checked = _checked_urdf_class()
    return checked(owners, urdf_path, robot.resolve_mesh, robot=parsed.robot, build_scene_graph=True,
                   load_meshes=True, build_collision_scene_graph=False, load_collision_meshes=False,
                   filename_handler=lambda fname: str(robot.resolve_mesh(fname)))


def _where(link: str | None, urdf_path: Path) -> str:
    return f"link {link!r} of {urdf_path}" if link else f"a visual of {urdf_path}"


def unreadable_mesh(link: str | None, urdf_path: Path, uri: str, path: Path, detail: str) -> InvalidInput:
    """The error of a mesh file that exists but is not a mesh pfield can draw."""
    return InvalidInput(f"{_where(link, urdf_path)}: mesh", uri,
                        f"cannot read {path} as a mesh: {detail}; replace the file with a valid mesh "
                        f"({MESH_FORMATS}) or point the <mesh filename> of that link at one")


@functools.cache
def _checked_urdf_class() -> type:
    """yourdfpy's URDF, whose mesh loading names the link and file of a mesh it cannot read."""
    import yourdfpy

    class CheckedURDF(yourdfpy.URDF):  # type: ignore[misc]
        def __init__(self, owners: Mapping[int, str], urdf_path: Path, resolve: Callable[[str], Path],
                     **kwargs: Any) -> None:
            self._pfield_owners = owners
            self._pfield_urdf = urdf_path
            self._pfield_resolve = resolve
            super().__init__(**kwargs)

        def _geometry2trimeshscene(self, geometry: Any, *args: Any, **kwargs: Any) -> Any:
            mesh = getattr(geometry, "mesh", None)
            load = kwargs.get("load_file", args[0] if args else True)
            if mesh is None or not load:
                return super()._geometry2trimeshscene(geometry, *args, **kwargs)
            link, uri = self._pfield_owners.get(id(geometry)), str(mesh.filename)
            try:
                path = self._pfield_resolve(uri)
                size = path.stat().st_size
            except (ResourceNotFound, ResourceNotAllowed) as exc:
                raise type(exc)(f"{_where(link, self._pfield_urdf)}: {exc}") from None
            except OSError as exc:
                raise ResourceNotFound(f"{_where(link, self._pfield_urdf)}: mesh {uri!r}: cannot read "
                                       f"({exc.strerror})") from None
            if size == 0:
                raise unreadable_mesh(link, self._pfield_urdf, uri, path, "the file is empty (0 bytes)")
            try:
                scene = super()._geometry2trimeshscene(geometry, *args, **kwargs)
            except PfieldError:
                raise
            except Exception as exc:  # trimesh and pycollada raise many types for malformed files
                detail = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
                raise unreadable_mesh(link, self._pfield_urdf, uri, path, detail) from None
            if scene is None or scene.is_empty:
                raise unreadable_mesh(link, self._pfield_urdf, uri, path, "it holds no triangles")
            return scene

    return CheckedURDF
