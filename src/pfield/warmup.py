"""Compile every numba kernel of pfield ahead of time, and say whether this process has done so.

A kernel compiles on its first call with a new argument type (seconds each, up to a minute for all with
an empty cache) and loads from numba's on-disk cache afterwards (milliseconds). :func:`warm` calls every
public computation once on a tiny problem, through the same entry points (and so with the same array
types) as real use: the first real request then finds its kernels compiled or cached.

* :data:`STEPS` — the warm-up steps, in order: geometry SDFs, task-space field and planner, the whole-body
  planner for each built-in robot's packed layout, IK, the autonomy vector, the global fallback, the mobile
  field, the costmap.
* :func:`warm` — run them (once per process; ``progress(done, total, step)`` after each step).
* :func:`start_background` — :func:`warm` in a daemon thread (``pfield serve``, ``pfield ros2 node``).
* :func:`fit_in_background` — build a robot's fitted link model (``robot.geometry``) in a daemon thread: the
  node's robot, whose first fit takes seconds (a URDF robot's, or after an edit of the fitting code).
* :func:`ready` — thread-safe: has :func:`warm` finished in this process, and has every robot handed to
  :func:`fit_in_background` its link model (what ``GET /health`` reports)?
* :func:`kernels` — every compiled dispatcher of pfield, to check what compiled and how often.

A failing step is logged and counted in :class:`WarmupReport`; the kernels it did not reach compile on
first use instead, so :func:`ready` still turns true when :func:`warm` returns.
"""

from __future__ import annotations

import importlib
import logging
import pkgutil
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pfield import _compile_notice

__all__ = ["LANES", "STEPS", "WarmupReport", "WarmupStep", "fit_in_background", "kernels", "ready",
           "start_background", "warm"]

_LOG = logging.getLogger(__name__)

Progress = Callable[[int, int, str], None]
"""``progress(done, total, step_name)``: called before the first step (done = 0) and after each step."""


@dataclass(frozen=True)
class WarmupStep:
    """One warm-up step: ``run(scratch_dir)`` exercises one area's public entry points on a tiny problem."""

    name: str
    run: Callable[[Path], None]


@dataclass(frozen=True)
class WarmupReport:
    """What :func:`warm` did: seconds per step (in order), the failed steps with their error, the total, and
    how many processes compiled side by side (one per :data:`LANES` entry when a cold cache was filled; else 0)."""

    seconds: dict[str, float]
    failures: dict[str, str]
    total_seconds: float
    lanes: int = 0


# -- the steps ------------------------------------------------------------------------------------------

def _scene(scratch: Path) -> list[Any]:
    from pfield.planning.scenes import seed_obstacles

    return seed_obstacles(scratch / "meshes")  # one obstacle of every shape, a triangle mesh included


def _geometry(scratch: Path) -> None:
    from pfield import spatial

    points = np.array([[0.4, 0.0, 0.1], [0.0, 0.0, 0.0], [0.5, 0.2, 0.3]])
    for obstacle in _scene(scratch):
        obstacle.signed_distance(points)
    quats = spatial.quaternion_exp(np.array([[0.1, 0.2, 0.3], [0.0, 0.0, 0.0]]))
    spatial.quaternion_log(quats)
    spatial.quaternion_from_matrix(spatial.matrix_from_quaternion(quats))
    spatial.geodesic_angle(quats[0], quats[1])
    spatial.rotate_vectors(quats, points[:2])
    spatial.quaternion_multiply(quats[0], spatial.quaternion_inverse(quats[1]))
    spatial.euler_zyx_from_quaternion(spatial.quaternion_from_euler_zyx(0.1, 0.2, 0.3))


def _task_space(scratch: Path) -> None:
    from pfield.field import FieldConfig, PotentialField
    from pfield.planning.scenes import SEED_GOAL, SEED_START
    from pfield.spatial import Pose

    field = PotentialField(FieldConfig(), SEED_GOAL, _scene(scratch))
    field.wrench(SEED_START)
    field.twist(SEED_START, field.twist(SEED_START), 0.01)
    positions = np.array([[0.3, 0.0, 0.3], [0.45, 0.1, 0.35]])
    field.wrenches(positions)
    field.twists(positions, np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]]))
    field.clearances(positions)
    field.plan(SEED_START, dt=0.02, goal_tolerance=0.01, max_iterations=20)
    from pfield.field.prepared import PreparedTwist

    prepared = PreparedTwist(field)
    prepared.pose[:3] = SEED_START.position
    prepared.evaluate()
    prepared.evaluate(0.01)
    PotentialField(FieldConfig(), Pose((0.5, 0.0, 0.3))).plan(Pose((0.2, 0.0, 0.3)), max_iterations=20)


def _whole_body(name: str) -> Callable[[Path], None]:
    def run(scratch: Path) -> None:
        from pfield.field import FieldConfig, PotentialField
        from pfield.planning.scenes import SEED_GOAL
        from pfield.robot import RobotModel
        from pfield.robot.collision import capsule_clearances

        robot = RobotModel.builtin(name)
        q0 = robot.mid_configuration
        obstacles = _scene(scratch)
        PotentialField(FieldConfig(), SEED_GOAL, obstacles).plan_whole_body(robot, q0, 0.02, 0.01, 20)
        PotentialField(FieldConfig(), SEED_GOAL).plan_whole_body(robot, q0, 0.02, 0.01, 20)
        capsule_clearances(robot, q0, obstacles)
        robot.forward_kinematics(q0)
        robot.jacobian(q0)
        robot.end_effector_positions(np.stack([q0, q0]))

    return run


def _inverse_kinematics(scratch: Path) -> None:
    from pfield.field import FieldConfig, PotentialField
    from pfield.planning.joint_trajectory import attach_joint_trajectory
    from pfield.robot import RobotModel
    from pfield.robot.ik import solve_ik

    robot = RobotModel.builtin("xarm7")
    q0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
    start = robot.forward_kinematics(q0)
    solve_ik(robot, start, q0)
    from pfield.robot.ik import IKSolver

    solver = IKSolver(robot)
    solver.target[:3], solver.target[3:] = start.position, start.orientation
    solver.seed[:] = q0
    solver.solve()
    goal = start.__class__(start.position + np.array([0.02, 0.0, 0.0]), start.orientation)
    path = PotentialField(FieldConfig(), goal).plan(start, dt=0.02, max_iterations=5)
    attach_joint_trajectory(path, robot, q0)


def _autonomy(scratch: Path) -> None:
    from pfield.field import FieldConfig, PotentialField
    from pfield.planning.scenes import SEED_GOAL, SEED_START
    from pfield.robot import RobotModel
    from pfield.shared_control.autonomy import (
        task_space_autonomy_vector,
        whole_body_autonomy,
        whole_body_autonomy_vector,
    )

    robot = RobotModel.builtin("xarm7")
    field = PotentialField(FieldConfig(), SEED_GOAL, _scene(scratch))
    q = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
    task_space_autonomy_vector(field, SEED_START)
    whole_body_autonomy_vector(field, robot, q)
    whole_body_autonomy_vector(field, robot, q, np.zeros(7), 0.01)
    whole_body_autonomy_vector(field, robot, q.tolist())  # not a float64 array: the validating path
    whole_body_autonomy(field, robot, q, np.zeros(7), 0.01, query_pose=SEED_START)
    from pfield.shared_control.assistance import AssistanceScene, task_space_assistance, whole_body_assistance
    from pfield.spatial import Twist

    assistance = AssistanceScene(field=field)
    task_space_assistance(assistance, SEED_START, Twist((0.02, 0.0, 0.0)))
    whole_body_assistance(assistance, robot, q, Twist((0.02, 0.0, 0.0)))
    # without a goal (the node before its first goal): the assistance alone, no field step
    no_goal = AssistanceScene(config=field.config, obstacles=field.obstacles)
    whole_body_assistance(no_goal, robot, q, Twist((0.02, 0.0, 0.0)))


def _global_fallback(scratch: Path) -> None:
    """Both fallbacks end to end (search, shortcutting, tracking, the exact contact check) and the retiming,
    on the smallest scenes that trap the field: a 40 cm wall between an xArm7 hand and its goal, and a
    box cup around a task-space start."""
    from pfield.field import FieldConfig, PotentialField
    from pfield.geometry import Box, Obstacle
    from pfield.robot import RobotModel
    from pfield.spatial import Pose

    robot = RobotModel.builtin("xarm7")
    wall = [Obstacle("wall", Box(0.04, 0.8, 0.4), Pose((0.4, 0.0, 0.2)))]
    config = FieldConfig(max_linear_velocity=0.25, max_angular_velocity=1.0, safety_distance=0.005,
                         influence_distance=0.05)
    q0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -1.5708, 0.0])
    PotentialField(config, Pose((0.55, 0.0, 0.36), (1.0, 0.0, 0.0, 0.0)), wall).plan_whole_body(
        robot, q0, 0.02, 0.01, 10000)
    sides = [((0.3, 0.0, 0.0), (0.05, 0.7, 0.7)), ((0.05, 0.35, 0.0), (0.55, 0.05, 0.7)),
             ((0.05, -0.35, 0.0), (0.55, 0.05, 0.7)), ((0.05, 0.0, 0.35), (0.55, 0.7, 0.05)),
             ((0.05, 0.0, -0.35), (0.55, 0.7, 0.05))]
    cup = [Obstacle(f"side{k}", Box(*size), Pose(centre)) for k, (centre, size) in enumerate(sides)]
    PotentialField(FieldConfig(), Pose((0.8, 0.0, 0.0)), cup).plan(Pose((0.0, 0.0, 0.0)), dt=0.02,
                                                                   max_iterations=20000)


def _link_fitting(scratch: Path) -> None:
    """Fit spheres and capsules to a small box (not cached): the kernels a robot's first fit uses."""
    from scipy.spatial import ConvexHull

    from pfield.robot._cover import inside_hull
    from pfield.robot._fit import LinkSurface, fit_link

    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * np.array([0.04, 0.02, 0.01])
    hull = ConvexHull(corners)
    fit_link(LinkSurface(corners, np.asarray(hull.simplices, dtype=np.int64), 0.08 * 0.04 * 0.02, "warm-up box"), 0.01)
    facets = np.ascontiguousarray(hull.equations)
    inside_hull(facets, facets, corners, 1e-12)  # what an open mesh's fit adds


def _mobile(scratch: Path) -> None:
    import math

    from pfield.mobile import VectorFieldParams, gradient, potential, velocity
    from pfield.mobile.controller import BaseController
    from pfield.mobile.scan import scan_ranges_obstacles
    from pfield.mobile.world import World2D

    params = VectorFieldParams()
    points, goal, obstacles = np.array([[0.0, 0.0], [1.0, 0.5]]), np.array([3.0, 3.0]), np.array([[1.0, 1.0]])
    potential(points, goal, obstacles, params)
    gradient(points, goal, obstacles, params)
    velocity(points, goal, obstacles, params)
    velocity(points, None, obstacles, params)
    world = World2D.build(points=[[1.0, 1.0]], circles=[[2.0, 0.0, 0.3]], polygons=[[[3, -1], [4, -1], [4, 1]]])
    angles = np.linspace(-math.pi, math.pi, 36, endpoint=False)
    ranges = world.raycast((0.0, 0.0), angles, 5.0)
    world.clearance((0.0, 0.0))
    controller = BaseController(params)
    controller.set_goal((3.0, 3.0))
    controller.set_obstacles(scan_ranges_obstacles(ranges, -math.pi, 2 * math.pi / 36, 0.05, 5.0))
    controller.step((0.0, 0.0, 0.0), 0.0)
    controller.set_teleop(0.1, 0.0, 0.0, 0.05)
    controller.step((0.0, 0.0, 0.0), 0.1)


def _costmap(scratch: Path) -> None:
    from pfield.costmap import _example
    from pfield.costmap.costmap import CostmapParams, build_costmap, local_window
    from pfield.costmap.find_valid_pose import find_valid_pose, pose_state
    from pfield.costmap.footprint import Footprint
    from pfield.costmap.map_io import load_map
    from pfield.spatial import Pose

    occupancy = load_map(_example.example_map_path())
    params = CostmapParams(footprint="[[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]]")
    footprint = params.padded_footprint()
    for costmap in (build_costmap(occupancy, params), local_window(occupancy, 2.5, -3.0, params)):
        find_valid_pose(costmap, footprint, Pose((2.5, -3.0, 0.0)), angle_tolerance=0.2)
        pose_state(costmap, footprint, 2.5, -3.0, 0.0)
    Footprint.from_radius(0.2).cells(0.0, 0.0, 0.3, (0.0, 0.0), 0.05)


STEPS: tuple[WarmupStep, ...] = (
    WarmupStep("geometry SDFs", _geometry),
    WarmupStep("task-space field and planner", _task_space),
    WarmupStep("whole-body planner (xarm7)", _whole_body("xarm7")),
    WarmupStep("whole-body planner (panda)", _whole_body("panda")),
    WarmupStep("inverse kinematics", _inverse_kinematics),
    WarmupStep("autonomy vector and assistance", _autonomy),
    WarmupStep("global fallback and retiming", _global_fallback),
    WarmupStep("robot link fitting", _link_fitting),
    WarmupStep("mobile field and controller", _mobile),
    WarmupStep("costmap and find_valid_pose", _costmap),
)

LANES: tuple[tuple[str, ...], ...] = (
    ("task-space field and planner", "mobile field and controller", "costmap and find_valid_pose",
     "autonomy vector and assistance", "robot link fitting"),
    ("whole-body planner (xarm7)", "whole-body planner (panda)", "inverse kinematics", "global fallback and retiming"),
)
"""How :func:`warm` shares the steps after the first between processes when the cache is cold (``jobs`` ≥ 2).
Cold, in one process (2-core x86-64): task space 175 s, whole body (xArm7) 265 s, autonomy and assistance 121 s,
every other step under 20 s after those; steps whose kernels build on another's follow it in its lane."""


# -- running them ---------------------------------------------------------------------------------------

_READY = threading.Event()
_RUN_LOCK = threading.Lock()
_REPORT: WarmupReport | None = None
_THREAD: threading.Thread | None = None
_THREAD_LOCK = threading.Lock()
_FITTED: list[threading.Event] = []  # one per fit_in_background call, set when its fit has ended


def ready() -> bool:
    """True once :func:`warm` has finished in this process and every :func:`fit_in_background` fit has ended
    (thread-safe; never blocks)."""
    return _READY.is_set() and all(done.is_set() for done in tuple(_FITTED))


def fit_in_background(robot: Any) -> threading.Thread:
    """Build ``robot.geometry`` (a :class:`~pfield.robot.RobotModel`'s fitted link model) in a daemon thread;
    :func:`ready` stays false until it has. Each link that is actually fitted (not read from the fit cache)
    is logged at INFO by :mod:`pfield.robot._fit`; a failure is logged as an error and raised again by the
    first request that needs the geometry."""
    done = threading.Event()
    _FITTED.append(done)

    def run() -> None:
        began = time.perf_counter()
        try:
            _ = robot.geometry  # a cached_property: reading it fits the links
        except Exception as exc:  # the node keeps serving what needs no link model
            _LOG.error("fitting the link model of robot %s failed: %s", robot.name, exc)
        else:
            _LOG.info("robot %s: link model ready (%.1f s)", robot.name, time.perf_counter() - began)
        finally:
            done.set()

    thread = threading.Thread(target=run, name="pfield-robot-fit", daemon=True)
    thread.start()
    return thread


def warm(progress: Progress | None = None, steps: Sequence[WarmupStep] = STEPS, jobs: int = 1) -> WarmupReport:
    """Run the warm-up ``steps`` (all by default), once per process: a second call returns the first report.

    ``progress(done, total, name)`` is called before the first step and after each one. Compiles are
    logged by :mod:`pfield._compile_notice` at INFO; a failing step is logged as an error and skipped.
    ``jobs`` ≥ 2 (all steps only): when numba's cache is cold (:func:`_cache_is_cold`), the steps after the
    first first run in
    :data:`LANES`, one process per lane, filling numba's on-disk cache side by side; this process then runs them
    too, loading what the lanes compiled, so that it ends warm either way.
    """
    global _REPORT
    with _RUN_LOCK:
        if _REPORT is not None and steps is STEPS:
            return _REPORT
        seconds: dict[str, float] = {}
        failures: dict[str, str] = {}
        start = time.perf_counter()
        lanes, shown = 0, 0  # progress never goes back (a lane's step counts as done when it finishes)

        def tell(done: int, name: str) -> None:
            nonlocal shown
            shown = max(shown, done)
            if progress is not None:
                progress(shown, len(steps), name)

        tell(0, steps[0].name if steps else "")
        side_by_side = jobs >= 2 and steps is STEPS and _cache_is_cold()
        with _compile_notice.quiet(), _own_info_dropped(), \
                tempfile.TemporaryDirectory(prefix="pfield-warmup-") as scratch:
            for done, step in enumerate(steps, 1):
                began = time.perf_counter()
                try:
                    step.run(Path(scratch))
                except Exception as exc:  # one area failing must not keep the others cold
                    failures[step.name] = f"{type(exc).__name__}: {exc}"
                    _LOG.error("warm-up step %r failed (its kernels compile on first use): %s", step.name, exc)
                seconds[step.name] = time.perf_counter() - began
                if done == 1 and side_by_side:
                    lanes = len(LANES)
                    _run_lanes(tell)
                tell(done, steps[done].name if done < len(steps) else step.name)
        report = WarmupReport(seconds, failures, time.perf_counter() - start, lanes)
        if steps is STEPS:
            _REPORT = report
            _READY.set()
        return report


def _cache_is_cold() -> bool:
    """Whether numba's on-disk cache is empty for pfield (a fresh install, or a cleared cache): one small kernel
    every warm-up compiles anyway is called, and it is cold when that call compiles. The first step no longer
    tells (its geometry is the compiled C++ core)."""
    from pfield._spatial_kernels import matrix_to_quat

    before = _compile_notice.compiles()
    with _compile_notice.quiet():
        matrix_to_quat(np.eye(3))
    return _compile_notice.compiles() > before


def _run_lanes(report: Callable[[int, str], None]) -> None:
    """Run each of :data:`LANES` in a process of its own, all at once (a lane's steps in order, ``python -c``),
    calling ``report(steps done, name)`` as their steps finish; a lane that fails leaves its kernels to this
    process."""
    total, finished, lock = len(STEPS), 1, threading.Lock()

    def follow(lane: tuple[str, ...]) -> None:
        nonlocal finished
        code = "import sys; from pfield.warmup import _lane; _lane(sys.argv[1:])"
        with subprocess.Popen([sys.executable, "-c", code, *lane], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True) as child:
            assert child.stdout is not None
            for line in child.stdout:
                name = line.strip()
                with lock:
                    finished += 1
                    report(min(finished, total - 1), name)
        if child.returncode:
            _LOG.warning("warm-up lane %s exited with %s; this process compiles what it left", lane, child.returncode)

    threads = [threading.Thread(target=follow, args=(lane,), daemon=True) for lane in LANES]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()


def _lane(names: Sequence[str]) -> None:
    """One lane of :func:`_run_lanes` (in its own process): run the named steps, printing each name when done."""
    by_name = {step.name: step for step in STEPS}
    with _compile_notice.quiet(), tempfile.TemporaryDirectory(prefix="pfield-warmup-") as scratch:
        for name in names:
            try:
                by_name[name].run(Path(scratch))
            except Exception as exc:  # the parent process runs the step again and reports the failure
                _LOG.error("warm-up step %r failed in its lane: %s", name, exc)
            print(name, flush=True)


class _OtherThreadsOnly(logging.Filter):
    """Drops the INFO and DEBUG records of one thread (the warm-up's toy plans "fail" by design)."""

    def __init__(self) -> None:
        super().__init__()
        self.thread = threading.get_ident()

    def filter(self, record: logging.LogRecord) -> bool:
        return (record.thread != self.thread or record.levelno >= logging.WARNING
                or record.name == _compile_notice.LOGGER_NAME)


@contextmanager
def _own_info_dropped() -> Iterator[None]:
    """Inside, the handlers of the root and ``pfield`` loggers drop this thread's INFO/DEBUG records (other
    threads log as usual; warnings, errors and the compile notices still show)."""
    dropped = _OtherThreadsOnly()
    handlers = [*logging.getLogger().handlers, *logging.getLogger("pfield").handlers]
    for handler in handlers:
        handler.addFilter(dropped)
    try:
        yield
    finally:
        for handler in handlers:
            handler.removeFilter(dropped)


def start_background(on_done: Callable[[WarmupReport], None] | None = None) -> threading.Thread:
    """Start :func:`warm` in a daemon thread (once per process; later calls return the same thread) and
    call ``on_done(report)`` from it when finished (the thread of an earlier call keeps its own callback)."""
    global _THREAD
    with _THREAD_LOCK:
        if _THREAD is None:
            def run() -> None:
                report = warm()
                _LOG.info("kernels ready (%.1f s%s)", report.total_seconds,
                          f", {len(report.failures)} step(s) failed" if report.failures else "")
                if on_done is not None:
                    on_done(report)

            low, high = _compile_notice.COLD_COMPILE_SECONDS
            _LOG.info("warming the numba kernels in the background (seconds when cached, %d-%d s after an install "
                      "or an edit)", low, high)
            _THREAD = threading.Thread(target=run, name="pfield-warmup", daemon=True)
            _THREAD.start()
        return _THREAD


_SKIPPED_PACKAGES = ("pfield.cli", "pfield.demo", "pfield.viz", "pfield.transport", "pfield.node")


def kernels() -> dict[str, Any]:
    """``{"module.name": dispatcher}`` of every numba kernel defined in pfield's computational packages.

    Kernels marked ``inline="always"`` are compiled into their callers, never on their own; they are left out.
    """
    from numba.core.registry import CPUDispatcher

    import pfield

    found: dict[str, Any] = {}
    for info in pkgutil.walk_packages(pfield.__path__, "pfield."):
        if info.name.startswith(_SKIPPED_PACKAGES) or info.name == __name__:
            continue
        module = importlib.import_module(info.name)
        for name, value in vars(module).items():
            if (isinstance(value, CPUDispatcher) and value.py_func.__module__ == info.name
                    and value.targetoptions.get("inline") != "always"):
                found[f"{info.name}.{name}"] = value
    return found
