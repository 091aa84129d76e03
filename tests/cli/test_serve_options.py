"""``pfield serve`` option handling, in-process: package paths, ROS parameter files, hosts and tokens."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from pfield_node_server import MESH_PACKAGE

from pfield.cli._node import ServeContext, _check_host, build_nodes, load_ros_parameters, parse_package_paths
from pfield.errors import InvalidInput
from pfield.node._base import Bus


@pytest.fixture(scope="module")
def robot() -> Any:
    from pfield.robot import RobotModel

    return RobotModel.builtin("xarm7")


def test_package_paths(tmp_path: Path) -> None:
    assert parse_package_paths([f"my_robot_description={MESH_PACKAGE}"]) == {
        "my_robot_description": MESH_PACKAGE.resolve()}
    for bad in ("my_robot_description", "=dir", f"pkg={tmp_path / 'missing'}"):
        with pytest.raises(InvalidInput) as info:
            parse_package_paths([bad])
        assert info.value.field == "--package-path"


def test_ros_parameter_files(tmp_path: Path, robot: Any) -> None:
    params = tmp_path / "pfield.yaml"
    params.write_text("pfield_manager:\n  ros__parameters:\n    attractive_gain: 2.5\n    fixed_frame: base\n"
                      "/**:\n  ros__parameters:\n    influence_distance: 0.2\n    not_a_parameter_anywhere: 1\n")
    values = load_ros_parameters(params)
    assert values["/pfield_manager"] == {"attractive_gain": 2.5, "fixed_frame": "base"}
    context = ServeContext(Bus(), robot, {"my_robot_description": MESH_PACKAGE}, [])
    nodes = build_nodes(context, values, None)
    manager = next(node for node in nodes if node.name == "/pfield_manager")
    got = manager.get_parameters()
    assert (got["attractive_gain"], got["fixed_frame"], got["influence_distance"]) == (2.5, "base", 0.2)
    with pytest.raises(InvalidInput) as info:
        build_nodes(context, {"/pfield_manager": {"attractive_gain": -1.0}}, None)
    assert info.value.field == "attractive_gain"
    params.write_text("pfield_manager: {attractive_gain: 2.5}\n")
    with pytest.raises(InvalidInput):
        load_ros_parameters(params)
    params.write_text("pfield_manager: {ros__parameters: {a: [1, 2}\n")
    with pytest.raises(InvalidInput):
        load_ros_parameters(params)


def test_a_section_for_no_node_here_is_warned_with_the_near_name(robot: Any, caplog: pytest.LogCaptureFixture) -> None:
    """Another node's section of a shared file is ignored, as ROS 2 does; a misspelled one names the node meant."""
    context = ServeContext(Bus(), robot, {}, [])
    with caplog.at_level("WARNING", logger="pfield.cli._node"):
        build_nodes(context, {"/pfield_manger": {"attractive_gain": 2.0}, "/camera_driver": {"fps": 30}}, None)
    assert sorted(r.getMessage() for r in caplog.records) == [
        "--params: no node /camera_driver here; its parameters are ignored",
        "--params: no node /pfield_manger here; its parameters are ignored (did you mean /pfield_manager?)"]


@pytest.mark.parametrize(("host", "token", "allowed"), [
    ("127.0.0.1", None, True), ("localhost", None, True), ("::1", None, True),
    ("0.0.0.0", None, False), ("192.168.1.5", None, False), ("0.0.0.0", "s3cret", True),
])
def test_only_loopback_without_a_token(host: str, token: str | None, allowed: bool) -> None:
    if allowed:
        _check_host(host, token)
    else:
        with pytest.raises(InvalidInput):
            _check_host(host, token)
