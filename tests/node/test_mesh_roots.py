"""The node reads mesh files only inside its allowed roots, while the library reads what its caller names."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from pfield.errors import PfieldError
from pfield.geometry import Mesh
from pfield.interfaces import message_from_yaml
from pfield.interfaces import potential_fields_interfaces as pfi
from pfield.node._base import Bus
from pfield.node._planning import make_resolver
from pfield.node.manager import ManagerNode

CUBE = Path(__file__).resolve().parents[1] / "data" / "meshes" / "unit_cube.obj"


def _mesh_message(resource: str) -> pfi.ObstacleArray:
    return message_from_yaml(pfi.ObstacleArray, (
        "{header: {frame_id: world}, obstacles: [{frame_id: cube, type: Mesh, group: Static, "
        f"mesh_resource: '{resource}', scale_x: 1, scale_y: 1, scale_z: 1}}]}}"))


@pytest.fixture
def tree(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "roots" / "meshes").mkdir(parents=True)
    (tmp_path / "outside").mkdir()
    shutil.copy(CUBE, tmp_path / "roots" / "meshes" / "cube.obj")
    shutil.copy(CUBE, tmp_path / "outside" / "cube.obj")
    monkeypatch.chdir(tmp_path / "roots")
    return tmp_path


@pytest.mark.parametrize("resource", ["{tree}/outside/cube.obj", "file://{tree}/outside/cube.obj",
                                      "../outside/cube.obj", "meshes/../../outside/cube.obj"])
@pytest.mark.parametrize("configured", [True, False])
def test_node_refuses_a_real_mesh_outside_its_roots(tree: Path, resource: str, configured: bool) -> None:
    resolver = make_resolver({}, [tree / "roots"]) if configured else None  # None: the current directory
    node = ManagerNode(Bus(), None, resolver=resolver)
    uri = resource.format(tree=tree)
    assert Mesh(uri).watertight  # the same file, named by the library's caller, loads
    with pytest.raises(PfieldError, match="outside the allowed roots") as info:
        node.on_obstacles(_mesh_message(uri))
    assert getattr(info.value, "field", "obstacles[0].mesh_resource") == "obstacles[0].mesh_resource"
    assert node.obstacles() == []


def test_node_reads_meshes_inside_its_roots(tree: Path) -> None:
    node = ManagerNode(Bus(), None, resolver=make_resolver({}, [tree / "roots"]))
    node.on_obstacles(_mesh_message(f"file://{tree}/roots/meshes/cube.obj"))
    node.on_obstacles(_mesh_message("meshes/cube.obj"))
    assert [o.id for o in node.obstacles()] == ["cube"]
