"""Demo section: the Panda's whole-body plan around a table and a pitcher as a self-contained 3D page.

Writes ``viewer.html`` into the output folder: open it in a browser (no server needed) to turn the scene
around and watch the arm move along the plan (the 3D viewer's HTML export; needs the ``viewer`` extra).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from rich.console import Console

TITLE = "3D viewer: HTML export"


def write_viewer_html(out_dir: Path) -> Path:
    """Plan the Panda demo (see :mod:`pfield.demo.whole_body`) and write ``out_dir/viewer.html``."""
    from pfield.demo.whole_body import PANDA_CONFIG, PANDA_GOAL, PANDA_OBSTACLES, plan_panda_demo
    from pfield.robot import RobotModel
    from pfield.viz.viewer import export_html

    robot = RobotModel.builtin("panda")
    path, _ = plan_panda_demo(robot)
    return export_html(out_dir / "viewer.html", path, PANDA_OBSTACLES, robot, goal=PANDA_GOAL, config=PANDA_CONFIG)


def run(out_dir: Path, console: Console) -> None:
    if importlib.util.find_spec("viser") is None or importlib.util.find_spec("yourdfpy") is None:
        console.print("viser/yourdfpy not installed: no viewer.html (pip install 'pfield[viewer]')")
        return
    target = write_viewer_html(out_dir)
    console.print(f"3D page of the Panda's whole-body plan: {target} ({target.stat().st_size / 1e6:.1f} MB)")
