"""Assisted teleoperation: a simulated operator under no assistance, MoveIt Servo's scaling and pfield's assistance.

Scenes (task space, the end effector as a point; :mod:`pfield.demo._teleop_sim` explains the operator, the modes
and the exact collision check): ``seed`` (the seed's five primitive obstacles; from the seed's task-space start,
reach over the capsule to :data:`SEED_REACH` in front of the table: the operator's straight line passes 7 mm above
the capsule), ``seed, planning line`` (the same obstacles, the seed's task-space start and goal: a control, no
obstacle within 7.6 cm of the line), and three cluttered scenes on the benchmark start–goal line (0.3, 0, 0.5) →
(0.6, 0.3, 0.3), each with a ``Dynamic`` sphere (r 0.04 m) moving across or along the line: ``spheres`` (5 spheres
r 0.03 m on the line), ``pillars`` (3 vertical cylinders r 0.03 m), ``boxes`` (3 boxes 6 cm). Seeded runs (50 per
scene and mode, 10 with ``--quick``), dt 0.05 s, time limit 30 s, success within 0.02 m of the target.

Figures per scene and mode: runs with a collision, minimum clearance over all runs (m), success rate,
median time to goal of the successful runs (s), agreement (mean cosine between the operator's and the
executed command). Targets (pfield): no collision, success ≥ Servo's, median time ≤ 0.8 × Servo's where Servo
acts (some run comes within its threshold; elsewhere Servo's time is the operator's own, and 0.8 × that would
need more than the top speed operator and field share).
Whole body: ``xarm7 whole body`` (the xArm7 past two static spheres, 50 runs per mode as in the other scenes,
exact coal distances, :func:`pfield.demo._teleop_sim.simulate_arm`).
Speed: ``compute_assistance`` from Python (task space, whole body) and over HTTP (p50).
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks._common import BenchRow, cpu_time, median_time
from pfield.demo._teleop_sim import (
    ARM_DISTANCE,
    MODES,
    SERVO_SCENE_THRESHOLD,
    Operator,
    TeleopRun,
    arm_scene,
    simulate,
    simulate_arm,
)
from pfield.geometry import Box, Cylinder, Obstacle, Sphere
from pfield.planning.scenes import BENCH_GOAL, BENCH_START, SEED_GOAL, SEED_START, seed_obstacles, sphere_line_scene
from pfield.spatial import Pose

SECTION = "assisted teleop"
_S, _G = BENCH_START.position, BENCH_GOAL.position
_D = _G - _S
_PERP = np.cross(_D, [0.0, 0.0, 1.0]) / np.linalg.norm(np.cross(_D, [0.0, 0.0, 1.0]))
_ALONG = _D / np.linalg.norm(_D)


def _mover(at: float, axis: np.ndarray, amplitude: float, rate: float) -> tuple[Obstacle, Callable[[float], Any]]:
    centre = _S + at * _D
    return (Obstacle("mover", Sphere(0.04), Pose(centre), group="Dynamic"),
            lambda t: centre + amplitude * math.sin(rate * t) * axis)


SEED_REACH = np.array([0.52, 0.0, 0.38])
"""m, world: the seed scene's target, 6.5 cm in front of the table and 3 cm above the capsule's top; the straight
line from the seed's start passes 7 mm above the capsule."""


def scenes() -> dict[str, tuple[list[Obstacle], np.ndarray, np.ndarray, dict[str, Callable[[float], Any]]]]:
    seed = [o for o in seed_obstacles(Path(tempfile.mkdtemp())) if o.type != "Mesh"]
    spheres, (m1, f1) = sphere_line_scene(5, 0.0, 0.03), _mover(0.5, _PERP, 0.12, 0.6)
    pillars = [Obstacle(f"pillar_{i}", Cylinder(0.03, 0.4), Pose(_S + f * _D + off * _PERP))
               for i, (f, off) in enumerate(((0.25, 0.0), (0.5, 0.03), (0.75, -0.03)))]
    m2, f2 = _mover(0.6, _PERP, 0.1, 0.8)
    boxes = [Obstacle(f"box_{i}", Box(0.06, 0.06, 0.06), Pose(_S + f * _D + off * _PERP))
             for i, (f, off) in enumerate(((0.3, 0.01), (0.55, -0.02), (0.8, 0.0)))]
    m3, f3 = _mover(0.45, _ALONG, 0.08, 0.5)  # moves along the line, toward and away from the operator
    return {"seed": (seed, SEED_START.position, SEED_REACH, {}),
            "seed, planning line": (seed, SEED_START.position, SEED_GOAL.position, {}),
            "spheres": ([*spheres, m1], _S, _G, {"mover": f1}),
            "pillars": ([*pillars, m2], _S, _G, {"mover": f2}),
            "boxes": ([*boxes, m3], _S, _G, {"mover": f3})}


GOAL_TOLERANCE = 0.02  # m, simulate()'s and simulate_arm()'s default


def _arm_runs(mode: str, runs: int) -> list[TeleopRun]:
    """xArm7 whole body (:func:`pfield.demo._teleop_sim.arm_scene`, exact coal checks)."""
    from pfield.robot import RobotModel
    from pfield.robot.collision import CollisionChecker

    robot = RobotModel.builtin("xarm7")
    q0, obstacles, goal = arm_scene(robot)
    checker = CollisionChecker(robot, obstacles)
    return [simulate_arm(robot, obstacles, q0, goal, mode, seed, checker=checker) for seed in range(runs)]


def teleop_rows(runs: int, arm_runs: int = 0) -> list[BenchRow]:
    """The table's figures, one row per scene, mode and figure (:func:`side_tables` lays them side by side)."""
    rows: list[BenchRow] = []
    cases = [(name, runs, float(np.linalg.norm(g - s)),
              lambda mode, o=o, s=s, g=g, m=m: [simulate(o, s, g, mode, seed, motion=m) for seed in range(runs)])
             for name, (o, s, g, m) in scenes().items()]
    if arm_runs:
        cases.append(("xarm7 whole body", arm_runs, ARM_DISTANCE, lambda mode: _arm_runs(mode, arm_runs)))
    for name, runs, distance, simulate_all in cases:
        # no mode arrives sooner than the straight line at the top speed (operator and field share it)
        fastest = (distance - GOAL_TOLERANCE) / Operator().top_speed
        summary: dict[str, dict[str, float]] = {}
        for mode in MODES:
            results = simulate_all(mode)
            times = [r.time_to_goal for r in results if r.success]
            summary[mode] = {"collisions": sum(r.collided for r in results),
                             "clearance": min(float(r.clearance.min()) for r in results),
                             "success": sum(r.success for r in results) / runs,
                             "time": float(np.median(times)) if times else math.inf,
                             "agreement": float(np.mean([r.agreement for r in results]))}
        servo = summary["servo"]
        servo_acts = servo["clearance"] < SERVO_SCENE_THRESHOLD
        for mode in MODES:
            s, mine = summary[mode], mode == "pfield"
            rows += [
                BenchRow(SECTION, f"{name} / {mode}: runs with a collision", s["collisions"], f"of {runs}",
                         target=0.0 if mine else None),
                BenchRow(SECTION, f"{name} / {mode}: min clearance", s["clearance"], "m", higher_is_better=True),
                BenchRow(SECTION, f"{name} / {mode}: success", s["success"], "share",
                         target=servo["success"] if mine else None, higher_is_better=True),
                BenchRow(SECTION, f"{name} / {mode}: median time to goal", s["time"], "s",
                         target=0.8 * servo["time"] if mine and servo_acts and math.isfinite(servo["time"]) else None,
                         note=_time_note(fastest, servo_acts) if mine else ""),
                BenchRow(SECTION, f"{name} / {mode}: agreement", s["agreement"], "cos", higher_is_better=True),
            ]
    return rows


_COLUMNS = (("runs with a collision", "collisions", "{:.0f}/{runs}"), ("min clearance", "min clearance (m)", "{:.4f}"),
            ("success", "success", "{:.2f}"), ("median time to goal", "median time (s)", "{:.2f}"),
            ("agreement", "agreement", "{:.3f}"))


def side_tables(rows: list[BenchRow]) -> dict[str, str]:
    """``teleop_table.md``: every scene and mode on one line (the runner writes it beside the run's results)."""
    figures: dict[tuple[str, str], dict[str, BenchRow]] = {}
    for row in rows:
        scene, sep, rest = row.name.partition(" / ")
        mode, _, figure = rest.partition(": ")
        if sep and mode in MODES:
            figures.setdefault((scene, mode), {})[figure] = row
    lines = ["| scene | mode | " + " | ".join(header for _, header, _ in _COLUMNS) + " |",
             "|---|---|" + "---:|" * len(_COLUMNS)]
    for (scene, mode), of in figures.items():
        runs = of["runs with a collision"].unit.removeprefix("of ")
        cells = [fmt.format(of[figure].value, runs=runs) for figure, _, fmt in _COLUMNS]
        lines.append(f"| {scene} | {mode} | " + " | ".join(cells) + " |")
    return {"teleop_table.md": "\n".join(lines) + "\n"}


def _time_note(fastest: float, servo_acts: bool) -> str:
    note = f"the straight line at the top speed takes {fastest:.2f} s"
    if servo_acts:
        return note
    return (f"{note}; Servo never acts here (no run within {SERVO_SCENE_THRESHOLD} m), so its time is the "
            "operator's own and the 0.8× target does not apply")


def _xyz(values: np.ndarray) -> dict[str, float]:
    return {"x": float(values[0]), "y": float(values[1]), "z": float(values[2])}


def speed_rows(quick: bool) -> list[BenchRow]:
    import httpx

    from pfield import FieldConfig, PotentialField, RobotModel, Twist
    from pfield.assistance import AssistanceScene, task_space_assistance, whole_body_assistance
    from pfield.node._base import Bus
    from pfield.node.manager import ManagerNode
    from pfield.transport.http import ServerThread, create_app

    obstacles, start, goal, _ = scenes()["seed"]
    field = PotentialField(FieldConfig(), Pose(goal), obstacles)
    scene = AssistanceScene(field=field)
    pose, command = Pose(start), Twist((0.02, 0.0, 0.0))
    repeat = 200 if quick else 2000
    task = median_time(lambda: task_space_assistance(scene, pose, command), repeat=7, number=repeat // 7)
    robot = RobotModel.builtin("xarm7")
    q = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
    whole = median_time(lambda: whole_body_assistance(scene, robot, q, command), repeat=7, number=repeat // 70 + 1)
    whole_cpu = cpu_time(lambda: whole_body_assistance(scene, robot, q, command), 7, repeat // 70 + 1)
    node = ManagerNode(Bus(), robot)
    body = {"query_pose": {"header": {"frame_id": "world"}, "pose": {"position": _xyz(start)}},
            "user_command": {"twist": {"linear": {"x": 0.02}}}}
    with ServerThread(create_app([node])) as server, httpx.Client() as client:
        client.post(f"{server.url}/topic/pfield/planning_goal_pose",
                    json={"pose": {"position": _xyz(goal)}})
        url = f"{server.url}/srv/pfield/compute_assistance"
        client.post(url, json=body).raise_for_status()
        samples = []
        for _ in range(repeat // 4):
            begin = time.perf_counter()
            client.post(url, json=body)
            samples.append(time.perf_counter() - begin)
    samples.sort()
    return [BenchRow(SECTION, "compute_assistance task space (Python)", task * 1e6, "µs",
                     note="seed scene, 5 obstacles"),
            BenchRow(SECTION, "compute_assistance whole body (Python)", whole * 1e6, "µs", target=25.0,
                     note=f"xArm7, seed scene; CPU {whole_cpu * 1e6:.3g} µs"),
            BenchRow(SECTION, "compute_assistance over HTTP, p50", samples[len(samples) // 2] * 1e3, "ms", target=1.0,
                     note="no obstacles in the node")]


def run(quick: bool) -> list[BenchRow]:
    return teleop_rows(10 if quick else 50, 5 if quick else 50) + speed_rows(quick)


if __name__ == "__main__":
    print(side_tables(teleop_rows(10))["teleop_table.md"])
