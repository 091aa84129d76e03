"""pfield's scene files: numbers typed as in ROS messages, the file read within the YAML bounds."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from pfield.errors import InvalidInput
from pfield.scene import load_scene

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "manipulator" / "scene.yaml"
BALL = "{frame_id: ball, type: Sphere, radius: %s, pose: {position: {x: 0.5}}}"


def scene(tmp_path: Path, text: str) -> dict[str, object]:
    (tmp_path / "scene.yaml").write_text(text)
    return load_scene(tmp_path / "scene.yaml", tmp_path)


def test_ints_serve_for_floats(tmp_path: Path) -> None:
    loaded = scene(tmp_path, f"obstacles: [{BALL % 1}]\ndelta_time: 1\ngoal_tolerance: 0\nmax_iterations: 50\n"
                             "params: {attractive_gain: 2}\n")
    assert (loaded["dt"], loaded["goal_tolerance"], loaded["max_iterations"]) == (1.0, 0.0, 50)
    assert loaded["config"].attractive_gain == 2.0  # type: ignore[attr-defined]
    assert loaded["obstacles"][0].shape.radius == 1.0  # type: ignore[index]


@pytest.mark.parametrize(("text", "field", "words"), [
    ('delta_time: "0.02"', "delta_time", "not a string"),
    ("goal_tolerance: true", "goal_tolerance", "not a boolean"),
    ("max_iterations: 25000.0", "max_iterations", "integer"),
    ('max_iterations: "25000"', "max_iterations", "integer"),
    ('params: {attractive_gain: "3"}', "params.attractive_gain", "not a string"),
    (f"obstacles: [{BALL % repr('0.1')}]", "obstacles[0].radius", "not a string"),
    ("start: {position: {x: yes}}", "start.position.x", "not a boolean"),
])
def test_strings_and_booleans_are_not_numbers(text: str, field: str, words: str, tmp_path: Path) -> None:
    with pytest.raises(InvalidInput, match=words) as raised:
        scene(tmp_path, text + "\n")
    assert raised.value.field == field


def test_the_file_is_read_within_the_yaml_bounds(tmp_path: Path) -> None:
    aliases = "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
        f"{name}: &{name} [{', '.join([f'*{below}'] * 10)}]\n" for below, name in zip("abcde", "bcdef", strict=True))
    for text, words in ((aliases, "aliases repeat"), ("[" * 10_000 + "]" * 10_000, "nested deeper than 100"),
                        (b"obstacles: []\n# \xff\n", "not UTF-8 text")):
        path = tmp_path / "bad.yaml"
        path.write_bytes(text.encode() if isinstance(text, str) else text)
        with pytest.raises(InvalidInput, match=words) as raised:
            load_scene(path, tmp_path)
        assert raised.value.field == "scene" and len(str(raised.value)) < 200
    os.mkfifo(tmp_path / "pipe.yaml")
    with pytest.raises(InvalidInput, match="FIFO"):
        load_scene(tmp_path / "pipe.yaml", tmp_path)


def test_the_example_scene_still_loads(tmp_path: Path) -> None:
    loaded = load_scene(EXAMPLE, tmp_path)
    assert [o.id for o in loaded["obstacles"]] == ["ball", "shelf", "post"]  # type: ignore[attr-defined]
    assert (loaded["dt"], loaded["max_iterations"]) == (0.01, 20000)
