"""``pfield plot2d`` and ``pfield sim2d`` write real, non-blank pictures."""

from __future__ import annotations

import numpy as np
from PIL import Image
from typer.testing import CliRunner

from pfield.cli import app

runner = CliRunner()
SEED_PLOTS = ["profile_repulsive", "profile_attractive", "profile_both", "profile_coincident",
              "field_grid_blocked", "field_grid_pass"]


def _assert_not_blank(path_or_image, min_colours=20):
    opened = path_or_image if isinstance(path_or_image, Image.Image) else Image.open(path_or_image)
    image = np.asarray(opened.convert("RGB"), dtype=float)
    assert image.shape[0] > 200 and image.shape[1] > 200
    assert image.std() > 10.0  # not a flat image
    assert len(np.unique(image.reshape(-1, 3), axis=0)) >= min_colours


def test_plot2d_writes_the_seed_plots(tmp_path):
    result = runner.invoke(app, ["plot2d", "--output-dir", str(tmp_path)])
    assert result.exit_code == 0, result.output
    for name in SEED_PLOTS:
        _assert_not_blank(tmp_path / f"{name}.png")


def test_sim2d_writes_png_and_animated_gif(tmp_path):
    result = runner.invoke(app, ["sim2d", "doorway", "--drive", "diff_drive", "--output-dir", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "goal_reached" in result.output
    _assert_not_blank(tmp_path / "sim2d_doorway_diff_drive.png")
    gif = Image.open(tmp_path / "sim2d_doorway_diff_drive.gif")
    assert gif.n_frames > 10
    gif.seek(gif.n_frames - 1)
    _assert_not_blank(gif, min_colours=5)


def test_sim2d_exit_code_says_whether_the_run_ended_as_the_scenario_expects(tmp_path):
    """0 for the expected outcome (grid_blocked is documented to end stuck), 1 for any other: a script can tell."""
    blocked = runner.invoke(app, ["sim2d", "grid_blocked", "--no-gif", "--output-dir", str(tmp_path)])
    assert blocked.exit_code == 0 and "stuck" in blocked.output, blocked.output
    short = tmp_path / "short.yaml"  # 6 m to go at most 1 m/s in 2 s: a timeout
    short.write_text("name: short\nstart: [0, 0, 0]\ngoal: [6, 0]\nduration: 2\n")
    timed_out = runner.invoke(app, ["sim2d", str(short), "--no-gif", "--output-dir", str(tmp_path)])
    assert timed_out.exit_code == 1 and "timeout" in timed_out.output, timed_out.output
    assert (tmp_path / "sim2d_short_holonomic.png").is_file()  # the picture of a failed run is written too
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text("name: wrong\nstart: [0, 0, 0]\ngoal: [6, 0]\nexpected: arrived\n")
    refused = runner.invoke(app, ["sim2d", str(wrong), "--no-gif", "--output-dir", str(tmp_path)])
    assert refused.exit_code == 2 and "expected" in refused.output and "arrived" in refused.output, refused.output


def test_sim2d_bad_input_fails_cleanly(tmp_path):
    unknown = runner.invoke(app, ["sim2d", "nowhere", "--output-dir", str(tmp_path)])
    assert unknown.exit_code == 2 and "nowhere" in unknown.output
    drive = runner.invoke(app, ["sim2d", "grid_pass", "--drive", "hover", "--output-dir", str(tmp_path)])
    assert drive.exit_code == 2 and "drive" in drive.output
    listing = runner.invoke(app, ["sim2d", "--list"])
    assert listing.exit_code == 0 and "grid_blocked" in listing.output
