"""The manipulator demo section, the 3D path plot and the built-in scenes produce real files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from rich.console import Console

from pfield.demo import manipulator
from pfield.errors import InvalidInput
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Mesh
from pfield.planning.scenes import (
    BENCH_GOAL,
    BENCH_START,
    EVALUATION_SCENES,
    evaluation_scene,
    seed_obstacles,
    sphere_line_scene,
)
from pfield.viz.plots import save_path_plot


def test_demo_section_writes_the_pictures_and_the_csv(tmp_path: Path) -> None:
    console = Console(record=True, width=120)
    manipulator.run(tmp_path, console)
    text = console.export_text()
    assert "reached" in text and "t (s)" in text
    for name in ("manipulator_task_space.png", "manipulator_head_on.png"):
        with Image.open(tmp_path / name) as image:
            assert image.size[0] > 1000 and image.size[1] > 500
    rows = (tmp_path / "manipulator_task_space.csv").read_text().splitlines()
    assert rows[0].startswith("time,x,y,z,qx,qy,qz,qw") and len(rows) > 100


def test_path_plot_draws_every_shape(tmp_path: Path) -> None:
    obstacles = seed_obstacles(tmp_path)
    assert {type(o.shape).__name__ for o in obstacles} == {"Sphere", "Box", "Cylinder", "Ellipsoid", "Capsule",
                                                           "Mesh"}
    assert isinstance(obstacles[-1].shape, Mesh) and (tmp_path / "seed_obstacle.stl").exists()
    field = PotentialField(FieldConfig(), BENCH_GOAL)
    target = save_path_plot(field.plan(BENCH_START), tmp_path / "deep" / "plan.png", obstacles, BENCH_GOAL)
    with Image.open(target) as image:
        assert image.format == "PNG"


def test_benchmark_scenes_follow_the_reference_layout() -> None:
    assert [len(evaluation_scene(name)) for name in EVALUATION_SCENES] == [0, 1, 10, 100, 10, 10, 10, 10]
    spheres = evaluation_scene("spheres_10")
    radii = [np.linalg.norm(o.pose.position - (0.45, 0.15, 0.40)) for o in spheres]
    np.testing.assert_allclose(radii, 0.30)
    line = sphere_line_scene(5)
    direction = BENCH_GOAL.position - BENCH_START.position
    for k, obstacle in enumerate(line):
        offset = obstacle.pose.position - BENCH_START.position - (k + 1) / 6 * direction
        assert np.linalg.norm(offset) == pytest.approx(0.05)
        assert np.dot(offset, direction) == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(InvalidInput, match="scene"):
        evaluation_scene("pyramids_3")


def test_path_plot_rejects_bad_input(tmp_path: Path) -> None:
    path = PotentialField(FieldConfig(), BENCH_GOAL).plan(BENCH_GOAL)
    for arguments, name in (({"path": "plan"}, "path"), ({"obstacles": ["ball"]}, "obstacles[0]"),
                            ({"goal": (1, 2, 3)}, "goal")):
        values = {"path": path, "file": tmp_path / "x.png", "obstacles": (), "goal": None} | arguments
        with pytest.raises(InvalidInput) as info:
            save_path_plot(**values)  # type: ignore[arg-type]
        assert info.value.field == name
    assert not (tmp_path / "x.png").exists()
