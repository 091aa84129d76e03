"""ROS's YAML flow rules for message arguments: defaults, unknown fields, ints for floats (strings and booleans
refused where numbers belong), bad YAML, and the bounds of a document (aliases, nodes, depth, length, files)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

import pfield.interfaces.all  # noqa: F401
from pfield.errors import InvalidInput
from pfield.interfaces import (
    _yaml,
    lookup_service,
    lookup_type,
    message_from_data,
    message_from_yaml,
    message_to_data,
    message_to_yaml,
)
from pfield.interfaces._yaml import ALIAS_ALLOWANCE, MAX_DEPTH, load_yaml, load_yaml_file
from pfield.interfaces.potential_fields_interfaces import ObstacleArray, PlanPath_Request

SPHERE = """{
header: {frame_id: 'world'},
obstacles: [{
frame_id: 'ball', type: 'Sphere', group: 'Static',
pose: {position: {x: 0.4, y: 0.0, z: 0.1}, orientation: {w: 1.0}},
radius: 0.1
}]
}"""


def test_seed_obstacle_fills_ros_defaults() -> None:
    message = message_from_yaml(lookup_type("potential_fields_interfaces/msg/ObstacleArray"), SPHERE)
    assert isinstance(message, ObstacleArray)
    (ball,) = message.obstacles
    assert (ball.frame_id, ball.type, ball.group, ball.radius) == ("ball", "Sphere", "Static", 0.1)
    assert (ball.pose.position.x, ball.pose.orientation.x, ball.pose.orientation.w) == (0.4, 0.0, 1.0)
    assert (ball.height, ball.mesh_resource, ball.scale_x) == (0.0, "", 0.0)
    assert message.header.stamp.sec == 0


def test_integers_are_accepted_for_floats_and_json_works() -> None:
    request = message_from_yaml(PlanPath_Request, '{"goal": {"position": {"x": 1}}, "max_iterations": 7}')
    assert request.goal.position.x == 1.0 and isinstance(request.goal.position.x, float)
    assert request.max_iterations == 7
    assert message_from_yaml(PlanPath_Request, "") == PlanPath_Request()


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("{obstacles: [{radiuss: 0.1}]}", "obstacles[0].radiuss"),
        ("{header: {frame: 'world'}}", "header.frame"),
        ("{obstacles: [{radius: 'big'}]}", "obstacles[0].radius"),
        ("{obstacles: {radius: 0.1}}", "obstacles"),
        ("{obstacles: [{frame_id: 'a'}, 3]}", "obstacles[1]"),
        ("[1, 2]", "message"),
        ("{header: {frame_id: 'world'}", "yaml"),
    ],
)
def test_bad_input_names_the_field(text: str, field: str) -> None:
    with pytest.raises(InvalidInput) as info:
        message_from_yaml(ObstacleArray, text)
    assert info.value.field == field


def test_int_range_is_checked() -> None:
    with pytest.raises(InvalidInput) as info:
        message_from_yaml(PlanPath_Request, "{max_iterations: 3000000000}")
    assert info.value.field == "max_iterations"


def test_round_trip_through_yaml_text() -> None:
    message = message_from_yaml(ObstacleArray, SPHERE)
    assert message_from_yaml(ObstacleArray, message_to_yaml(message)) == message
    assert message_to_data(message)["obstacles"][0]["pose"]["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0,
                                                                                "w": 1.0}


def test_unknown_types_are_rejected() -> None:
    with pytest.raises(InvalidInput, match="unknown message type"):
        lookup_type("potential_fields_interfaces/msg/Nope")
    with pytest.raises(InvalidInput, match="unknown service type"):
        lookup_service("potential_fields_interfaces/srv/Nope")
    assert lookup_service("potential_fields_interfaces/PlanPath").request is PlanPath_Request


# -- ROS's field types: numbers are numbers ------------------------------------------------------------------

@pytest.mark.parametrize(("text", "field", "words"), [
    ('{goal: {position: {x: "0.02"}}}', "goal.position.x", "not a string"),
    ("{goal: {position: {x: true}}}", "goal.position.x", "not a boolean"),
    ("{delta_time: '0.02'}", "delta_time", "not a string"),
    ("{max_iterations: 7.0}", "max_iterations", "must be an integer"),
    ("{max_iterations: '7'}", "max_iterations", "must be an integer"),
    ("{max_iterations: false}", "max_iterations", "must be an integer"),
    ("{goal: {position: {x: 1e400}}}", "goal.position.x", None),  # a number (inf): the node judges it
])
def test_strings_and_booleans_are_refused_where_numbers_belong(text: str, field: str, words: str | None) -> None:
    if words is None:
        assert message_from_yaml(PlanPath_Request, text).goal.position.x == float("inf")
        return
    with pytest.raises(InvalidInput, match=words) as info:
        message_from_yaml(PlanPath_Request, text)
    assert info.value.field == field


def test_exponents_are_numbers_as_in_json_and_yaml_1_2() -> None:
    assert load_yaml("[1e-3, 2E5, -1.5e+2, .5e1, 1.0e5, 1.0e+5, 1_000, 0x10, '1e3', 1e3x]") == [
        0.001, 200000.0, -150.0, 5.0, 100000.0, 100000.0, 1000, 16, "1e3", "1e3x"]
    assert message_from_yaml(PlanPath_Request, '{"delta_time": 2e-2}').delta_time == 0.02


def test_json_strings_and_numbers_for_booleans_are_refused_too() -> None:
    assert PlanPath_Request.model_validate_json('{"delta_time": 1}').delta_time == 1.0
    for body in ('{"delta_time": "0.02"}', '{"max_iterations": "7"}', '{"max_iterations": true}'):
        with pytest.raises(ValueError, match="must be"):
            PlanPath_Request.model_validate_json(body)
    trigger = lookup_service("std_srvs/srv/Trigger").response
    assert message_from_data(trigger, {"success": True}).success is True
    for value in (1, "true", 0.0):
        with pytest.raises(InvalidInput, match="must be a boolean"):
            message_from_data(trigger, {"success": value})


# -- the bounds of a YAML document --------------------------------------------------------------------------

def laughs(levels: int) -> str:
    """Aliases nested ``levels`` deep, each level nine uses of the one below: 9**levels scalars expanded."""
    lines = ["a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for level in range(1, levels):
        name, below = chr(ord("a") + level), chr(ord("a") + level - 1)
        lines.append(f"{name}: &{name} [" + ", ".join([f"*{below}"] * 9) + "]")
    return "\n".join(lines)


def test_aliases_that_save_writing_are_kept() -> None:
    text = "pose: &p {position: {x: 0.5, y: 0.0, z: 0.3}, orientation: {w: 1.0}}\n" + "".join(
        f"o{i}: {{radius: 0.1, pose: *p}}\n" for i in range(40))
    data = load_yaml(text)
    assert data["o39"]["pose"] == data["pose"] == {"position": {"x": 0.5, "y": 0.0, "z": 0.3},
                                                   "orientation": {"w": 1.0}}
    assert load_yaml(laughs(3))["c"][8][8] == ["lol"] * 9  # 800 nodes repeated: within the allowance


def test_a_billion_laughs_is_refused_at_once() -> None:
    started = time.perf_counter()
    with pytest.raises(InvalidInput, match=rf"repeat \d+ nodes, more than the \d+ it writes out plus {ALIAS_ALLOWANCE}"
                       ) as info:
        load_yaml(laughs(9), "scene")
    assert time.perf_counter() - started < 0.5
    assert info.value.field == "scene" and "(at line 4, column" in str(info.value) and len(str(info.value)) < 200


def test_an_alias_inside_the_node_it_names_is_refused() -> None:
    with pytest.raises(InvalidInput, match=r"the alias \*a is used inside the node it names"):
        load_yaml("&a [1, *a]")
    with pytest.raises(InvalidInput, match="undefined alias"):
        load_yaml("a: *nowhere")


def test_the_node_count_and_the_length_are_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_yaml, "MAX_NODES", 100)
    assert len(load_yaml("[" + "0, " * 98 + "0]")) == 99  # 99 scalars and their sequence
    with pytest.raises(InvalidInput, match="expands to more than 100 nodes"):
        load_yaml("[" + "0, " * 99 + "0]")
    monkeypatch.setattr(_yaml, "MAX_BYTES", 1000)
    with pytest.raises(InvalidInput, match="1001 characters long, over the limit of 1000"):
        load_yaml("#" * 1001)


@pytest.mark.parametrize("text", ["[" * 10_000 + "]" * 10_000, "- " * 10_000 + "x", "{a: " * 150 + "1" + "}" * 150,
                                  "a:\n" + "".join(" " * i + "a:\n" for i in range(1, 150))])
def test_deep_documents_are_refused_in_flow_and_block_style(text: str) -> None:
    with pytest.raises(InvalidInput, match=f"nested deeper than {MAX_DEPTH} levels"):
        load_yaml(text)


@pytest.mark.parametrize("text", ["when: 2001-02-30", "n: !!float abc", "n: !!int 0x", "b: !!binary xyz"])
def test_impossible_tagged_values_are_malformed_yaml(text: str) -> None:
    with pytest.raises(InvalidInput, match="malformed YAML"):
        load_yaml(text)


def test_a_file_is_read_only_when_regular_bounded_and_utf8(tmp_path: Path) -> None:
    (tmp_path / "ok.yaml").write_text("a: [1, 2]\n")
    assert load_yaml_file(tmp_path / "ok.yaml", "--params") == {"a": [1, 2]}
    os.mkfifo(tmp_path / "pipe.yaml")
    (tmp_path / "zero.yaml").symlink_to("/dev/zero")
    (tmp_path / "latin1.yaml").write_bytes("a: café\n".encode("latin-1"))
    for name, words in (("pipe.yaml", "FIFO"), ("zero.yaml", "character device"), ("latin1.yaml", "not UTF-8"),
                        ("missing.yaml", "no such file")):
        with pytest.raises(InvalidInput, match=words) as info:
            load_yaml_file(tmp_path / name, "--params")
        assert info.value.field == "--params" and info.value.value == str(tmp_path / name)
