"""MotionBenchMaker Panda plans executed in MuJoCo: contacts with obstacles, final end-effector error, tracking.

Data and problems as in :mod:`benchmarks.bench_mbm` (its readers: the scene's obstacles, the request's start, goal
and finger opening, the Panda models by finger opening). Each problem is planned whole-body with the public API
and the global fallback (``PotentialField.plan_whole_body(..., global_fallback=True, goal_configuration=goal)``),
and a successful plan's retimed joint trajectory is executed in MuJoCo (:class:`pfield.sim.Simulation`: the
Panda's collision meshes, its URDF inertias with the fingers locked where the request puts them, Menagerie's
servo gains, gravity on with the controller's gravity compensation, 2 ms steps, 0.5 s of settling), the goal
pose being the planning goal (FK of the goal joints at ``panda_hand_tcp``). Reported per scene: problems executed,
the steps with a robot–obstacle contact (target 0) and the distinct pairs, the largest final end-effector error
(target ≤ 1 cm), the largest tracking error (rad, max over time and joints), and the median simulated and wall time.
The exact check of the plan itself (coal, convex hulls of the link meshes, every 10th waypoint) is shown beside a
contact, to tell a plan that grazes from a servo that strays.

Scriptable: ``python -m benchmarks.bench_physics [--scenes NAME ...] [--limit N] [--out FILE.jsonl]`` (default 20
problems per scene); ``make bench`` runs :func:`run` (3 per scene with ``--quick``).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from rich.progress import Progress

from benchmarks._common import BenchRow
from benchmarks.bench_mbm import (
    ARCHIVE,
    CONFIG,
    DT,
    MAX_STEPS,
    SCENES,
    TOLERANCE,
    Robots,
    extracted_scene_folders,
    problem_indices,
    request_fingers,
    request_joints,
    scene_obstacles,
    status_name,
)
from pfield.field import PotentialField
from pfield.robot.collision import CollisionChecker
from pfield.sim import Simulation

SECTION = "MotionBenchMaker Panda plans executed in MuJoCo (physics check)"
PROBLEMS = 20
"""Problems per scene (the issue's figure)."""
POSITION_TARGET = 0.01
"""m: the final end-effector error the issue asks for."""


def execute(robots: Robots, directory: Path, index: int) -> dict[str, Any]:
    """Plan problem ``index`` of ``directory`` and execute the plan in MuJoCo; the JSON record.

    Keys: ``scene``, ``index``, ``plan_status``, ``planner``, ``plan_seconds``, ``executed`` (a successful plan),
    and for an executed plan ``duration`` (s), ``sim_wall`` (s), ``contact_steps``, ``contact_pairs``,
    ``penetration`` (m), ``self_contact_steps``, ``base_overlaps``, ``position_error`` (m), ``rotation_error``
    (rad), ``max_tracking`` (rad), ``tracking_joint``, ``final_tracking`` (rad), ``servo_position_error`` (m: the
    simulated end effector against the plan's last waypoint, what the servos add to the plan's own goal error) and
    ``plan_mesh_distance`` (m, coal).
    """
    scene = yaml.safe_load((directory / f"scene{index:04d}.yaml").read_text())
    request = yaml.safe_load((directory / f"request{index:04d}.yaml").read_text())
    robot = robots.get(request_fingers(request))
    start, goal_joints = request_joints(request)
    start = np.clip(start, robot.lower_limits, robot.upper_limits)
    goal_joints = np.clip(goal_joints, robot.lower_limits, robot.upper_limits)
    obstacles = scene_obstacles(scene)
    goal = robot.forward_kinematics(goal_joints)
    begin = time.perf_counter()
    path = PotentialField(CONFIG, goal, obstacles).plan_whole_body(
        robot, start, DT, TOLERANCE, MAX_STEPS, global_fallback=True, goal_configuration=goal_joints)
    record: dict[str, Any] = {"scene": directory.name, "index": index, "plan_status": status_name(path),
                              "planner": path.planner, "plan_seconds": time.perf_counter() - begin,
                              "executed": bool(path.success and path.trajectory is not None)}
    if not record["executed"]:
        return record
    report = Simulation(robot, obstacles).execute(path, goal)
    assert path.joint_positions is not None
    checker = CollisionChecker(robot, obstacles)
    samples = [*path.joint_positions[::10], path.joint_positions[-1]]
    record.update(
        duration=report.duration, sim_wall=report.wall_time, contact_steps=report.contacts.obstacle_steps,
        contact_pairs=list(report.contacts.obstacle_pairs), penetration=report.contacts.obstacle_penetration,
        self_contact_steps=report.contacts.self_steps, base_overlaps=list(report.base_overlaps),
        position_error=report.final_position_error, rotation_error=report.final_rotation_error,
        max_tracking=report.max_tracking_error, tracking_joint=report.max_tracking_joint,
        final_tracking=report.final_tracking_error,
        servo_position_error=report.final_pose.translation_distance(
            robot.forward_kinematics(path.joint_positions[-1])),
        plan_mesh_distance=min(checker.distances(q)[0] for q in samples))
    return record


def run_scenes(archive: Path, scenes: Sequence[str], limit: int, robots: Robots | None = None,
               progress: Progress | None = None) -> Iterator[dict[str, Any]]:
    """Records of :func:`execute` for the first ``limit`` problems of each scene folder named in ``scenes``."""
    robots = robots or Robots()
    wanted = {s.removesuffix("_panda") for s in scenes}
    with extracted_scene_folders(archive) as all_folders:
        folders = [f for f in all_folders if f.name.removesuffix("_panda") in wanted]
        task = progress.add_task("physics", total=limit * len(folders)) if progress else None
        for folder in folders:
            for index in problem_indices(folder)[:limit]:
                if progress is not None and task is not None:
                    progress.update(task, description=f"{folder.name} #{index}")
                yield execute(robots, folder, index)
                if progress is not None and task is not None:
                    progress.advance(task)


def summary_rows(records: list[dict[str, Any]]) -> list[BenchRow]:
    """Per scene: contact steps, worst final EE error, worst tracking error, with counts and times in the notes."""
    rows = []
    for name in dict.fromkeys(r["scene"] for r in records):
        results = [r for r in records if r["scene"] == name]
        done = [r for r in results if r["executed"]]
        scene = name.removesuffix("_panda")
        head = f"{len(done)}/{len(results)} plans succeeded and were executed"
        if not done:
            rows.append(BenchRow(SECTION, f"{scene}: executed", 0.0, "plans", note=head))
            continue
        touching = [r for r in done if r["contact_steps"] or r["base_overlaps"]]
        pairs = sorted({p for r in touching for p in r["contact_pairs"] + r["base_overlaps"]})
        grazing = ", ".join(f"#{r['index']}: plan mesh distance {r['plan_mesh_distance'] * 1e3:.1f} mm, "
                            f"penetration {r['penetration'] * 1e3:.2f} mm" for r in touching)
        where = f" ({'; '.join(pairs)}; {grazing})" if touching else ""
        rows.append(BenchRow(
            SECTION, f"{scene}: steps in contact with obstacles", float(sum(r["contact_steps"] for r in done)),
            "steps", target=0.0,
            note=f"{head}; {len(touching)} executions touched{where}; min exact mesh distance of the plans (coal, "
                 f"every 10th waypoint) {min(r['plan_mesh_distance'] for r in done) * 1e3:.1f} mm"))
        worst = max(done, key=lambda r: r["position_error"])
        within = sum(r["position_error"] <= POSITION_TARGET for r in done)
        rows.append(BenchRow(
            SECTION, f"{scene}: max final end-effector error", worst["position_error"] * 100, "cm",
            target=POSITION_TARGET * 100,
            note=f"{within}/{len(done)} within 1 cm; median {np.median([r['position_error'] for r in done]) * 1e3:.2f}"
                 f" mm; max rotation error {max(r['rotation_error'] for r in done):.4f} rad; the servos' share (final "
                 f"EE vs the plan's last waypoint) at most "
                 f"{max(r['servo_position_error'] for r in done) * 1e3:.3f} mm, "
                 "the rest is the plan's own goal tolerance (1 cm)"))
        tracking = max(done, key=lambda r: r["max_tracking"])
        rows.append(BenchRow(
            SECTION, f"{scene}: max tracking error", tracking["max_tracking"], "rad",
            note=f"at {tracking['tracking_joint']} (#{tracking['index']}); median of the runs' maxima "
                 f"{np.median([r['max_tracking'] for r in done]):.4f} rad; median trajectory "
                 f"{np.median([r['duration'] for r in done]):.2f} s simulated in "
                 f"{np.median([r['sim_wall'] for r in done]):.2f} s wall; self-contact steps "
                 f"{sum(r['self_contact_steps'] for r in done)}"))
    return rows


def run(quick: bool) -> list[BenchRow]:
    """The MBM plans executed in MuJoCo, then the assisted-teleop scene driven through the servo loop there."""
    teleop = teleop_rows(3 if quick else TELEOP_RUNS)
    if not ARCHIVE.exists():
        return [BenchRow(SECTION, "skipped", 0.0, "", note=f"{ARCHIVE} not found"), *teleop]
    return [*summary_rows(list(run_scenes(ARCHIVE, SCENES, 3 if quick else PROBLEMS))), *teleop]


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_physics", description=__doc__.split("\n\n")[0])
    parser.add_argument("--archive", type=Path, default=ARCHIVE, help="MBM problems (.tar.bz2)")
    parser.add_argument("--scenes", nargs="*", default=list(SCENES), help="scene folder names (default: the four)")
    parser.add_argument("--limit", type=int, default=PROBLEMS, help=f"problems per scene (default {PROBLEMS})")
    parser.add_argument("--out", type=Path, default=None, help="JSON lines output file (optional)")
    args = parser.parse_args(argv)
    if not args.archive.exists():
        parser.error(f"--archive: {args.archive} not found")
    if args.limit < 1:
        parser.error(f"--limit: must be >= 1, got {args.limit}")
    records = []
    with Progress(transient=True) as progress:
        out = args.out.open("w", encoding="utf-8") if args.out else None
        for record in run_scenes(args.archive, args.scenes, args.limit, progress=progress):
            records.append(record)
            if out is not None:
                out.write(json.dumps(record) + "\n")
                out.flush()
        if out is not None:
            out.close()
    for row in summary_rows(records):
        print(f"{row.name}: {row.value:.4g} {row.unit} — {row.note}")



# ---- assisted teleop through the servo loop, in physics -----------------------------------------------------
TELEOP_SECTION = "assisted teleop through /pfield_servo in MuJoCo (physics check)"
TELEOP_RUNS = 10
"""Seeded operator runs (the kinematic bench's seeds 0..N-1)."""


def servo_teleop_run(robot: Any, obstacles: Sequence[Any], q0: np.ndarray, goal: np.ndarray, seed: int, *,
                     period: float = 0.01, operator_period: float = 0.05, time_limit: float = 30.0,
                     goal_tolerance: float = 0.02, simulation: Simulation | None = None,
                     checker: CollisionChecker | None = None) -> dict[str, Any]:
    """One run of the kinematic bench's simulated operator (:func:`pfield.demo._teleop_sim.simulate_arm`: gain
    toward ``goal`` on the end-effector position it saw ``delay`` ago, a constant drift and noise drawn from
    ``seed``, at most ``top_speed``; a new twist every ``operator_period`` s) driving
    :class:`pfield.shared_control.Servo` (``publish_period`` = ``period`` s, the bench's field and
    arbitration), whose position/velocity commands the Panda's or xArm7's MuJoCo servos hold for one period; the
    servo measures the simulated joints each cycle. Success: the end effector within ``goal_tolerance`` m of
    ``goal`` before ``time_limit`` s. Returns contact steps with obstacles (and self), success, the time to goal,
    the end-effector trail, the wall time and, with ``checker``, the smallest exact robot–obstacle distance (coal)
    at every 5th cycle's simulated joints (m)."""
    from pfield import FieldConfig, Twist
    from pfield.demo._teleop_sim import ARBITRATION, Operator
    from pfield.shared_control import AssistanceScene, Servo, ServoConfig
    from pfield.spatial import Pose

    op = Operator()
    rng = np.random.default_rng(seed)  # the same draws, in the same order, as simulate_arm
    direction = rng.normal(size=3)
    bias = op.bias * direction / np.linalg.norm(direction)
    sim = simulation or Simulation(robot, obstacles, q0=q0)
    sim.reset(q0)
    field = PotentialField(FieldConfig(max_linear_velocity=0.08),
                           Pose(goal, robot.forward_kinematics(q0).orientation), list(obstacles))
    servo = Servo(robot, ServoConfig(publish_period=period), AssistanceScene(field=field), arbitration=ARBITRATION)
    per_op, delay_steps = round(operator_period / period), round(op.delay / operator_period)
    q = np.array(sim.state.positions)
    seen_history = [robot.forward_kinematics(q).position]
    trail, success, reached = [seen_history[0]], False, float("inf")
    clearance = float("inf")
    wall = time.perf_counter()
    for k in range(round(time_limit / period)):
        now = k * period
        if k % per_op == 0:
            seen = seen_history[max(0, len(seen_history) - 1 - delay_steps)]
            command = op.gain * (goal - seen) + bias + rng.normal(scale=op.noise, size=3)
            speed = np.linalg.norm(command)
            if speed > op.top_speed:
                command *= op.top_speed / speed
            servo.command(Twist(command), now)
        out = servo.step(q, now)
        q = np.array(sim.step(out.positions, out.velocities, dt=period).positions)
        position = robot.forward_kinematics(q).position
        trail.append(position)
        if checker is not None and k % 5 == 0:
            clearance = min(clearance, float(checker.distances(q)[0]))
        if (k + 1) % per_op == 0:
            seen_history.append(position)
        if np.linalg.norm(goal - position) <= goal_tolerance:
            success, reached = True, (k + 1) * period
            break
    tally = sim.contacts
    return {"seed": seed, "success": success, "time": reached, "obstacle_steps": tally.obstacle_steps,
            "obstacle_pairs": list(tally.obstacle_pairs), "self_steps": tally.self_steps,
            "trail": np.array(trail), "wall": time.perf_counter() - wall, "clearance": clearance}


def teleop_rows(runs: int = TELEOP_RUNS) -> list[BenchRow]:
    """The kinematic bench's whole-body teleop scene (``xarm7 whole body``: :func:`pfield.demo._teleop_sim.arm_scene`
    and its operator; :mod:`benchmarks.bench_teleop`) driven through the servo loop in MuJoCo, beside the same
    seeds in the kinematic bench's ``pfield`` mode (:func:`~pfield.demo._teleop_sim.simulate_arm`). Targets
    (issue 35): 0 contact steps with obstacles, success ≥ the kinematic bench's. The bench's task-space scenes move
    a point, not a robot, so they have no physical counterpart and are left out."""
    from pfield.demo._teleop_sim import arm_scene, simulate_arm
    from pfield.robot import RobotModel

    robot = RobotModel.builtin("xarm7")
    q0, obstacles, goal = arm_scene(robot)
    checker = CollisionChecker(robot, obstacles)
    kinematic = [simulate_arm(robot, obstacles, q0, goal, "pfield", seed, checker=checker) for seed in range(runs)]
    sim = Simulation(robot, obstacles, q0=q0)
    physical = [servo_teleop_run(robot, obstacles, q0, goal, seed, simulation=sim, checker=checker)
                for seed in range(runs)]
    kinematic_success = sum(r.success for r in kinematic) / runs
    done = [r["time"] for r in physical if r["success"]]
    name = "xarm7 whole body"
    return [
        BenchRow(TELEOP_SECTION, f"{name}: contact steps with obstacles", sum(r["obstacle_steps"] for r in physical),
                 "steps", target=0.0, note=f"{runs} runs; self-contact steps {sum(r['self_steps'] for r in physical)}"),
        BenchRow(TELEOP_SECTION, f"{name}: min clearance (servo in MuJoCo)", min(r["clearance"] for r in physical),
                 "m", higher_is_better=True, note="exact (coal), every 5th cycle; kinematic bench: "
                 f"{min(float(r.clearance.min()) for r in kinematic):.4f} m"),
        BenchRow(TELEOP_SECTION, f"{name}: success (servo in MuJoCo)", sum(r["success"] for r in physical) / runs,
                 "share", target=kinematic_success, higher_is_better=True,
                 note=f"kinematic bench, same seeds: {kinematic_success:.2f}"),
        BenchRow(TELEOP_SECTION, f"{name}: success (kinematic bench)", kinematic_success, "share",
                 higher_is_better=True),
        BenchRow(TELEOP_SECTION, f"{name}: median time to goal (servo in MuJoCo)",
                 float(np.median(done)) if done else float("inf"), "s",
                 note="kinematic bench: " + (f"{np.median([r.time_to_goal for r in kinematic if r.success]):.2f} s"
                                             if kinematic_success else "no success")),
        BenchRow(TELEOP_SECTION, f"{name}: wall time per run", float(np.median([r["wall"] for r in physical])), "s",
                 note="median"),
    ]

if __name__ == "__main__":
    main()
