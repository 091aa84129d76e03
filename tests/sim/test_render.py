"""A frame of the simulation rendered offscreen (EGL here) into a PNG that shows the scene."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pfield.errors import InvalidInput
from pfield.geometry import Box, Obstacle
from pfield.robot import RobotModel
from pfield.sim import Simulation, render_frame
from pfield.spatial import Pose


def test_a_frame_is_written_and_shows_the_robot_and_the_obstacle(panda: RobotModel, tmp_path: Path) -> None:
    box = Obstacle("crate", Box(length=0.2, width=0.2, height=0.2), Pose((0.5, 0.3, 0.1)))
    sim = Simulation(panda, [box], q0=panda.named_configuration("ready"))
    target = render_frame(sim, tmp_path / "frames" / "f.png", width=160, height=120,
                          trail=[[0.3, 0.0, 0.5], [0.35, 0.0, 0.5]])
    pixels = np.asarray(Image.open(target).convert("RGB"), dtype=np.float64)
    assert pixels.shape == (120, 160, 3)
    grey = (np.abs(pixels[..., 0] - pixels[..., 2]) < 12) & (pixels.mean(axis=2) > 150)  # the robot's light grey
    orange = (pixels[..., 0] > pixels[..., 2] + 40) & (pixels[..., 0] > 90)  # the obstacle
    assert grey.sum() > 50 and orange.sum() > 50
    # without the obstacle the orange is gone: the picture is of this scene
    empty = render_frame(Simulation(panda, q0=panda.named_configuration("ready")), tmp_path / "e.png", width=160,
                         height=120)
    pixels = np.asarray(Image.open(empty).convert("RGB"), dtype=np.float64)
    assert ((pixels[..., 0] > pixels[..., 2] + 40) & (pixels[..., 0] > 90)).sum() == 0


def test_the_default_camera_frames_the_robot_and_every_obstacle(panda: RobotModel, tmp_path: Path) -> None:
    """The camera looked at a fixed point 2 m away: a taller robot (the UR5 on its stand) or a far obstacle fell
    out of the picture. By default it frames them all."""
    far = Obstacle("crate", Box(length=0.3, width=0.3, height=0.3), Pose((2.5, -2.0, 0.15)))
    sim = Simulation(panda, [far], q0=panda.named_configuration("ready"))
    pixels = np.asarray(Image.open(render_frame(sim, tmp_path / "f.png", width=320, height=240)).convert("RGB"),
                        dtype=np.float64)
    grey = (np.abs(pixels[..., 0] - pixels[..., 2]) < 12) & (pixels.mean(axis=2) > 150)
    orange = (pixels[..., 0] > pixels[..., 2] + 40) & (pixels[..., 0] > 90)
    assert grey.sum() > 20 and orange.sum() > 20
    fixed = np.asarray(Image.open(render_frame(sim, tmp_path / "g.png", width=160, height=120,
                                               lookat=(0.35, 0.0, 0.35), distance=2.0)).convert("RGB"), dtype=float)
    assert ((fixed[..., 0] > fixed[..., 2] + 40) & (fixed[..., 0] > 90)).sum() == 0  # the old view missed it


@pytest.mark.parametrize(("keyword", "value", "field"), [("width", 8, "width"), ("height", 2.5, "height"),
                                                         ("distance", 0.0, "distance"),
                                                         ("lookat", (0.0, np.nan, 0.0), "lookat"),
                                                         ("trail", [[0.0, 0.0]], "trail")])
def test_bad_render_input_is_refused(panda: RobotModel, tmp_path: Path, keyword: str, value: object,
                                     field: str) -> None:
    sim = Simulation(panda)
    with pytest.raises(InvalidInput, match=field):
        render_frame(sim, tmp_path / "x.png", **{keyword: value})  # type: ignore[arg-type]
    assert not (tmp_path / "x.png").exists()
