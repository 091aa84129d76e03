"""The fitted link model: coverage of the real collision meshes, the fit report, its cache, locked fingers,
the two-level clearances and the MotionBenchMaker harness that uses them."""

from __future__ import annotations

import json
import re
import tarfile
from pathlib import Path

import numpy as np
import pytest

from pfield import errors
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Obstacle, Sphere
from pfield.robot import RobotModel, _fit
from pfield.robot.collision import CollisionChecker, capsule_clearances
from pfield.robot.geometry import fit_table
from pfield.spatial import Pose

ROOT = Path(__file__).resolve().parents[2]
MBM = ROOT.parent / "shared" / "benchmarks" / "mbm" / "panda_problems_dev.tar.bz2"


def _element_points(obj: object) -> np.ndarray:
    """Vertices of one collision element in its joint's frame (box corners for boxes)."""
    shape = obj.geometry  # type: ignore[attr-defined]
    if hasattr(shape, "vertices"):
        local = np.asarray(shape.vertices()).reshape(-1, 3)
    else:
        half = np.asarray(shape.halfSide)
        local = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    placement = obj.placement  # type: ignore[attr-defined]
    return local @ placement.rotation.T + placement.translation


def _outside(points: np.ndarray, a: np.ndarray, b: np.ndarray, r: np.ndarray) -> np.ndarray:
    """How far each point lies outside the union of the capsules (a, b, r): ≤ 0 inside."""
    return _fit.depth_outside(points, _fit.Primitives(a, b, r)).min(axis=1)


@pytest.mark.parametrize("name", ["xarm7", "panda"])
def test_every_collision_vertex_is_inside_the_fitted_primitives(name: str, xarm: RobotModel,
                                                                 panda: RobotModel) -> None:
    robot = xarm if name == "xarm7" else panda
    g = robot.geometry
    links = {link: i for i, link in enumerate(g.link_names)}
    count = 0
    for obj in robot.collision_model.geometryObjects:
        link = links[robot.pinocchio_model.frames[obj.parentFrame].name]
        start, stop = g.link_start[link], g.link_start[link + 1]
        assert stop > start
        assert np.all(g.prim_joint[start:stop] == g.joints[link])
        points = _element_points(obj)
        assert _outside(points, g.prim_a[start:stop], g.prim_b[start:stop], g.prim_r[start:stop]).max() <= 1e-9
        # the bounding capsule contains the primitives' every point too (checked on their ends ± radius)
        count += len(points)
    assert count > 100
    for report in g.fits:
        assert 0.0 <= report.mean_gap <= 0.01  # the documented target: mean gap ≤ 1 cm on every link
        assert report.max_gap >= report.mean_gap
        assert report.volume_ratio >= 1.0
        assert report.spheres + report.capsules == g.link_start[links[report.link] + 1] - g.link_start[
            links[report.link]]


@pytest.mark.parametrize("name", ["xarm7", "panda"])
def test_bounding_capsules_contain_the_primitives(name: str, xarm: RobotModel, panda: RobotModel) -> None:
    robot = xarm if name == "xarm7" else panda
    g = robot.geometry
    rng = np.random.default_rng(3)
    for link in range(len(g.capsules)):
        for p in range(g.link_start[link], g.link_start[link + 1]):
            t = rng.random((50, 1))
            direction = rng.normal(size=(50, 3))
            direction /= np.linalg.norm(direction, axis=1, keepdims=True)
            points = g.prim_a[p] + t * (g.prim_b[p] - g.prim_a[p]) + g.prim_r[p] * direction
            assert _outside(points, g.a[link:link + 1], g.b[link:link + 1], g.radii[link:link + 1]).max() <= 1e-9


def test_fit_of_a_box_covers_it_and_stays_within_the_gap() -> None:
    half = np.array([0.1, 0.05, 0.03])
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    from scipy.spatial import ConvexHull

    surface = _fit.LinkSurface(corners, np.asarray(ConvexHull(corners).simplices), float(np.prod(2 * half)))
    prims = _fit.fit_primitives(surface, 0.01)
    assert len(prims) > 1
    assert _fit.depth_outside(corners, prims).min(axis=1).max() <= 1e-9
    mean_gap, max_gap, ratio = _fit.measure(surface, prims)
    assert max_gap <= 0.01 + 1e-6  # every primitive lies within the gap of the solid
    assert 0.0 < mean_gap < max_gap
    assert ratio > 1.0


def test_fits_are_cached_on_disk(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * 0.02
    from scipy.spatial import ConvexHull

    surface = _fit.LinkSurface(corners, np.asarray(ConvexHull(corners).simplices), 0.04**3)
    monkeypatch.setenv("PFIELD_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_fit, "_MEMORY", {})
    first = _fit.cached_fit(surface, 0.012)
    files = list((tmp_path / "robot-fits").glob("*.npz"))
    assert len(files) == 1
    monkeypatch.setattr(_fit, "_MEMORY", {})
    monkeypatch.setattr(_fit, "fit_link", lambda *args: pytest.fail("refitted instead of reading the cache"))
    second = _fit.cached_fit(surface, 0.012)
    np.testing.assert_array_equal(second.primitives.a, first.primitives.a)
    np.testing.assert_array_equal(second.primitives.radii, first.primitives.radii)
    assert second.mean_gap == first.mean_gap


@pytest.mark.parametrize("name", ["xarm7", "panda"])
def test_docs_table_is_the_fit(name: str, xarm: RobotModel, panda: RobotModel) -> None:
    robot = xarm if name == "xarm7" else panda
    text = (ROOT / "docs" / "robots.md").read_text()
    block = re.search(rf"<!-- fit-table {name} -->\n(.*?)\n<!-- /fit-table -->", text, re.S)
    assert block is not None, f"docs/robots.md has no fit table for {name}"
    assert block.group(1).strip() == fit_table(robot.geometry)


def test_locked_fingers_move_the_finger_links(panda: RobotModel) -> None:
    wide = RobotModel.builtin("panda", locked_joints={"panda_finger_joint1": 0.065, "panda_finger_joint2": 0.065})
    assert wide.joint_names == panda.joint_names
    q = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    spread = []
    for robot in (panda, wide):
        g = robot.geometry
        rotations, origins = robot.joint_frames(q)
        centres = {}
        for link in ("panda_leftfinger", "panda_rightfinger"):
            i = g.link_names.index(link)
            j = g.joints[i]
            centres[link] = rotations[j] @ (0.5 * (g.a[i] + g.b[i])) + origins[j]
        spread.append(np.linalg.norm(centres["panda_leftfinger"] - centres["panda_rightfinger"]))
    assert spread[1] - spread[0] == pytest.approx(2 * 0.025, abs=1e-4)  # each finger 2.5 cm further out
    with pytest.raises(errors.InvalidInput, match="panda_finger_joint1"):
        RobotModel.builtin("panda", locked_joints={"panda_finger_joint1": float("nan")})
    with pytest.raises(errors.InvalidInput, match="no_such_joint"):
        RobotModel.builtin("panda", locked_joints={"no_such_joint": 0.0})


def test_clearances_are_the_minimum_over_each_links_primitives(xarm: RobotModel) -> None:
    from pfield._core import robot_distance
    from pfield.geometry import pack_obstacles
    from pfield.planning._whole_body_core import core_obstacles
    from pfield.planning.whole_body import make_scene

    fine_range = 0.1  # (m) src/core/robot/clearance.hpp's kFineRange: nearer, the fitted primitives answer
    q = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])
    obstacles = [Obstacle("ball", Sphere(0.03), Pose((0.35, 0.05, 0.4))),
                 Obstacle("box", Box(0.1, 0.2, 0.05), Pose((0.3, -0.1, 0.3), (0.0, 0.0, 0.38268343, 0.92387953)))]
    clearances = capsule_clearances(xarm, q, obstacles)
    obstacle, own = clearances.obstacle, clearances.self_pairs
    obstacle_set = core_obstacles(make_scene(pack_obstacles(obstacles)))
    g = xarm.geometry
    rotations, origins = xarm.joint_frames(q)
    near = 0
    for i in range(len(obstacles)):
        for link in range(len(g.capsules)):
            best = np.inf
            for p in range(g.link_start[link], g.link_start[link + 1]):
                j = g.prim_joint[p]
                a = g.prim_a[p] if j < 0 else rotations[j] @ g.prim_a[p] + origins[j]
                b = g.prim_b[p] if j < 0 else rotations[j] @ g.prim_b[p] + origins[j]
                d = robot_distance.segment_obstacle_distance(obstacle_set, i, a, b).distance
                best = min(best, d - g.prim_r[p])
            assert obstacle[link, i] <= best + 1e-9  # never more than the fitted model's distance
            if obstacle[link, i] < fine_range:  # near: exactly the fitted model's
                assert obstacle[link, i] == pytest.approx(best, abs=1e-9)
                near += 1
    assert near >= 2
    assert own.shape == (len(g.self_pairs),)


def test_a_start_the_meshes_clear_is_not_refused_when_the_fitted_model_overlaps(panda: RobotModel) -> None:
    q = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    tip = panda.forward_kinematics(q).position
    # a table top 3 mm below the lowest point of the meshes: the fitted model (up to 1.4 cm out) overlaps it
    table = Obstacle("table", Box(1.0, 1.0, 0.1), Pose((tip[0], tip[1], 0.0)))
    lowest = CollisionChecker(panda, [table]).distances(q)[0]
    table = Obstacle("table", Box(1.0, 1.0, 0.1), Pose((tip[0], tip[1], lowest - 0.003)))
    checker = CollisionChecker(panda, [table])
    assert not checker.check(q).in_collision
    fitted = capsule_clearances(panda, q, [table]).obstacle
    assert fitted.min() < 0.0
    goal = Pose(tip + np.array([0.0, 0.1, 0.05]), panda.forward_kinematics(q).orientation)
    config = FieldConfig(max_linear_velocity=0.25, safety_distance=0.002, influence_distance=0.05)
    path = PotentialField(config, goal, [table]).plan_whole_body(panda, q, 0.02, 0.01, 300)
    assert len(path) > 1  # planned, not refused at the start
    assert not path.failure_reason.startswith("collision: the start")
    assert path.joint_positions is not None
    for waypoint in path.joint_positions[::10]:
        assert not checker.check(waypoint).in_collision


# ---- the MotionBenchMaker harness ----------------------------------------------------------------------------
def _mini_archive(tmp_path: Path) -> Path:
    with tarfile.open(MBM) as source:
        members = {m.name: m for m in source.getmembers()}
        out = tmp_path / "mini.tar.bz2"
        with tarfile.open(out, "w:bz2") as target:
            for stem in ("scene0001", "request0001", "scene0002", "request0002"):
                member = members[f"problems/table_pick_panda/{stem}.yaml"]
                data = source.extractfile(member)
                member.name = f"problems/mini_scene/{stem}.yaml"
                target.addfile(member, data)
    return out


@pytest.mark.skipif(not MBM.exists(), reason="the MotionBenchMaker archive is not in ../shared")
def test_mbm_harness_writes_one_record_per_problem(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import sys

    sys.path.insert(0, str(ROOT))
    from benchmarks import bench_mbm

    archive, out = _mini_archive(tmp_path), tmp_path / "out.jsonl"
    bench_mbm.main(["--archive", str(archive), "--limit", "1", "--out", str(out)])
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(records) == 1
    record = records[0]
    assert record["scene"] == "mini_scene" and record["index"] == 1 and record["planner"] == "field"
    assert record["fingers"] == {"panda_finger_joint1": 0.065, "panda_finger_joint2": 0.065}
    assert record["joint_names"] == [f"panda_joint{i}" for i in range(1, 8)]
    assert len(record["positions"]) == len(record["times"]) >= 1
    assert record["times"][0] == 0.0
    assert record["start_clear"] and record["goal_clear"]
    assert record["status"] in {"reached", "stagnation", "iteration_limit", "collision", "self_collision"}
    assert record["success"] == (record["status"] == "reached")
    assert "mini_scene: success rate" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        bench_mbm.main(["--archive", str(archive), "--scenes", "nothing", "--out", str(tmp_path / "x.jsonl")])
    with pytest.raises(SystemExit):
        bench_mbm.main(["--archive", str(tmp_path / "missing.tar.bz2"), "--out", str(tmp_path / "x.jsonl")])


def test_mbm_status_names_follow_the_failure_reason() -> None:
    import sys
    from types import SimpleNamespace

    sys.path.insert(0, str(ROOT))
    from benchmarks.bench_mbm import status_name

    cases = {"": "reached", "stagnation: no progress": "stagnation", "iteration limit: 10 steps": "iteration_limit",
             "collision: the start configuration collides (a/b)": "start_invalid",
             "collision: the next step would bring link 'x' into contact": "collision",
             "self-collision: the next step would bring two links into contact": "self_collision"}
    for reason, expected in cases.items():
        path = SimpleNamespace(success=not reason, failure_reason=reason)
        assert status_name(path) == expected  # type: ignore[arg-type]
    with_status = SimpleNamespace(success=False, failure_reason="x", status=SimpleNamespace(name="GOAL_INVALID"))
    assert status_name(with_status) == "goal_invalid"  # type: ignore[arg-type]
