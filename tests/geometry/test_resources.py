"""Resource URIs: any file for the library's caller; only configured packages and allowed roots when confined."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from pfield.errors import InvalidInput, ResourceNotAllowed, ResourceNotFound
from pfield.geometry import Mesh, ResourceResolver

from ._helpers import MESHES, PACKAGE

SEED_URI = "package://my_robot_description/meshes/obstacle.dae"


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """tmp/root/{cube.obj, sub/cube.obj} and tmp/outside/cube.obj."""
    for directory in ("root/sub", "outside"):
        (tmp_path / directory).mkdir(parents=True)
    for target in ("root/cube.obj", "root/sub/cube.obj", "outside/cube.obj"):
        shutil.copy(MESHES / "unit_cube.obj", tmp_path / target)
    return tmp_path


def test_package_uri_through_package_paths():
    resolver = ResourceResolver(package_paths={"my_robot_description": PACKAGE})
    assert resolver.resolve(SEED_URI) == PACKAGE / "meshes" / "obstacle.dae"


def test_package_uri_through_the_ament_index(tmp_path, monkeypatch):
    share = tmp_path / "install" / "share" / "my_robot_description"
    shutil.copytree(PACKAGE, share)
    monkeypatch.setenv("AMENT_PREFIX_PATH", f"/nonexistent:{tmp_path / 'install'}")
    assert ResourceResolver().resolve(SEED_URI) == share / "meshes" / "obstacle.dae"
    with pytest.raises(ResourceNotFound):
        ResourceResolver(use_ament=False).resolve(SEED_URI)


def test_configured_package_paths_win_over_ament(tmp_path, monkeypatch):
    share = tmp_path / "share" / "my_robot_description"
    shutil.copytree(PACKAGE, share)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path))
    resolver = ResourceResolver(package_paths={"my_robot_description": PACKAGE})
    assert resolver.resolve(SEED_URI) == PACKAGE / "meshes" / "obstacle.dae"


def test_missing_package_says_what_to_do(monkeypatch):
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    with pytest.raises(ResourceNotFound, match="--package-path my_robot_description=DIR"):
        ResourceResolver().resolve(SEED_URI)


def test_missing_file_in_package():
    resolver = ResourceResolver(package_paths={"my_robot_description": PACKAGE})
    with pytest.raises(ResourceNotFound, match="no such file"):
        resolver.resolve("package://my_robot_description/meshes/absent.dae")


def test_package_uri_cannot_escape_its_package():
    resolver = ResourceResolver(package_paths={"my_robot_description": PACKAGE})
    with pytest.raises(ResourceNotAllowed, match="outside package"):
        resolver.resolve("package://my_robot_description/../meshes/unit_cube.obj")


def test_file_uri_and_paths_inside_the_roots(tree):
    resolver = ResourceResolver(allowed_roots=[tree / "root"])
    assert resolver.resolve(f"file://{tree}/root/cube.obj") == tree / "root" / "cube.obj"
    assert resolver.resolve(str(tree / "root" / "sub" / "cube.obj")) == tree / "root" / "sub" / "cube.obj"
    assert resolver.resolve(f"{tree}/root/sub/../cube.obj") == tree / "root" / "cube.obj"


@pytest.mark.parametrize("uri", [
    "file:///etc/passwd",
    "/etc/passwd",
    "{tree}/outside/cube.obj",
    "file://{tree}/outside/cube.obj",
    "{tree}/root/../outside/cube.obj",
    "file://{tree}/root/sub/../../outside/cube.obj",
    "http://example.com/cube.obj",
    "file://remotehost/cube.obj",
])
def test_everything_else_is_not_allowed(tree, uri):
    with pytest.raises(ResourceNotAllowed):
        ResourceResolver(allowed_roots=[tree / "root"]).resolve(uri.format(tree=tree))


def test_symlink_escaping_the_root_is_not_allowed(tree):
    (tree / "root" / "link.obj").symlink_to(tree / "outside" / "cube.obj")
    with pytest.raises(ResourceNotAllowed):
        ResourceResolver(allowed_roots=[tree / "root"]).resolve(str(tree / "root" / "link.obj"))


def test_relative_paths_and_the_default_root(tree, monkeypatch):
    monkeypatch.chdir(tree / "root")
    resolver = ResourceResolver.default()
    assert resolver.resolve("sub/cube.obj") == tree / "root" / "sub" / "cube.obj"
    assert Mesh("cube.obj").watertight  # Mesh uses the default resolver when none is given


def test_the_library_reads_any_file_its_caller_names(tree, monkeypatch):
    """The caller of the library is trusted: ``..``, absolute paths and file:// URIs all resolve."""
    monkeypatch.chdir(tree / "root" / "sub")
    outside = tree / "outside" / "cube.obj"
    assert ResourceResolver.default().resolve("../../outside/cube.obj") == outside
    for resource in ("../../outside/cube.obj", str(outside), f"file://{outside}", f"file://localhost{outside}",
                     outside):
        mesh = Mesh(resource)
        assert mesh.source == str(outside) and mesh.watertight


def test_relative_paths_follow_the_base_directory(tree, monkeypatch):
    monkeypatch.chdir(tree / "outside")
    resolver = ResourceResolver(base_directory=tree / "root" / "sub")
    assert resolver.resolve("cube.obj") == tree / "root" / "sub" / "cube.obj"
    assert resolver.resolve("../cube.obj") == tree / "root" / "cube.obj"


def test_an_empty_root_list_allows_no_file(tree):
    with pytest.raises(ResourceNotAllowed, match="none configured"):
        ResourceResolver(allowed_roots=[]).resolve(str(tree / "root" / "cube.obj"))


def test_other_schemes_stay_refused_by_the_default_resolver():
    for uri in ("http://example.com/cube.obj", "file://remotehost/cube.obj"):
        with pytest.raises(ResourceNotAllowed):
            ResourceResolver.default().resolve(uri)


@pytest.mark.parametrize("uri", ["", "   ", "package://", "package://my_robot_description", "package:///x.dae"])
def test_malformed_uris(uri):
    resolver = ResourceResolver(package_paths={"my_robot_description": PACKAGE})
    with pytest.raises(InvalidInput):
        resolver.resolve(uri)


def test_bad_package_names():
    with pytest.raises(InvalidInput):
        ResourceResolver(package_paths={"a/b": PACKAGE})
