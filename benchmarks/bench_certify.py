"""Cost of the planner's certificate (:func:`pfield.planning.certify.certify_path`) per whole-body plan (issue 34).

Data: the MotionBenchMaker problems of ``../shared/benchmarks/mbm/`` (the Panda dev set and the UR5 + Robotiq set;
see their READMEs), extracted to a temporary directory at run time. For the first ``--limit`` problems of each
chosen scene, the whole-body planner runs as the MBM bench runs it (``pfield.scene.MBM_CONFIG``/``mbm_options``, the
joint goal given as ``goal_configuration``); then the returned joint path is certified again, alone, with a fresh
checker (its construction included): the wall time of that call is the certificate's cost per plan. Reported per
robot: median and p95 ms, grid configurations, placements (configurations where exact distances were computed) and
coal calls per plan, and how many plans the certificate refuses (there must be none among the reached).

``python -m benchmarks.bench_certify [--limit N] [--robots NAME ...] [--paths FILE]`` prints the table; with
``--paths /tmp/paths_ROBOT.npz`` the plans are stored on the first run and certified again from there on later runs
(``ROBOT`` becomes the robot's name), so that two versions of the certificate are timed on the same paths.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import yaml

from benchmarks._common import BenchRow
from benchmarks.bench_mbm import extracted_scene_folders
from pfield.field import PotentialField
from pfield.planning.certify import certify_path
from pfield.robot import RobotModel
from pfield.scene import MBM_CONFIG, WORLD_FRAMES, mbm_options, request_from_moveit, scene_obstacles

MBM = Path(__file__).resolve().parents[2] / "shared" / "benchmarks" / "mbm"
UR5 = MBM / "ur5"
ROBOTS = {
    "ur5": (UR5 / "ur5_problems.tar.bz2", ("table_pick_ur5", "box_ur5", "cage_ur5", "bookshelf_tall_ur5"),
            ("base_link",)),
    "panda": (MBM / "panda_problems_dev.tar.bz2", ("table_pick_panda", "box_panda", "bookshelf_small_panda",
                                                   "table_under_pick_panda"), ("panda_link0",)),
}


def _robot(name: str, start: dict[str, float]) -> RobotModel:
    if name == "ur5":
        root = str(UR5) + "/"
        return RobotModel.from_urdf(root + "ur5.urdf", end_effector="tool0", package_paths={"meshes": root + "meshes"},
                                    srdf=root + "ur5.srdf")
    fingers = {k: v for k, v in start.items() if "finger" in k}
    return RobotModel.builtin("panda", locked_joints=fingers)


def measure(name: str, limit: int, paths: Path | None = None) -> list[dict[str, float]]:
    """Plan and certify the first ``limit`` problems of each scene of robot ``name``. ``paths``: an ``.npz`` of the
    joint paths to certify (planned and written there when the file does not exist yet), so that two versions of
    the certificate are timed on the same plans."""
    archive, scenes, frames = ROBOTS[name]
    stored = dict(np.load(paths)) if paths is not None and paths.exists() else None
    planned: dict[str, np.ndarray] = {}
    records: list[dict[str, float]] = []
    robots: dict[tuple[tuple[str, float], ...], RobotModel] = {}
    with extracted_scene_folders(archive) as folders:
        for scene in scenes:
            folder = next(f for f in folders if f.name == scene)
            for request_file in sorted(folder.glob("request[0-9]*.yaml"))[:limit]:
                number = request_file.stem.removeprefix("request")
                scene_data = yaml.safe_load((folder / f"scene{number}.yaml").read_text())
                request = request_from_moveit(yaml.safe_load(request_file.read_text()), (*WORLD_FRAMES, *frames))
                assert request.goal_joints is not None
                key = tuple(sorted((k, v) for k, v in request.start.items() if "finger" in k))
                robot = robots.setdefault(key, _robot(name, request.start))
                start = np.clip([request.start[j] for j in robot.joint_names], robot.lower_limits, robot.upper_limits)
                goal = np.clip([request.goal_joints[j] for j in robot.joint_names], robot.lower_limits,
                               robot.upper_limits)
                obstacles = scene_obstacles(scene_data, (*WORLD_FRAMES, *frames))
                key_name = f"{scene}/{number}"
                if stored is not None:
                    joint_positions, success = stored[key_name], bool(stored[key_name + "/reached"])
                else:
                    field = PotentialField(MBM_CONFIG, robot.forward_kinematics(goal), obstacles)
                    path = field.plan_whole_body(robot, start, options=mbm_options(robot),
                                                 goal_configuration=goal)
                    assert path.joint_positions is not None
                    joint_positions, success = path.joint_positions, path.success
                    planned[key_name], planned[key_name + "/reached"] = joint_positions, np.array(success)
                certificate = certify_path(robot, obstacles, joint_positions)
                records.append({"ms": certificate.seconds * 1e3, "grid": certificate.grid_points,
                                "placements": certificate.placements, "calls": certificate.distance_calls,
                                "reached": float(success), "refused": float(success and not certificate.clear)})
    if paths is not None and stored is None:
        np.savez(paths, **planned)
    return records


SECTION = "Certificate of whole-body plans (exact meshes, 0.01 rad)"


def run(quick: bool) -> list[BenchRow]:
    """Median and p95 cost of the certificate per plan, per robot (1 problem per scene when ``quick``, else 5)."""
    rows = []
    for name in ROBOTS:
        if not ROBOTS[name][0].exists():
            rows.append(BenchRow(SECTION, f"{name}: skipped", 0.0, "", note=f"{ROBOTS[name][0]} not found"))
            continue
        records = measure(name, 1 if quick else 5)
        ms = np.array([r["ms"] for r in records])
        note = (f"{len(records)} plans, {int(sum(r['reached'] for r in records))} reached, "
                f"{int(sum(r['refused'] for r in records))} reached plans refused; median "
                f"{np.median([r['placements'] for r in records]):.0f} placements of "
                f"{np.median([r['grid'] for r in records]):.0f} grid configurations")
        rows.append(BenchRow(SECTION, f"{name}: median per plan", float(np.median(ms)), "ms", note=note))
        rows.append(BenchRow(SECTION, f"{name}: p95 per plan", float(np.percentile(ms, 95)), "ms"))
    return rows


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_certify", description=__doc__.split("\n\n")[0])
    parser.add_argument("--limit", type=int, default=5, help="problems per scene (4 scenes per robot)")
    parser.add_argument("--robots", nargs="*", default=list(ROBOTS), choices=list(ROBOTS))
    parser.add_argument("--paths", type=Path, default=None,
                        help="ROBOT is replaced by the robot's name: certify the joint paths stored in this .npz "
                             "(plan and store them when it does not exist)")
    args = parser.parse_args(argv)
    print("| robot | plans | reached | certificate median ms | p95 ms | grid points | placements | coal calls |"
          " refused reached |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.robots:
        rows = measure(name, args.limit, Path(str(args.paths).replace("ROBOT", name)) if args.paths else None)
        ms = np.array([r["ms"] for r in rows])
        print(f"| {name} | {len(rows)} | {int(sum(r['reached'] for r in rows))} | {np.median(ms):.1f} | "
              f"{np.percentile(ms, 95):.1f} | {np.median([r['grid'] for r in rows]):.0f} | "
              f"{np.median([r['placements'] for r in rows]):.0f} | {np.median([r['calls'] for r in rows]):.0f} | "
              f"{int(sum(r['refused'] for r in rows))} |")


if __name__ == "__main__":
    main()
