"""``pfield plan``: the seed scene, a scene file, bad scene files (the examples run in ``tests/test_examples.py``)."""

from __future__ import annotations

from pathlib import Path

from PIL import Image
from typer.testing import CliRunner

from pfield.cli import app

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples" / "manipulator"


def test_plan_in_the_seed_scene_writes_png_and_csv(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["plan", "-o", str(tmp_path / "p.png"), "--csv", str(tmp_path / "p.csv")])
    assert result.exit_code == 0, result.output
    assert "reached the goal" in result.output
    with Image.open(tmp_path / "p.png") as image:
        assert image.format == "PNG"
    assert (tmp_path / "p.csv").read_text().startswith("time,")


def test_plan_with_the_example_scene_file(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["plan", "--scene", str(EXAMPLES / "scene.yaml"), "-o", str(tmp_path / "s.png")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "s.png").exists()


def test_a_failed_plan_exits_with_1(tmp_path: Path) -> None:
    scene = tmp_path / "short.yaml"
    scene.write_text("goal: {position: {x: 2.0}, orientation: {w: 1.0}}\nmax_iterations: 3\n")
    result = CliRunner().invoke(app, ["plan", "-s", str(scene), "-o", str(tmp_path / "f.png")])
    assert result.exit_code == 1
    assert "iteration limit" in result.output


def test_bad_scene_files_exit_with_2_naming_the_field(tmp_path: Path) -> None:
    cases = {
        "obstacles: [{frame_id: x, type: Cone}]": "obstacles[0].type",
        "obstacles: [{frame_id: b, type: Sphere, radius: -1}]": "obstacles[0].radius",
        "params: {attractive_gain: -2}": "attractive_gain",
        "goal: {orientation: {w: 0.0}}": "goal.orientation",
        "obstacles: [{frame_id: m, type: Mesh, mesh_resource: /etc/passwd.stl, scale_x: 1, scale_y: 1, scale_z: 1}]":
            "passwd",
        "[1, 2": "scene",
    }
    for text, name in cases.items():
        scene = tmp_path / "bad.yaml"
        scene.write_text(text)
        result = CliRunner().invoke(app, ["plan", "-s", str(scene), "-o", str(tmp_path / "b.png")])
        assert result.exit_code == 2, (text, result.output)
        assert name in result.output.replace("\n", ""), (text, result.output)
    assert not (tmp_path / "b.png").exists()



def _plan_scene(tmp_path: Path, text: str, name: str = "scene.yaml") -> tuple[int, str]:
    scene = tmp_path / name
    scene.parent.mkdir(parents=True, exist_ok=True)
    scene.write_text(text)
    result = CliRunner().invoke(app, ["plan", "-s", str(scene), "-o", str(tmp_path / "u.png")])
    return result.exit_code, " ".join(result.output.split())


def test_unknown_scene_keys_are_refused_naming_the_known_ones(tmp_path: Path) -> None:
    """A misspelled key used to be ignored, and the seed example planned instead (exit 0)."""
    cases = {
        "param: {attractive_gain: 1.0}": ("param", "known: obstacles, start, goal, params, delta_time"),
        "strat: {position: {x: 0.3}}": ("strat", "known: obstacles, start, goal"),
        "params: {atractive_gain: 1.0}": ("params.atractive_gain", "attractive_gain"),
        "goal: {positon: {x: 0.3}}": ("goal.positon", "known: position, orientation"),
        "goal: {position: {x: 0.3, w: 1}}": ("goal.position.w", "known: x, y, z"),
        "obstacles: [{frame_id: b, type: Sphere, radus: 0.1}]": ("obstacles[0].radus", "known: frame_id, type"),
        "obstacles: [{frame_id: b, type: Sphere, radius: 0.1, pose: {orientaton: {w: 1}}}]":
            ("obstacles[0].pose.orientaton", "known: position, orientation"),
    }
    for text, (field, known) in cases.items():
        code, output = _plan_scene(tmp_path, text)
        assert code == 2, (text, output)
        assert field in output and known in output, (text, output)
    assert not (tmp_path / "u.png").exists()


def test_relative_mesh_paths_are_relative_to_the_scene_file(tmp_path: Path, monkeypatch) -> None:
    import shutil

    (tmp_path / "models").mkdir()
    shutil.copy(REPO / "tests" / "data" / "meshes" / "unit_cube.obj", tmp_path / "models" / "wedge.obj")
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    text = ("obstacles: [{frame_id: m, type: Mesh, mesh_resource: ../models/wedge.obj, scale_x: 0.1, "
            "scale_y: 0.1, scale_z: 0.1, pose: {position: {x: 0.5, y: 0.4, z: 0.3}, orientation: {w: 1}}}]\n"
            "start: {position: {x: 0.3, y: 0.0, z: 0.3}, orientation: {w: 1.0}}\n"
            "goal: {position: {x: 0.4, y: 0.0, z: 0.3}, orientation: {w: 1.0}}\n")
    code, output = _plan_scene(tmp_path, text, "scenes/scene.yaml")
    assert code == 0, output
    (tmp_path / "sub").mkdir()
    code, output = _plan_scene(tmp_path, text.replace("../models/wedge.obj", "wedge.obj"), "sub/scene.yaml")
    assert code == 2 and "no such file" in output and str(tmp_path / "sub" / "wedge.obj") in output, output
