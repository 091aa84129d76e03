"""MotionBenchMaker Panda problems solved by whole-body potential-field planning (a baseline, no target).

Data: ``../shared/benchmarks/mbm/panda_problems_dev.tar.bz2`` (4 scenes × 100 problems; see its README),
extracted to a temporary directory at run time and never copied into the project. Each problem is a MoveIt
PlanningScene (boxes and cylinders; cylinder dimensions are [height, radius]) and a MotionPlanRequest
(start joints, joint-space goal). pfield plans whole-body from the start joints to the goal *pose* = FK of
the goal joints at the Panda's TCP (``panda_hand_tcp``), dt 0.02, tolerance 1 cm (and 0.05 rad), at most
10000 steps. Parameters: rosYaml except max_linear_velocity 0.25 m/s, max_angular_velocity 1.0 rad/s,
rotational_attractive_gain 0.6 and max_angular_acceleration 1.0 (the seed's 5 cm/s makes every plan
slow), safety_distance 2 mm and influence_distance 5 cm: MBM goals are grasp poses next to objects, and
with one conservative capsule per link a 1 cm safety distance stops the hand 1–2 cm short of most of them.
Reported per scene: success rate, median planning time, median end-effector path length of the successful
plans, the minimum link-capsule clearance over all plans (negative where a start's conservative capsules
already overlap the table: such pairs may not approach further), and the exact minimum distance of the
robot's collision meshes (coal, convex hulls) at every 25th waypoint.
Sampling planners solve all of these (REFERENCE §5); a potential field is local and is not expected to.
"""

from __future__ import annotations

import tarfile
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from benchmarks._common import BenchRow
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Cylinder, Obstacle
from pfield.robot import RobotModel
from pfield.robot.collision import CollisionChecker
from pfield.spatial import Pose

SECTION = "MotionBenchMaker Panda baseline (whole-body potential field)"
ARCHIVE = Path(__file__).resolve().parents[2] / "shared" / "benchmarks" / "mbm" / "panda_problems_dev.tar.bz2"
SCENES = ("table_pick_panda", "table_under_pick_panda", "box_panda", "bookshelf_small_panda")
CONFIG = FieldConfig(max_linear_velocity=0.25, max_angular_velocity=1.0, rotational_attractive_gain=0.6,
                     max_angular_acceleration=1.0, safety_distance=0.002, influence_distance=0.05)
ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))


def scene_obstacles(scene: dict[str, Any]) -> list[Obstacle]:
    """Obstacles of a MoveIt PlanningScene (``world.collision_objects`` boxes and cylinders)."""
    obstacles = []
    for item in scene.get("world", {}).get("collision_objects", []):
        for index, (primitive, pose) in enumerate(zip(item["primitives"], item["primitive_poses"], strict=True)):
            dims = primitive["dimensions"]
            shape: Box | Cylinder
            if primitive["type"] == "box":
                shape = Box(length=dims[0], width=dims[1], height=dims[2])
            elif primitive["type"] == "cylinder":
                shape = Cylinder(radius=dims[1], height=dims[0])
            else:
                raise ValueError(f"unsupported primitive {primitive['type']!r}")
            suffix = f"_{index}" if len(item["primitives"]) > 1 else ""
            obstacles.append(Obstacle(f"{item['id']}{suffix}", shape, Pose(pose["position"], pose["orientation"])))
    return obstacles


def request_joints(request: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """(start, goal) arm joint angles of a MotionPlanRequest, in the Panda's tree order."""
    state = request["start_state"]["joint_state"]
    start_map = dict(zip(state["name"], state["position"], strict=True))
    goal_map = {c["joint_name"]: c["position"] for c in request["goal_constraints"][0]["joint_constraints"]}
    return np.array([start_map[j] for j in ARM_JOINTS]), np.array([goal_map[j] for j in ARM_JOINTS])


def _solve(robot: RobotModel, directory: Path, index: int) -> tuple[bool, float, float, float, float]:
    scene = yaml.safe_load((directory / f"scene{index:04d}.yaml").read_text())
    request = yaml.safe_load((directory / f"request{index:04d}.yaml").read_text())
    start, goal_joints = request_joints(request)
    # a few MBM states lie just outside example-robot-data's Panda limits (MoveIt's differ): clip onto them
    start = np.clip(start, robot.lower_limits, robot.upper_limits)
    goal_joints = np.clip(goal_joints, robot.lower_limits, robot.upper_limits)
    field = PotentialField(CONFIG, robot.forward_kinematics(goal_joints), scene_obstacles(scene))
    begin = time.perf_counter()
    path = field.plan_whole_body(robot, start, 0.02, 0.01, 10000)
    seconds = time.perf_counter() - begin
    length = float(np.linalg.norm(np.diff(path.positions, axis=0), axis=1).sum())
    assert path.joint_positions is not None
    checker = CollisionChecker(robot, list(field.obstacles))
    samples = [*path.joint_positions[::25], path.joint_positions[-1]]
    exact = min(checker.distances(q)[0] for q in samples)
    return path.success, seconds, length, path.min_clearance, exact


def run(quick: bool) -> list[BenchRow]:
    if not ARCHIVE.exists():
        return [BenchRow(SECTION, "skipped", 0.0, "", note=f"{ARCHIVE} not found")]
    robot = RobotModel.builtin("panda")
    per_scene = 3 if quick else 100
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        with tarfile.open(ARCHIVE) as archive:
            archive.extractall(tmp, filter="data")
        root = next(Path(tmp).rglob(SCENES[0])).parent
        for name in SCENES:
            results = [_solve(robot, root / name, index) for index in range(1, per_scene + 1)]
            successes = [r for r in results if r[0]]
            rate = 100.0 * len(successes) / len(results)
            median_ms = float(np.median([r[1] for r in results])) * 1e3
            length = float(np.median([r[2] for r in successes])) if successes else float("nan")
            clearance = min(r[3] for r in results)
            exact = min(r[4] for r in results)
            rows.append(BenchRow(
                SECTION, f"{name.removesuffix('_panda')}: success rate", rate, "%", higher_is_better=True,
                note=f"{len(successes)}/{len(results)} problems; median {median_ms:.0f} ms per plan; median path "
                     f"length {length:.3f} m (successes); min capsule clearance {clearance * 100:.2f} cm; min "
                     f"mesh distance (coal, every 25th waypoint) {exact * 100:.2f} cm"))
    return rows
