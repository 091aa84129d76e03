"""Resolution of resource URIs (meshes, URDF files) to files, optionally confined to allowed places.

Accepted forms:

* ``package://<pkg>/<relative path>`` — through the configured ``package_paths`` (``{pkg: directory}``),
  then through the ament index: ``<prefix>/share/<pkg>`` for each prefix of ``AMENT_PREFIX_PATH``;
* ``file:///abs/path``, ``file://localhost/abs/path`` and plain paths (relative to ``base_directory``,
  by default the current directory).

Whoever calls the library is trusted: by default (``allowed_roots=None``) any local file the caller names
is read. A resolver serving untrusted clients — the node, whose messages come from the network — is given
``allowed_roots``: then ``file://`` URIs and plain paths must resolve (symlinks and ``..`` resolved) inside
one of them. A ``package://`` file must always stay inside its package directory. Other schemes, files
outside the roots and escapes raise :class:`~pfield.errors.ResourceNotAllowed`; a missing package or file
raises :class:`~pfield.errors.ResourceNotFound` saying what to configure.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlparse

from pfield._files import relative_to_cwd
from pfield._validation import text
from pfield.errors import InvalidInput, ResourceNotAllowed, ResourceNotFound

__all__ = ["PackagePaths", "ResourceResolver", "package_path_map"]

_PACKAGE = "package://"


def _inside(path: Path, root: Path) -> bool:
    return path == root or root in path.parents


@dataclass(frozen=True)
class ResourceResolver:
    """Maps resource URIs to existing files (see the module docstring).

    ``package_paths`` maps ROS package names to their directories. ``allowed_roots`` are the directories
    ``file://`` URIs and plain paths may point into; ``None`` (the default) allows every local file, an empty
    sequence none. ``base_directory`` anchors relative paths (``None``: the current directory when
    resolving; a scene file's folder for its meshes). ``use_ament`` also looks packages up under
    ``AMENT_PREFIX_PATH``.
    """

    package_paths: Mapping[str, Path] = field(default_factory=dict)
    allowed_roots: Sequence[Path] | None = None
    use_ament: bool = True
    base_directory: Path | None = None

    def __post_init__(self) -> None:
        packages: dict[str, Path] = {}
        for name, directory in dict(self.package_paths).items():
            if not name or "/" in name:
                raise InvalidInput("package_paths", name, "package names are non-empty and contain no '/'")
            packages[name] = Path(directory).expanduser().resolve()
        if self.allowed_roots is not None:
            roots = tuple(Path(root).expanduser().resolve() for root in self.allowed_roots)
            object.__setattr__(self, "allowed_roots", roots)
        if self.base_directory is not None:
            object.__setattr__(self, "base_directory", Path(self.base_directory).expanduser().resolve())
        object.__setattr__(self, "package_paths", packages)

    @classmethod
    def default(cls) -> ResourceResolver:
        """The library's resolver: any local file (relative to the current directory), ``package://``
        through the ament index."""
        return cls()

    def resolve(self, uri: str) -> Path:
        """The existing file ``uri`` names (absolute, symlinks resolved).

        Raises :class:`ResourceNotAllowed` outside the allowed places, :class:`ResourceNotFound` when the
        package or file does not exist, :class:`InvalidInput` for an empty or malformed URI.
        """
        if not isinstance(uri, str) or not uri.strip():
            raise InvalidInput("mesh_resource", uri, "empty resource URI")
        if uri.startswith(_PACKAGE):
            return self._resolve_package(uri)
        scheme = urlparse(uri).scheme
        if scheme == "file":
            parsed = urlparse(uri)
            if parsed.netloc not in ("", "localhost"):
                raise ResourceNotAllowed(f"{uri!r}: file:// URIs must name a local file (file:///abs/path)")
            return self._resolve_file(uri, Path(unquote(parsed.path)))
        if scheme and len(scheme) > 1:  # "C:" style drive letters are not schemes
            raise ResourceNotAllowed(f"{uri!r}: scheme {scheme!r} not supported; use package://, file:// or a path")
        return self._resolve_file(uri, Path(uri).expanduser())

    def _resolve_file(self, uri: str, path: Path) -> Path:
        resolved = ((self.base_directory or Path.cwd()) / path).resolve()
        if self.allowed_roots is not None and not any(_inside(resolved, root) for root in self.allowed_roots):
            roots = ", ".join(str(root) for root in self.allowed_roots) or "none configured"
            raise ResourceNotAllowed(
                f"{uri!r} resolves to {resolved}, outside the allowed roots ({roots}); "
                "add its directory as an allowed root (pfield serve --mesh-root DIR) or use package://"
            )
        return _existing(uri, resolved)

    def _resolve_package(self, uri: str) -> Path:
        package, _, relative = uri[len(_PACKAGE):].partition("/")
        if not package or not relative:
            raise InvalidInput("mesh_resource", uri, "expected package://<package>/<path inside the package>")
        directory = self.package_directory(package)
        resolved = (directory / unquote(relative)).resolve()
        if not _inside(resolved, directory):
            raise ResourceNotAllowed(f"{uri!r} resolves to {resolved}, outside package {package!r} ({directory})")
        # the package's folder is wrong more often than the file is missing; a root the caller gave can be mended
        advice = (f"; check its root (package_paths={{{package!r}: DIR}}, on the command line --package-path "
                  f"{package}=DIR)") if package in self.package_paths else ""
        return _existing(uri, resolved, f" (package {package!r} is {directory}: its folder must hold "
                                        f"{unquote(relative)!r}{advice})")

    def package_directory(self, package: str) -> Path:
        """The directory of ROS package ``package`` (configured paths first, then the ament index)."""
        if package in self.package_paths:
            return Path(self.package_paths[package])
        if self.use_ament:
            for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
                candidate = Path(prefix) / "share" / package
                if prefix and candidate.is_dir():
                    return candidate.resolve()
        raise ResourceNotFound(
            f"package {package!r} is unknown: add --package-path {package}=DIR "
            f"(or ResourceResolver(package_paths={{{package!r}: DIR}})) or source its ROS workspace"
        )


PackagePaths = Mapping[str, str | Path] | Iterable[str | tuple[str, str | Path]]
"""Package roots: a mapping ``{NAME: DIR}``, ``(NAME, DIR)`` pairs or ``"NAME=DIR"`` strings
(:func:`package_path_map`)."""


def package_path_map(values: PackagePaths | None, field: str = "package_paths") -> dict[str, Path]:
    """``{NAME: absolute DIR}`` of package roots given as a mapping, ``(NAME, DIR)`` pairs or ``"NAME=DIR"``
    strings (a relative ``DIR`` is relative to the current directory). Refuses, naming ``field``, an entry that
    is not ``NAME=DIR``, a ``DIR`` that is not a directory and a name given twice with two folders."""
    if values is None:
        return {}
    if isinstance(values, str | bytes):
        values = [values]  # type: ignore[list-item]
    items = values.items() if isinstance(values, Mapping) else values
    paths: dict[str, Path] = {}
    for item in items:
        if isinstance(item, str):
            name, sep, directory = item.partition("=")
            if not sep or not name.strip() or not directory.strip():
                raise InvalidInput(field, item, "expected NAME=DIR (a package name, '=', its root folder), "
                                                "e.g. meshes=./meshes")
        elif isinstance(item, tuple) and len(item) == 2:
            name, directory = text(field, item[0]), str(item[1])
        else:
            raise InvalidInput(field, item, "expected NAME=DIR strings, (NAME, DIR) pairs or a mapping")
        name = text(field, name).strip()
        folder = Path(directory).expanduser()
        if not folder.is_dir():
            raise InvalidInput(field, f"{name}={directory}", f"{directory} is not a directory{relative_to_cwd(folder)}")
        folder = folder.resolve()
        if paths.get(name, folder) != folder:
            raise InvalidInput(field, f"{name}={directory}", f"package {name!r} is given twice, with two folders")
        paths[name] = folder
    return paths


def _existing(uri: str, path: Path, hint: str = "") -> Path:
    if not path.is_file():
        raise ResourceNotFound(f"{uri!r}: no such file {path}{hint}")
    return path
