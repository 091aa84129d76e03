"""Whole-body planning, the whole-body autonomy vector and the robot kinematics, next to the C++ figures.

REFERENCE.md §2 whole-body scenes: xArm7 from q0 = (0, −0.6, 0, 0.9, 0, 1.5, 0) to (0.6, 0.3, 0.3) with
orientation Rx(π), dt 0.01, tolerance 0.01 m, at most 30000 steps; no obstacles or 5 spheres (r 0.02 m,
lateral offset 0.15 m); parameters "default" and "rosYaml". µs per step = (median wall time of the whole
``plan_whole_body`` call − that of its exact mesh certificate) / steps taken (pfield needs far fewer steps, so ms
per plan is also shown, with the certificate's share: a reached plan is certified on the exact meshes, which
neither the numba engine nor the C++ original did, so the per-step figure leaves it out).
Autonomy vector: ``whole_body_autonomy_vector`` from Python at q0 (previous velocities zero, dt 0.01); also toward
three candidate goals in turn, as shared autonomy's goal inference asks (a field per goal, 5 cm apart), where each
field keeps its compiled stepper (``pfield.shared_control._recent``).
Kinematics: FK, end-effector Jacobian and one IK solve (+1 cm) through the public Python API (target ≤ 2× the
C++ library's in-process calls, issue 32), and the IK solve also through the core's entry without the result object.
Notes add the median CPU time (the machine is shared; wall time includes waiting for a core).
The C++ column is the anchor program run in the same ``make bench`` (:mod:`benchmarks._anchor`), else REFERENCE §3.
Prepared calls: :class:`~pfield.robot.ik.IKSolver` (bound arrays, one compiled call) next to the kernel.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from benchmarks._anchor import cpp_figures, cpp_median
from benchmarks._common import BenchRow, auto_number, cpu_time, median_time
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Obstacle
from pfield.planning.certify import certify_path
from pfield.planning.result import PlannedPath
from pfield.planning.scenes import DEFAULT_PARAMS, SEED_GOAL, seed_obstacles, sphere_line_scene
from pfield.planning.whole_body import joint_velocity_sign_flips
from pfield.robot import RobotModel
from pfield.robot.ik import IKSolver, ik_settings, solve_ik
from pfield.shared_control.autonomy import whole_body_autonomy_vector
from pfield.spatial import Pose

SECTION_PLAN = "whole-body planning (xArm7, µs per step)"
SECTION_VECTOR = "whole-body autonomy vector (xArm7, µs per call from Python)"
SECTION_KIN = "robot kinematics (xArm7, µs per call)"
Q0 = np.array([0.0, -0.6, 0.0, 0.9, 0.0, 1.5, 0.0])
GOAL = Pose((0.6, 0.3, 0.3), (1.0, 0.0, 0.0, 0.0))
PARAMS = {"default": DEFAULT_PARAMS, "rosYaml": FieldConfig()}
# C++ original (REFERENCE §3): ms per plan, steps, µs per step, outcome.
CPP = {(0, "default"): (386.0, 19770, 19.5, "reached"),
       (5, "default"): (1826.0, 21232, 86.0, "stagnation, arm thrown outside joint limits"),
       (0, "rosYaml"): (132.0, 7319, 18.1, "reached"), (5, "rosYaml"): (1047.0, 30000, 35.0, "not reached")}
TARGET_US = {0: 19.5, 5: 35.0}
ANCHOR_SECTIONS = ("whole_body", "extra")
CPP_VECTOR = {(0, "default"): 17.0, (5, "default"): 59.0, (0, "rosYaml"): 19.0, (5, "rosYaml"): 19.0}


def _certificate_seconds(robot: RobotModel, obstacles: list[Obstacle], path: PlannedPath, repeat: int) -> float:
    """Median wall time of the exact mesh certificate ``plan_whole_body`` ran on ``path`` (0 when it did not reach
    its goal: only a reached motion is certified), with its own collision checker as the planner builds one."""
    if not path.success:
        return 0.0
    return median_time(lambda: certify_path(robot, obstacles, path.joint_positions), repeat=repeat)


def _plan_rows(robot: RobotModel, repeat: int) -> list[BenchRow]:
    rows = []
    for name, config in PARAMS.items():
        for count in (0, 5):
            obstacles = sphere_line_scene(count, lateral_offset=0.15)
            field = PotentialField(config, GOAL, obstacles)

            def plan(field: PotentialField = field) -> object:
                return field.plan_whole_body(robot, Q0, 0.01, 0.01, 30000)

            seconds = median_time(plan, repeat=repeat)
            cpu = cpu_time(plan, repeat)
            path = field.plan_whole_body(robot, Q0, 0.01, 0.01, 30000)
            steps = max(path.iterations, 1)
            certificate = _certificate_seconds(robot, obstacles, path, repeat)
            cpp_ms, cpp_steps, cpp_us, cpp_outcome = CPP[(count, name)]
            measured = cpp_figures(ANCHOR_SECTIONS).get(("whole_body", f"{count} spheres", name, "plan"))
            source = "C++ from REFERENCE.md"
            if measured is not None:
                cpp_ms, cpp_steps = float(measured["median"]), int(measured.get("steps", cpp_steps))
                cpp_us, source = cpp_ms * 1e3 / max(cpp_steps, 1), "C++ measured in this run"
            state = "reached" if path.success else path.failure_reason.split(":")[0]
            distance = float(np.linalg.norm(path.positions[-1] - GOAL.position))
            rows.append(BenchRow(
                SECTION_PLAN, f"{count} spheres / {name}", (seconds - certificate) / steps * 1e6, "µs/step", cpp_us,
                target=TARGET_US[count],
                note=f"{seconds * 1e3:.3g} ms per plan (C++ {cpp_ms:g} ms), CPU {cpu * 1e3:.3g} ms, of which the "
                     f"exact certificate {certificate * 1e3:.3g} ms; {steps} steps, "
                     f"{state} ({distance * 100:.2f} cm from goal, min clearance {path.min_clearance * 100:.2f} cm, "
                     f"{joint_velocity_sign_flips(path)} joint-velocity sign flips); C++: {cpp_steps} steps, "
                     f"{cpp_outcome}; {source}"))
    with tempfile.TemporaryDirectory() as directory:
        obstacles = seed_obstacles(Path(directory))
        field = PotentialField(FieldConfig(), SEED_GOAL, obstacles)
        seed_q = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
        seconds = median_time(lambda: field.plan_whole_body(robot, seed_q, 0.02, 0.01, 25000), repeat=repeat)
        path = field.plan_whole_body(robot, seed_q, 0.02, 0.01, 25000)
        certificate = _certificate_seconds(robot, obstacles, path, repeat)
        state = "reached" if path.success else path.failure_reason
        rows.append(BenchRow(SECTION_PLAN, "seed whole_body example, six seed obstacles / rosYaml, dt 0.02",
                             (seconds - certificate) / max(path.iterations, 1) * 1e6, "µs/step",
                             note=f"{seconds * 1e3:.3g} ms per plan, of which the exact certificate "
                                  f"{certificate * 1e3:.3g} ms; {path.iterations} steps, {state}, min clearance "
                                  f"{path.min_clearance * 100:.2f} cm, {joint_velocity_sign_flips(path)} sign flips"))
    return rows


def _vector_rows(robot: RobotModel, repeat: int) -> list[BenchRow]:
    rows = []
    previous = np.zeros(7)
    for name, config in PARAMS.items():
        for count in (0, 5):
            field = PotentialField(config, GOAL, sphere_line_scene(count, lateral_offset=0.15))

            def call(field: PotentialField = field) -> object:
                return whole_body_autonomy_vector(field, robot, Q0, previous, 0.01)

            number = auto_number(call)
            seconds = median_time(call, repeat=repeat, number=number)
            cpu = cpu_time(call, repeat, number)
            cpp, source = cpp_median(cpp_figures(ANCHOR_SECTIONS),
                                     ("extra", f"{count} spheres", name, "whole_body_autonomy_vector"),
                                     CPP_VECTOR[(count, name)])
            rows.append(BenchRow(SECTION_VECTOR, f"{count} spheres / {name}", seconds * 1e6, "µs", cpp, target=cpp,
                                 note=f"CPU {cpu * 1e6:.3g} µs; {source}; target ≤ 1.0× the C++"))
    scene = sphere_line_scene(5, lateral_offset=0.15)
    goals = [Pose(GOAL.position + np.array((0.0, dy, 0.0)), GOAL.orientation) for dy in (0.0, 0.05, -0.05)]
    fields = [PotentialField(PARAMS["rosYaml"], goal, scene) for goal in goals]
    turn = [0]

    def in_turn() -> object:
        turn[0] += 1
        return whole_body_autonomy_vector(fields[turn[0] % len(fields)], robot, Q0, previous, 0.01)

    number = auto_number(in_turn)
    seconds = median_time(in_turn, repeat=repeat, number=number)
    rows.append(BenchRow(SECTION_VECTOR, "5 spheres / rosYaml, three candidate goals in turn", seconds * 1e6, "µs",
                         note=f"CPU {cpu_time(in_turn, repeat, number) * 1e6:.3g} µs; a field per goal, each keeping "
                              "its stepper (with one kept per thread, every call built one: about 70 µs)"))
    return rows


def _kinematics_rows(robot: RobotModel, repeat: int) -> list[BenchRow]:
    n = robot.n_joints
    start = robot.forward_kinematics(Q0)
    target = Pose(start.position + np.array([0.01, 0.0, 0.0]), start.orientation)
    settings = ik_settings(200, 1e-4, 1e-3, 1e-4, 0.3)
    core, q_out = robot._core_kinematics, np.empty(n)
    tp, tq = np.array(target.position), np.array(target.orientation)

    def ik_compiled() -> object:  # the core's solve from Python, without solve_ik's result object
        return core.solve_ik(Q0, tp, tq, settings, q_out)

    ik = median_time(ik_compiled, repeat=repeat, number=auto_number(ik_compiled))
    solver = IKSolver(robot)
    solver.target[:3], solver.target[3:], solver.seed[:] = target.position, target.orientation, Q0
    prepared = median_time(solver.solve, repeat=repeat, number=auto_number(solver.solve))
    prepared_cpu = cpu_time(solver.solve, repeat, auto_number(solver.solve))
    figures = cpp_figures(ANCHOR_SECTIONS)
    _, ik_source = cpp_median(figures, ("extra", "xarm7", "-", "ik_plus_1cm"), 4.2)
    cpp_fk, fk_source = cpp_median(figures, ("extra", "xarm7", "-", "fk"), 1.0)
    cpp_jac, _ = cpp_median(figures, ("extra", "xarm7", "-", "ee_point_jacobian"), 1.0)
    cpp_ik, _ = cpp_median(figures, ("extra", "xarm7", "-", "ik_plus_1cm"), 4.2)
    api_fk = median_time(lambda: robot.forward_kinematics(Q0), repeat=repeat, number=2000)
    api_jac = median_time(lambda: robot.jacobian(Q0), repeat=repeat, number=2000)
    api_ik = median_time(lambda: solve_ik(robot, target, Q0), repeat=repeat, number=500)
    iterations = solve_ik(robot, target, Q0).iterations
    return [
        BenchRow(SECTION_KIN, "FK (public forward_kinematics from Python)", api_fk * 1e6, "µs", cpp_fk,
                 target=2.0 * cpp_fk, note=f"returns a validated Pose; target ≤ 2× the C++; {fk_source}"),
        BenchRow(SECTION_KIN, "FK + end-effector Jacobian (public jacobian from Python)", api_jac * 1e6, "µs",
                 cpp_jac, target=2.0 * cpp_jac, note=f"target ≤ 2× the C++; {fk_source}"),
        BenchRow(SECTION_KIN, "IK solve, +1 cm (prepared IKSolver.solve from Python)", prepared * 1e6, "µs", cpp_ik,
                 target=cpp_ik, note=f"CPU {prepared_cpu * 1e6:.3g} µs; {iterations} DLS iterations; {ik_source}; "
                                     "target ≤ 1.0× the C++"),
        BenchRow(SECTION_KIN, "IK solve, +1 cm (kernel called from Python)", ik * 1e6, "µs", cpp_ik,
                 note=f"public solve_ik(): {api_ik * 1e6:.3g} µs"),
    ]


def run(quick: bool) -> list[BenchRow]:
    repeat = 3 if quick else 7
    robot = RobotModel.builtin("xarm7")
    return _plan_rows(robot, repeat) + _vector_rows(robot, repeat) + _kinematics_rows(robot, repeat)
