"""One problem → one result record: the unit of work every batch backend runs (in a worker or in-process).

A worker keeps a :class:`Workspace`: the robot models it has built, one per robot description
(:class:`~pfield.robot.RobotDescription`, a built-in name or a URDF with its files; ``pfield.scene.RobotSpec``
is the same type), so a robot is loaded once per worker and not once per problem. :func:`solve` never raises
for a problem's own fault: a malformed problem, a failing plan or a timeout become a record with ``status``
``"error"`` or ``"timeout"`` and the ``error`` sentence.
"""

from __future__ import annotations

import hashlib
import logging
import random
import threading
import time
from collections.abc import Iterable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from pfield.errors import InvalidInput
from pfield.field import FieldConfig, PotentialField
from pfield.geometry import Box, Obstacle
from pfield.planning import CancelToken, PlanOptions, PlanStatus
from pfield.planning.result import PlannedPath
from pfield.robot import RobotModel
from pfield.scene import Problem, RobotSpec, mbm_options
from pfield.spatial import Pose

__all__ = ["RECORD_FIELDS", "TIMING_FIELDS", "Workspace", "problem_seed", "solve"]

RECORD_FIELDS = ("scene", "index", "success", "status", "seconds", "cpu_seconds", "steps", "planner", "joint_names",
                 "positions", "times", "clearances", "error")
"""The keys of every result record, in order (the MotionBenchMaker ``--out`` file's fields, plus ``error``)."""
_LOG = logging.getLogger(__name__)
TIMING_FIELDS = ("seconds", "cpu_seconds")
"""The fields that depend on the machine's load: every other field is a pure function of the problem."""


def problem_seed(seed: int, problem: Problem) -> int:
    """The problem's own seed: a hash of (``seed``, scene, index), the same whichever worker runs it."""
    digest = hashlib.blake2b(f"{seed}\0{problem.scene}\0{problem.index}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little") >> 1


class Workspace:
    """What one worker keeps between problems: the robots built so far (by description).

    With ``warm``, each robot given is built and makes a short plan through the field and its global
    fallback at once (:func:`_warm_plan`), so the worker imports the planners, reads the robot's fitted link model
    and sets up the fallback's search before its first problem, not while timing it.
    """

    def __init__(self, robots: Iterable[RobotSpec] = (), warm: bool = False) -> None:
        self._robots: dict[RobotSpec, RobotModel] = {}
        for spec in robots:
            try:
                robot = self.robot(spec)
                if warm:
                    _warm_plan(robot)
            except Exception:  # the problems that need this robot report the error themselves
                _LOG.exception("building robot %s failed", spec)
        if warm:
            PotentialField(FieldConfig(), Pose((0.01, 0.0, 0.0))).plan(Pose(), max_iterations=2,
                                                                        global_fallback=False)

    def robot(self, spec: RobotSpec) -> RobotModel:
        if spec not in self._robots:
            self._robots[spec] = spec.build()
        return self._robots[spec]


_WARM_OPTIONS = PlanOptions(max_iterations=2000, stagnation_window=0.02, stagnation_progress=10.0)
"""The field stops after two steps (no 10 m of progress in a 0.02 s window), so the fallback runs."""


def _warm_plan(robot: RobotModel) -> PlannedPath:
    """A plan of ``robot`` from the middle of its joint ranges to the pose 0.3 rad further on its first joint,
    past a box far away: the field's loop runs two steps and stagnates by :data:`_WARM_OPTIONS`, then the
    global fallback solves IK for goal configurations, searches, tracks the path and retimes it, so each of those
    has run once before the first timed problem (a pose goal takes every step a joint goal takes, and IK)."""
    q = robot.mid_configuration
    goal = q.copy()
    goal[0] += 0.3 if q[0] + 0.3 <= robot.upper_limits[0] else -0.3
    far = [Obstacle("warm-up", Box(0.1, 0.1, 0.1), Pose((5.0, 5.0, 5.0)))]
    return PotentialField(FieldConfig(), robot.forward_kinematics(goal), far).plan_whole_body(
        robot, q, options=_WARM_OPTIONS)


def _joints(robot: RobotModel, values: Mapping[str, float], field: str) -> np.ndarray:
    missing = [name for name in robot.joint_names if name not in values]
    if missing:
        raise InvalidInput(field, sorted(values), f"no value for the robot's joints {missing}")
    vector = np.array([float(values[name]) for name in robot.joint_names])
    # MoveIt's limits differ slightly from the URDF's: clip onto the model's
    return np.clip(vector, robot.lower_limits, robot.upper_limits)


def _plan(problem: Problem, workspace: Workspace, token: CancelToken) -> tuple[PlannedPath, RobotModel | None]:
    if problem.robot is None:
        assert problem.goal is not None and isinstance(problem.start, type(problem.goal))
        assert problem.options is not None  # Problem refuses None without a robot
        field = PotentialField(problem.config, problem.goal, problem.obstacles)
        return field.plan(problem.start, options=replace(problem.options, cancel=token)), None
    robot = workspace.robot(problem.robot)
    options = replace(mbm_options(robot) if problem.options is None else problem.options,
                      cancel=token)
    start = _joints(robot, problem.start, "start")  # type: ignore[arg-type]
    goal, goal_q = problem.goal, None
    if goal is None:  # a joint goal: the field's goal is its pose, the fallback searches to the joints
        assert problem.goal_joints is not None
        goal_q = _joints(robot, problem.goal_joints, "goal_joints")
        goal = robot.forward_kinematics(goal_q)
    field = PotentialField(problem.config, goal, problem.obstacles)
    return field.plan_whole_body(robot, start, options=options, goal_configuration=goal_q), robot


def _error(problem: Any, status: str, message: str, seconds: float = 0.0, cpu: float = 0.0) -> dict[str, Any]:
    scene = getattr(problem, "scene", "?")
    index = getattr(problem, "index", -1)
    return {"scene": scene, "index": index, "success": False, "status": status, "seconds": seconds,
            "cpu_seconds": cpu, "steps": 0, "planner": "", "joint_names": [], "positions": [], "times": [],
            "clearances": [], "error": message}


def solve(problem: Problem, workspace: Workspace, timeout: float | None = None, seed: int = 0) -> dict[str, Any]:
    """Plan ``problem``; the JSON-ready record (:data:`RECORD_FIELDS`).

    ``status`` is the :class:`PlanStatus` name in lower case, ``"timeout"`` when the plan was still running
    after ``timeout`` seconds (it is cancelled then; the waypoints so far are kept), or ``"error"`` when the
    problem could not be planned (``error`` says why). ``positions`` are the joint positions (whole body) or
    the end-effector positions (task space) from the start on, ``times`` their times (s), ``clearances`` the
    plan's clearances (m), ``steps`` its iterations. Python's and numpy's global random generators are
    seeded with :func:`problem_seed` before the plan, so nothing the plan draws from them depends on the
    worker or the order.
    """
    if not isinstance(problem, Problem):
        return _error(problem, "error", f"problem: expected a pfield.scene.Problem, got {type(problem).__name__}")
    if problem.error:
        return _error(problem, "error", problem.error)
    own = problem_seed(seed, problem)
    random.seed(own)
    np.random.seed(own % 2**32)  # noqa: NPY002 (the legacy global generator is what third-party code draws from)
    token = CancelToken()
    timer = threading.Timer(timeout, token.cancel) if timeout is not None else None
    begin, cpu = time.perf_counter(), time.process_time()
    try:
        if timer is not None:
            timer.start()
        path, robot = _plan(problem, workspace, token)
    except Exception as exc:  # a problem's own fault is reported, never raised: the batch goes on
        return _error(problem, "error", f"{type(exc).__name__}: {exc}", time.perf_counter() - begin,
                      time.process_time() - cpu)
    finally:
        if timer is not None:
            timer.cancel()
    seconds, cpu = time.perf_counter() - begin, time.process_time() - cpu
    timed_out = token.cancelled and path.status == PlanStatus.CANCELLED
    positions = path.joint_positions if path.joint_positions is not None else path.positions
    return {"scene": problem.scene, "index": problem.index, "success": bool(path.success),
            "status": "timeout" if timed_out else path.status.name.lower(), "seconds": seconds,
            "cpu_seconds": cpu, "steps": int(path.iterations), "planner": path.planner,
            "joint_names": list(robot.joint_names) if robot is not None else [],
            "positions": positions.tolist(), "times": path.times.tolist(), "clearances": path.clearances.tolist(),
            "error": f"timeout: still planning after {timeout} s" if timed_out else
            ("" if path.success else path.failure_reason)}
