"""MotionBenchMaker Panda problems solved by whole-body potential-field planning (a baseline, no target).

Data: ``../shared/benchmarks/mbm/panda_problems_dev.tar.bz2`` (4 scenes × 100 problems; see its README),
extracted to a temporary directory at run time and never copied into the project. Each problem is a MoveIt
PlanningScene (boxes and cylinders; cylinder dimensions are [height, radius]) and a MotionPlanRequest
(start joints including the two finger joints, joint-space goal). The fingers are locked at the request's
values (0.065 m per finger in every MBM request: wider than the URDF's 0.04 m limit, as the data set's
robot allows; at 0.04 m the fingers intersect the objects being grasped). pfield plans whole-body from the
start joints to the goal *pose* = FK of the goal joints at the Panda's TCP (``panda_hand_tcp``), dt 0.02,
tolerance 1 cm (and 0.05 rad), at most 10000 steps. Parameters: rosYaml except max_linear_velocity 0.25 m/s,
max_angular_velocity 1.0 rad/s, rotational_attractive_gain 0.6 and max_angular_acceleration 1.0 (the seed's 5
cm/s makes every plan slow), safety_distance 2 mm and influence_distance 5 cm (MBM goals are grasp poses next
to objects), stagnation_window 0.5 s (``pfield.scene.MBM_CONFIG``). Reported per scene: success rate, median
planning time, the status counts, median end-effector path length of the successful plans, the minimum link-
model clearance over all plans (negative where a start's fitted model already overlaps an obstacle: such pairs
may not approach further), the exact minimum distance of the robot's collision meshes (coal, convex hulls) at
every 25th waypoint, and how many starts/goals the exact meshes clear.

Scriptable: ``python -m benchmarks.bench_mbm --archive PATH.tar.bz2 [--scenes NAME ...] [--limit N]
--out FILE.jsonl`` plans the problems of every scene folder of any archive in this format and writes one
JSON object per problem (see :func:`solve`). ``make bench`` builds its summary table from the same code.
Sampling planners solve all of these (REFERENCE §5); a potential field is local and is not expected to.
"""

from __future__ import annotations

import argparse
import json
import tarfile
import tempfile
import time
from collections import Counter
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from benchmarks._common import BenchRow
from pfield.field import PotentialField
from pfield.geometry import Obstacle
from pfield.planning.result import PlannedPath
from pfield.robot import RobotModel
from pfield.robot.collision import CollisionChecker
from pfield.scene import MBM_CONFIG, MBM_OPTIONS, WORLD_FRAMES, request_from_moveit, scene_folders
from pfield.scene import scene_obstacles as moveit_obstacles

SECTION = "MotionBenchMaker Panda baseline (whole-body potential field)"
ARCHIVE = Path(__file__).resolve().parents[2] / "shared" / "benchmarks" / "mbm" / "panda_problems_dev.tar.bz2"
SCENES = ("table_pick_panda", "table_under_pick_panda", "box_panda", "bookshelf_small_panda")
CONFIG = MBM_CONFIG
ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGER_JOINTS = ("panda_finger_joint1", "panda_finger_joint2")
DT, TOLERANCE, MAX_STEPS = MBM_OPTIONS.dt, MBM_OPTIONS.goal_tolerance, MBM_OPTIONS.max_iterations


def scene_obstacles(scene: dict[str, Any]) -> list[Obstacle]:
    """Obstacles of a MoveIt PlanningScene (:func:`pfield.scene.scene_obstacles`; the Panda's base is the world)."""
    return moveit_obstacles(scene, (*WORLD_FRAMES, "panda_link0"))


def request_joints(request: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """(start, goal) arm joint angles of a MotionPlanRequest (:func:`pfield.scene.request_from_moveit`)."""
    parsed = request_from_moveit(request)
    assert parsed.goal_joints is not None, "MBM goals are joint goals"
    return (np.array([parsed.start[j] for j in ARM_JOINTS]), np.array([parsed.goal_joints[j] for j in ARM_JOINTS]))


def read_problem(directory: Path, index: int, joints: Sequence[str], base_link: str
                 ) -> tuple[np.ndarray, np.ndarray, list[Obstacle], dict[str, float]]:
    """(start, goal, obstacles, the request's other start joints) of problem ``index`` of an MBM scene folder, for
    any robot: ``joints`` are the planned joints in order, ``base_link`` the robot's root (taken as the world, as
    MBM's robots stand at the origin). The other start joints are e.g. the Panda's fingers or the Robotiq joints
    (fixed joints in the UR5's URDF)."""
    frames = (*WORLD_FRAMES, base_link)
    scene = yaml.safe_load((directory / f"scene{index:04d}.yaml").read_text())
    parsed = request_from_moveit(yaml.safe_load((directory / f"request{index:04d}.yaml").read_text()), frames)
    assert parsed.goal_joints is not None, "MBM goals are joint goals"
    start = np.array([parsed.start[j] for j in joints])
    goal = np.array([parsed.goal_joints[j] for j in joints])
    others = {name: value for name, value in parsed.start.items() if name not in joints}
    return start, goal, moveit_obstacles(scene, frames), others


def request_fingers(request: dict[str, Any]) -> dict[str, float]:
    """The finger joint values of the request's start state (locked for the whole plan)."""
    start = request_from_moveit(request).start
    return {name: start[name] for name in FINGER_JOINTS if name in start}


def status_name(path: PlannedPath) -> str:
    """The plan's status in lower case: ``path.status`` when the path carries one, else read from the reason."""
    status = getattr(path, "status", None)
    if status is not None:
        return str(status.name).lower()
    if path.success:
        return "reached"
    reason = path.failure_reason
    if reason.startswith("collision: the start"):
        return "start_invalid"
    return reason.split(":")[0].strip().replace(" ", "_").replace("-", "_")


class Robots:
    """Panda models by finger opening (each built once; the link fit is cached across them)."""

    def __init__(self, target_gap: float | None = None, one_capsule: bool = False) -> None:
        self._models: dict[tuple[tuple[str, float], ...], RobotModel] = {}
        self._target_gap, self._one_capsule = target_gap, one_capsule

    def get(self, fingers: dict[str, float]) -> RobotModel:
        key = tuple(sorted(fingers.items()))
        if key not in self._models:
            robot = RobotModel.builtin("panda", locked_joints=fingers)
            if self._target_gap is not None or self._one_capsule:
                robot.refit(self._target_gap, one_capsule=self._one_capsule)
            self._models[key] = robot
        return self._models[key]


def solve(robots: Robots, directory: Path, index: int) -> dict[str, Any]:
    """Plan problem ``index`` of the scene folder ``directory``; the JSON record of the result.

    Keys: ``scene`` (folder name), ``index``, ``success``, ``status``, ``seconds`` (planning wall time),
    ``cpu_seconds`` (its CPU time: the machine may be shared), ``steps``, ``planner``, ``joint_names``,
    ``positions`` (joint vectors from the start on), ``times`` (s), and ``fingers``,
    ``start_clear``/``goal_clear`` (the exact meshes clear the start/goal joints),
    ``path_length`` (m), ``min_clearance`` (m, link model), ``mesh_min_distance`` (m, coal, every 25th
    waypoint and the last).
    """
    scene = yaml.safe_load((directory / f"scene{index:04d}.yaml").read_text())
    request = yaml.safe_load((directory / f"request{index:04d}.yaml").read_text())
    fingers = request_fingers(request)
    robot = robots.get(fingers)
    start, goal_joints = request_joints(request)
    # a few MBM states lie just outside example-robot-data's Panda limits (MoveIt's differ): clip onto them
    start = np.clip(start, robot.lower_limits, robot.upper_limits)
    goal_joints = np.clip(goal_joints, robot.lower_limits, robot.upper_limits)
    obstacles = scene_obstacles(scene)
    field = PotentialField(CONFIG, robot.forward_kinematics(goal_joints), obstacles)
    begin, cpu = time.perf_counter(), time.process_time()
    path = field.plan_whole_body(robot, start, DT, TOLERANCE, MAX_STEPS, global_fallback=False)  # the field alone
    seconds, cpu = time.perf_counter() - begin, time.process_time() - cpu
    assert path.joint_positions is not None
    checker = CollisionChecker(robot, obstacles)
    samples = [*path.joint_positions[::25], path.joint_positions[-1]]
    return {
        "scene": directory.name, "index": index, "success": bool(path.success), "status": status_name(path),
        "seconds": seconds, "cpu_seconds": cpu, "steps": int(path.iterations), "planner": path.planner,
        "joint_names": list(robot.joint_names),
        "positions": path.joint_positions.tolist(), "times": path.times.tolist(), "fingers": fingers,
        "start_clear": not checker.check(start).in_collision, "goal_clear": not checker.check(goal_joints).in_collision,
        "path_length": float(np.linalg.norm(np.diff(path.positions, axis=0), axis=1).sum()),
        "min_clearance": float(path.min_clearance), "mesh_min_distance": min(checker.distances(q)[0] for q in samples),
    }


def problem_indices(directory: Path) -> list[int]:
    return sorted(int(p.stem.removeprefix("request")) for p in directory.glob("request[0-9][0-9][0-9][0-9].yaml")
                  if (directory / f"scene{p.stem.removeprefix('request')}.yaml").exists())


@contextmanager
def extracted_scene_folders(archive: Path) -> Iterator[list[Path]]:
    """The scene folders of a MotionBenchMaker archive (:func:`pfield.scene.scene_folders`), extracted into a
    temporary directory that lives as long as the ``with`` block: the one reader of the archives for every bench."""
    with tempfile.TemporaryDirectory() as tmp:
        with tarfile.open(archive) as opened:
            opened.extractall(tmp, filter="data")
        yield scene_folders(Path(tmp))


def run_archive(archive: Path, scenes: Sequence[str] | None = None, limit: int | None = None,
                robots: Robots | None = None) -> Iterator[dict[str, Any]]:
    """The records of :func:`solve` for the problems of ``archive`` (scene folders named in ``scenes``, with
    or without the ``_panda`` suffix; all when None), at most ``limit`` per scene."""
    robots = robots or Robots()
    with extracted_scene_folders(archive) as folders:
        if scenes:
            wanted = {s.removesuffix("_panda") for s in scenes}
            unknown = wanted - {f.name.removesuffix("_panda") for f in folders}
            if unknown:
                raise SystemExit(f"--scenes: no such scene folder {sorted(unknown)}; the archive holds "
                                 f"{[f.name for f in folders]}")
            folders = [f for f in folders if f.name.removesuffix("_panda") in wanted]
        for folder in folders:
            for index in problem_indices(folder)[:limit]:
                yield solve(robots, folder, index)


def summary_rows(records: list[dict[str, Any]]) -> list[BenchRow]:
    """One row per scene: success rate, with median time, status counts and the clearances in the note."""
    rows = []
    for name in dict.fromkeys(r["scene"] for r in records):
        results = [r for r in records if r["scene"] == name]
        successes = [r for r in results if r["success"]]
        rate = 100.0 * len(successes) / len(results)
        median_ms = float(np.median([r["seconds"] for r in results])) * 1e3
        length = float(np.median([r["path_length"] for r in successes])) if successes else float("nan")
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(Counter(r["status"] for r in results).items()))
        clear_starts = sum(r["start_clear"] for r in results)
        clear_goals = sum(r["goal_clear"] for r in results)
        refused = sum(r["start_clear"] and r["status"] == "start_invalid" for r in results)
        rows.append(BenchRow(
            SECTION, f"{name.removesuffix('_panda')}: success rate", rate, "%", higher_is_better=True,
            note=f"{len(successes)}/{len(results)} problems; median {median_ms:.0f} ms per plan; status {statuses}; "
                 f"meshes clear {clear_starts} starts and {clear_goals} goals, {refused} clear starts refused; "
                 f"median path length {length:.3f} m (successes); min model clearance "
                 f"{min(r['min_clearance'] for r in results) * 100:.2f} cm; min mesh distance (coal, every 25th "
                 f"waypoint) {min(r['mesh_min_distance'] for r in results) * 100:.2f} cm"))
    return rows


def run(quick: bool) -> list[BenchRow]:
    if not ARCHIVE.exists():
        return [BenchRow(SECTION, "skipped", 0.0, "", note=f"{ARCHIVE} not found")]
    return summary_rows(list(run_archive(ARCHIVE, SCENES, 3 if quick else 100)))


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_mbm", description=__doc__.split("\n\n")[0])
    parser.add_argument("--archive", type=Path, default=ARCHIVE, help="MBM problems (.tar.bz2)")
    parser.add_argument("--scenes", nargs="*", default=None, help="scene folder names (default: all)")
    parser.add_argument("--limit", type=int, default=None, help="at most N problems per scene")
    parser.add_argument("--out", type=Path, required=True, help="JSON lines output file")
    parser.add_argument("--target-gap", type=float, default=None, help="refit the link model with this bound (m)")
    parser.add_argument("--one-capsule", action="store_true", help="one capsule per link (the coarse model)")
    args = parser.parse_args(argv)
    if not args.archive.exists():
        parser.error(f"--archive: {args.archive} not found")
    if args.limit is not None and args.limit < 1:
        parser.error(f"--limit: must be >= 1, got {args.limit}")
    records = []
    with args.out.open("w", encoding="utf-8") as out:
        for record in run_archive(args.archive, args.scenes, args.limit, Robots(args.target_gap, args.one_capsule)):
            out.write(json.dumps(record) + "\n")
            out.flush()
            records.append(record)
    for row in summary_rows(records):
        print(f"{row.name}: {row.value:.0f} % — {row.note}")


if __name__ == "__main__":
    main()
