"""A robot's first fit (issue 33 item 5): which link it is on, which link and file a mesh warning is about, and a
node that is not ready before its robot's link model is."""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from pfield import warmup
from pfield.robot import RobotDescription, RobotModel, _fit
from pfield.robot import geometry as robot_geometry
from pfield.robot.geometry import _link_surfaces, fit_robot_geometry

UR5 = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "mbm" / "ur5"

TWO_BOXES = """<robot name="two_boxes">
  <link name="base"><collision><geometry><box size="0.2 0.1 0.05"/></geometry></collision></link>
  <link name="arm"><collision><origin xyz="0.1 0 0"/><geometry><box size="0.2 0.04 0.04"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


@pytest.fixture
def fresh_fits(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty fit cache (on disk and in memory): every link is fitted anew."""
    monkeypatch.setattr(_fit, "fit_cache_directory", lambda: tmp_path)
    monkeypatch.setattr(_fit, "_MEMORY", {})
    return tmp_path


def test_fitting_logs_each_link_it_fits_with_its_place(tmp_path: Path, fresh_fits: Path,
                                                      caplog: pytest.LogCaptureFixture) -> None:
    urdf = tmp_path / "two_boxes.urdf"
    urdf.write_text(TWO_BOXES)
    with caplog.at_level(logging.INFO, logger="pfield.robot._fit"):
        fit_robot_geometry(RobotModel.from_urdf(urdf, "arm"))
    fitting = [r.getMessage() for r in caplog.records if r.getMessage().startswith("fitting link")]
    assert fitting == ["fitting link 1/2 base (box): 12 triangles", "fitting link 2/2 arm (box): 12 triangles"]
    assert sum(r.getMessage().startswith("fitted link") for r in caplog.records) == 2
    assert len(list(fresh_fits.glob("*.npz"))) == 2
    caplog.clear()
    _fit._MEMORY.clear()  # read from the disk cache now: nothing is fitted, nothing is said
    with caplog.at_level(logging.INFO, logger="pfield.robot._fit"):
        again = fit_robot_geometry(RobotModel.from_urdf(urdf, "arm"))
    assert not [r for r in caplog.records if "fit" in r.getMessage()]
    assert len(again.fits) == 2


@pytest.mark.skipif(not UR5.exists(), reason="the UR5 files are not in ../shared")
def test_the_ur5_mesh_warning_names_the_link_and_its_file(fresh_fits: Path, caplog: pytest.LogCaptureFixture) -> None:
    robot = RobotModel.from_urdf(UR5 / "ur5.urdf", "ee_link", {"meshes": UR5 / "meshes"}, srdf=UR5 / "ur5.srdf")
    surface = _link_surfaces(robot)["fts_robotside"][2]
    with caplog.at_level(logging.INFO):
        fit = _fit.cached_fit(surface, progress="9/18")
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    mesh = str((UR5 / "meshes" / "robotiq_fts300.stl").resolve())
    assert warnings == [f"mesh memory://fts_robotside ({mesh}) is not watertight: its distance is unsigned "
                        "(never negative: a point inside reads as outside); close its surface if it bounds a solid "
                        "obstacle (a robot link's mesh needs nothing: the link's fit covers its surface)"]
    # once a link (the fit and its measures share the mesh)
    assert f"fitting link 9/18 fts_robotside ({mesh}): 43473 triangles" in caplog.messages
    assert fit.max_gap <= 0.017 and fit.mean_gap <= 0.01


def test_health_is_not_ready_until_the_robot_link_model_is(monkeypatch: pytest.MonkeyPatch) -> None:
    from pfield.cli._node import nodes_from_options
    from pfield.transport.http import ServerThread, create_app

    kernels_warm = threading.Event()
    kernels_warm.set()  # the kernels count as warm here: only the robot's link model is waited for
    monkeypatch.setattr(warmup, "_READY", kernels_warm)
    monkeypatch.setattr(warmup, "_FITTED", [])
    release, fit_started = threading.Event(), threading.Event()
    real_fit = robot_geometry.fit_robot_geometry

    def fit_when_released(robot: RobotModel, *args: object, **kwargs: object) -> object:
        fit_started.set()
        assert release.wait(120)
        return real_fit(robot, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(robot_geometry, "fit_robot_geometry", fit_when_released)
    nodes = nodes_from_options(RobotDescription("xarm7"), None, None, None, None, None)
    robot = next(n.robot for n in nodes if hasattr(n, "robot"))
    with ServerThread(create_app(nodes, ready=warmup.ready)) as server:
        assert fit_started.wait(60)
        health = httpx.get(f"{server.url}/health").json()
        assert health["ready"] is False and "geometry" not in vars(robot)
        release.set()
        deadline = time.monotonic() + 120
        while not (health := httpx.get(f"{server.url}/health").json())["ready"]:
            assert time.monotonic() < deadline, "the node never became ready"
            time.sleep(0.05)
        assert "geometry" in vars(robot) and len(robot.geometry.fits) == len(robot.geometry.capsules)
        assert np.all(robot.geometry.prim_r > 0.0)
