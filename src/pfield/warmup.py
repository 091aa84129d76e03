"""A fast self-check of pfield on this machine (``pfield warmup``), and the node's readiness.

pfield's per-step kernels are the compiled core (:mod:`pfield._core`, built when pfield is installed), so nothing
compiles on first use, and the built-in robots' link models ship with pfield
(:data:`pfield.robot._fit.SHIPPED_DIRECTORY`); a URDF robot new to the machine has its link model fitted once
(seconds), then read from pfield's cache (:func:`pfield.robot._fit.cache_root`). :func:`check` runs :data:`STEPS`,
each on a tiny problem, and says what each checked:

* the compiled core imports, with every part;
* the signed distances of one obstacle of every shape (a triangle mesh included) against closed forms;
* each built-in robot's link model, read from the user's cache or the fits shipped with pfield;
* a task-space plan and an xArm7 whole-body plan, each reaching its goal.

For the node (``pfield serve``, ``pfield ros2 node``):

* :func:`start_background` — :func:`check` of :data:`NODE_STEPS` in a background thread, once per process;
* :func:`fit_in_background` — build a robot's fitted link model (``robot.geometry``) in a background thread: the
  node's robot, whose first fit takes seconds;
* :func:`ready` — thread-safe: has the background check finished, and has every robot handed to
  :func:`fit_in_background` its link model (what ``GET /health`` reports)?

A failing step is logged and counted in :class:`CheckReport`; the other steps still run.

The background threads are not daemons: a process that stops while one runs waits for it (a tiny plan or one
robot's fit) before the interpreter finalizes. A daemon thread would be stopped inside a core call that has
released the GIL, and unwinding it through the core's frames aborts the process ("terminate called without an
active exception").
"""

from __future__ import annotations

import logging
import math
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["NODE_STEPS", "STEPS", "CheckReport", "CheckStep", "check", "fit_in_background", "ready", "start_background",
           "start_up_errors"]

_LOG = logging.getLogger(__name__)

Progress = Callable[[int, int, str], None]
"""``progress(done, total, step_name)``: called before the first step (done = 0, the first step's name) and after
each step (the next step's name, or the last one's when all are done)."""


@dataclass(frozen=True)
class CheckStep:
    """One step: ``run(scratch_dir)`` exercises one area on a tiny problem and returns what it checked (one line);
    it raises when the area does not work."""

    name: str
    run: Callable[[Path], str]


@dataclass(frozen=True)
class CheckReport:
    """What :func:`check` did: per step (in order) its seconds and what it checked, the failed steps with their
    error, and the total seconds."""

    seconds: dict[str, float]
    checked: dict[str, str]
    failures: dict[str, str]
    total_seconds: float

    @property
    def ok(self) -> bool:
        return not self.failures


# -- the steps ------------------------------------------------------------------------------------------

def _compiled_core(scratch: Path) -> str:
    import importlib

    import pfield._core as core

    # each of these binds its part of the core when imported: a core built from other sources fails here
    for package in ("geometry", "field", "planning", "robot", "shared_control", "mobile", "costmap"):
        importlib.import_module(f"pfield.{package}")
    parts = sorted(name for name, value in vars(core).items() if type(value).__name__ == "module")
    return f"pfield._core ({len(parts)} parts, {Path(core.__file__).name}) and the packages over it import"


def _signed_distances(scratch: Path) -> str:
    from pfield.geometry import pack_obstacles, signed_distances
    from pfield.planning.scenes import seed_obstacles

    obstacles = seed_obstacles(scratch / "meshes")  # one obstacle of every shape, a triangle mesh included
    points = np.array([[0.4, 0.0, 0.5], [0.0, 0.0, 0.0], [0.5, 0.0, 0.1], [0.5, 0.2, 0.3]])
    distances, normals = signed_distances(pack_obstacles(obstacles), points)
    if not (np.all(np.isfinite(distances)) and np.allclose(np.linalg.norm(normals, axis=2), 1.0, atol=1e-9)):
        raise RuntimeError("a signed distance or normal is not finite, or a normal not of unit length")
    ball, mesh = distances[:, 0], distances[:, 5]  # a 10 cm sphere at (0.4, 0, 0.1); an icosphere of 6 cm there
    if not (math.isclose(ball[0], 0.3, abs_tol=1e-12) and -0.06 <= mesh[2] < -0.04):
        raise RuntimeError(f"wrong distances: sphere {ball[0]} (expected 0.3), mesh centre {mesh[2]} (about -0.05)")
    return f"{len(obstacles)} obstacles of every shape, a mesh included: exact where closed forms tell"


def _robot_link_models(scratch: Path) -> str:
    from pfield.robot import RobotModel, fit_cache_directory
    from pfield.robot.catalog import BUILTIN_ROBOTS

    parts = []
    for name in BUILTIN_ROBOTS:
        began = time.perf_counter()
        geometry = RobotModel.builtin(name).geometry  # fits the links, or reads their fits from the cache
        if not (len(geometry.prim_r) and np.all(geometry.prim_r > 0.0)):
            raise RuntimeError(f"{name}: the link model has no primitives or a radius ≤ 0")
        parts.append(f"{name} {len(geometry.capsules)} links, {len(geometry.prim_r)} primitives "
                     f"({time.perf_counter() - began:.1f} s)")
    cache = fit_cache_directory()
    return "; ".join(parts) + f"; fits cached in {cache}" if cache else "; ".join(parts) + "; no writable fit cache"


def _task_space_plan(scratch: Path) -> str:
    from pfield.field import FieldConfig, PotentialField
    from pfield.spatial import Pose

    path = PotentialField(FieldConfig(), Pose((0.5, 0.0, 0.3))).plan(Pose((0.2, 0.0, 0.3)))
    if not path.success:
        raise RuntimeError(f"0.3 m in free space did not reach its goal: {path.status.name}, {path.failure_reason}")
    return f"0.3 m in free space: reached in {path.iterations} steps"


def _whole_body_plan(scratch: Path) -> str:
    from pfield.field import FieldConfig, PotentialField
    from pfield.robot import RobotModel

    robot = RobotModel.builtin("xarm7")
    q0 = robot.mid_configuration
    path = PotentialField(FieldConfig(), robot.forward_kinematics(q0 + 0.1)).plan_whole_body(robot, q0)
    if not path.success:
        raise RuntimeError(f"the xArm7 did not reach its goal: {path.status.name}, {path.failure_reason}")
    return f"xArm7, every joint +0.1 rad: reached in {path.iterations} steps"


STEPS: tuple[CheckStep, ...] = (
    CheckStep("compiled core", _compiled_core),
    CheckStep("signed distances", _signed_distances),
    CheckStep("robot link models", _robot_link_models),
    CheckStep("task-space plan", _task_space_plan),
    CheckStep("whole-body plan", _whole_body_plan),
)

NODE_STEPS: tuple[CheckStep, ...] = tuple(step for step in STEPS if step.name != "robot link models")
"""What a node checks on start (:func:`start_background`): not every built-in robot's link model, since the node
fits its own robot (:func:`fit_in_background`)."""


# -- running them ---------------------------------------------------------------------------------------

_READY = threading.Event()
_FITTED: list[threading.Event] = []  # one per fit_in_background call, set when its fit has ended
_FIT_FAILURES: list[str] = []  # why each failed fit failed
_THREAD: threading.Thread | None = None
_THREAD_LOCK = threading.Lock()


def check(progress: Progress | None = None, steps: Sequence[CheckStep] | None = None) -> CheckReport:
    """Run ``steps`` (default :data:`STEPS`) in order; a failing step is logged as an error and the others still
    run."""
    steps = STEPS if steps is None else steps
    seconds: dict[str, float] = {}
    checked: dict[str, str] = {}
    failures: dict[str, str] = {}
    start = time.perf_counter()
    if progress is not None:
        progress(0, len(steps), steps[0].name if steps else "")
    with tempfile.TemporaryDirectory(prefix="pfield-check-") as scratch:
        for done, step in enumerate(steps, 1):
            began = time.perf_counter()
            try:
                checked[step.name] = step.run(Path(scratch))
            except Exception as exc:  # one area failing must not hide the state of the others
                failures[step.name] = f"{type(exc).__name__}: {exc}"
                _LOG.error("self-check step %r failed: %s", step.name, exc)
            seconds[step.name] = time.perf_counter() - began
            if progress is not None:
                progress(done, len(steps), steps[done].name if done < len(steps) else step.name)
    return CheckReport(seconds, checked, failures, time.perf_counter() - start)


def ready() -> bool:
    """True once :func:`start_background`'s check has finished in this process and every
    :func:`fit_in_background` fit has ended, none of them failed (thread-safe; never blocks)."""
    return _READY.is_set() and all(done.is_set() for done in tuple(_FITTED)) and not _FIT_FAILURES


def start_up_errors() -> list[str]:
    """Why the start-up work cannot be done: each :func:`fit_in_background` fit that failed (a robot whose link
    model cannot be fitted cannot plan; ``GET /health`` reports it)."""
    return list(_FIT_FAILURES)


def fit_in_background(robot: Any) -> threading.Thread:
    """Build ``robot.geometry`` (a :class:`~pfield.robot.RobotModel`'s fitted link model) in a background thread;
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
            _FIT_FAILURES.append(f"fitting the link model of robot {robot.name} failed: {exc}")
            _LOG.error("%s", _FIT_FAILURES[-1])
        else:
            _LOG.info("robot %s: link model ready (%.1f s)", robot.name, time.perf_counter() - began)
        finally:
            done.set()

    thread = threading.Thread(target=run, name="pfield-robot-fit", daemon=False)  # see the module's note
    thread.start()
    return thread


def start_background(on_done: Callable[[CheckReport], None] | None = None) -> threading.Thread:
    """Start :func:`check` of :data:`NODE_STEPS` in a background thread (once per process; later calls return the same
    thread), log its outcome (``self-check passed (… s)`` at INFO) and call ``on_done(report)`` from it when
    finished (the thread of an earlier call keeps its own callback)."""
    global _THREAD
    with _THREAD_LOCK:
        if _THREAD is None:
            def run() -> None:
                report = check(steps=NODE_STEPS)  # a failing step is caught, logged and reported
                if report.ok:
                    _LOG.info("self-check passed (%.2f s)", report.total_seconds)
                else:
                    _LOG.error("self-check: %d of %d steps failed (%s)", len(report.failures), len(NODE_STEPS),
                               ", ".join(report.failures))
                _READY.set()  # ready either way: the failures are logged, the node serves what works
                if on_done is not None:
                    on_done(report)

            _THREAD = threading.Thread(target=run, name="pfield-check", daemon=False)  # see the module's note
            _THREAD.start()
        return _THREAD
