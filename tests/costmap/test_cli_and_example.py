"""The shipped example map, ``pfield find-valid-pose`` and the costmap node factory of ``pfield serve``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml
from typer.testing import CliRunner

from pfield.cli import app
from pfield.cli._costmap import _serve_costmap
from pfield.cli._node import ServeContext
from pfield.costmap import load_map
from pfield.costmap._example import draw_example_map, example_map_path
from pfield.node._base import Bus
from pfield.node.costmap_server import CostmapServer

ROBOT = "[[0.4, 0.25], [-0.4, 0.25], [-0.4, -0.25], [0.4, -0.25]]"


def test_shipped_example_map_matches_its_generator() -> None:
    shipped = load_map(example_map_path())
    drawn = draw_example_map()
    np.testing.assert_array_equal(shipped.data, drawn.data)
    assert shipped.origin == drawn.origin and shipped.resolution == drawn.resolution


def test_find_valid_pose_cli_writes_answer_and_png(tmp_path: Path) -> None:
    png = tmp_path / "table.png"
    result = CliRunner().invoke(app, ["find-valid-pose", "--x", "-1.0", "--y", "-1.6", "--footprint", ROBOT,
                                      "--dist-tolerance", "1.0", "--angle-tolerance", "1.57", "-o", str(png)])
    assert result.exit_code == 0, result.output
    answer = yaml.safe_load(result.stdout)
    assert answer["state_name"] == "INSCRIBED" and answer["state"] == 1
    assert answer["pose"]["pose"]["position"]["y"] == -2.25  # the table's edge at y = -2.0 minus half the width
    assert png.stat().st_size > 10_000


def test_find_valid_pose_cli_bad_input(tmp_path: Path) -> None:
    runner = CliRunner()
    bad = runner.invoke(app, ["find-valid-pose", "--x", "0", "--y", "0", "--dist-tolerance", "-1",
                              "-o", str(tmp_path / "x.png")])
    assert bad.exit_code == 2 and "dist_tolerance" in bad.output
    missing = runner.invoke(app, ["find-valid-pose", "--x", "0", "--y", "0", "--map", str(tmp_path / "no.yaml")])
    assert missing.exit_code == 2 and "no.yaml" in missing.output
    footprint = runner.invoke(app, ["find-valid-pose", "--x", "0", "--y", "0", "--footprint", "[[0, 0], [1, 1]]"])
    assert footprint.exit_code == 2 and "footprint" in footprint.output


def test_serve_factory_builds_costmap_node() -> None:
    context = ServeContext(Bus(), None, {}, [], example_map_path(), ROBOT)
    (node,) = _serve_costmap(context)
    assert isinstance(node, CostmapServer) and node.params.footprint == ROBOT
    assert node.costmap is not None and node.costmap.size_x == 200
    bare = _serve_costmap(ServeContext(Bus(), None, {}, []))[0]
    assert isinstance(bare, CostmapServer) and bare.costmap is None


def test_find_valid_pose_help_shows_the_footprint_format() -> None:
    result = CliRunner().invoke(app, ["find-valid-pose", "--help"], env={"COLUMNS": "200", "TERMINAL_WIDTH": "200"})
    assert result.exit_code == 0
    assert "nav2 footprint '[[x, y], ...]'" in result.output  # not eaten as rich markup
