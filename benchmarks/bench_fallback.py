"""MotionBenchMaker Panda, side by side: the field alone, the field with its global fallback, OMPL RRT-Connect.

Data: the MBM dev archive of ``../shared/benchmarks/mbm`` (its README), extracted to a temporary directory;
problem loading is :mod:`benchmarks.bench_mbm`'s. The Panda's fingers are locked at **0.065 m** (the
requests' value; the data set's robot allows it, example-robot-data's URDF limit is 0.04 m). Planner
settings are bench_mbm's (field parameters, dt 0.02 s, 1 cm / 0.05 rad, 10000 steps; the goal is the pose
FK(goal joints) at ``panda_hand_tcp``).

* **field** — ``plan_whole_body(..., global_fallback=False)``;
* **field+global** — ``plan_whole_body(..., global_fallback=True, global_time_limit=5)`` with the request's
  goal joints as ``goal_configuration`` (the goal OMPL is given): the field, and when it stagnates, the
  compiled RRT-Connect on the fitted link model to those joints, shortcutting, and the field tracking the path;
* **OMPL** — ``ompl`` 2.0.1 RRT-Connect (default range and validity resolution), a 5 s limit, from the start
  joints to the request's goal joints, each state checked exactly: coal on the robot's collision meshes
  (convex hulls) through :class:`pfield.robot.collision.CollisionChecker` (a Python callback per state).

Reported per scene and planner: success rate, median and p95 planning time (every problem; a failure
counts with the time it took), median joint-space path length (successes), the minimum exact mesh
clearance over the successful trajectories (every waypoint, and edges interpolated every ≤ 0.01 rad), the
number of successful trajectories that the exact check finds in collision, and the median number of
states checked (field: none; field+global: the compiled search's checks; OMPL: the callback's calls). The
note of the field+global row gives the time ratio against OMPL (median over median) and whether the
problems that the field alone solves kept the field's plan unchanged.

Run: ``python -m benchmarks.bench_fallback [--limit N] [--scenes NAME ...] [--out FILE.jsonl]`` (default
20 problems per scene; ``make bench`` runs 3 per scene). ``--out`` writes one JSON object per plan with
``scene``, ``index``, ``success``, ``status``, ``seconds``, ``planner``, ``joint_names``, ``positions``,
``times`` (joint trajectory, time-parameterised for the pfield planners).
"""

from __future__ import annotations

import argparse
import itertools
import json
import logging
import math
import tarfile
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from benchmarks._common import BenchRow
from benchmarks.bench_mbm import ARCHIVE, CONFIG, SCENES, request_joints, scene_obstacles
from pfield.field import PotentialField
from pfield.robot import RobotModel
from pfield.robot._loader import load_urdf, read_disabled_pairs
from pfield.robot.catalog import builtin_spec, example_robot_data_root
from pfield.robot.collision import CollisionChecker

SECTION = "MotionBenchMaker Panda: field, field + global fallback, OMPL RRT-Connect"
FINGER_OPENING = 0.065
OMPL_TIME_LIMIT = 5.0
CHECK_RESOLUTION = 0.01
PLANNERS = ("field", "field+global", "OMPL RRT-Connect")


def panda_open_fingers() -> RobotModel:
    """The built-in Panda with both finger joints locked at :data:`FINGER_OPENING` (m)."""
    spec = builtin_spec("panda")
    root = example_robot_data_root()
    locked = {name: FINGER_OPENING for name in spec.locked_joints}
    loaded = load_urdf(root / spec.urdf, {"example-robot-data": root}, locked)
    return RobotModel(loaded, spec.end_effector, read_disabled_pairs(root / spec.srdf), name="panda")


@dataclass
class Outcome:
    """One plan of one planner."""

    success: bool
    status: str
    seconds: float
    planner: str
    positions: np.ndarray
    times: np.ndarray
    states: int = 0
    length: float = math.nan
    clearance: float = math.nan
    colliding: bool = False
    extra: dict[str, Any] = field(default_factory=dict)


class _StateCounter(logging.Handler):
    """Reads ``states_checked`` off the global fallback's log records."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.states = 0

    def emit(self, record: logging.LogRecord) -> None:
        self.states += int(getattr(record, "states_checked", 0))


@contextmanager
def _counting() -> Iterator[_StateCounter]:
    logger = logging.getLogger("pfield.planning.fallback")
    handler, level = _StateCounter(), logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG)
    try:
        yield handler
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def _pfield(robot: RobotModel, field_: PotentialField, start: np.ndarray, goal: np.ndarray, fallback: bool
            ) -> Outcome:
    with _counting() as counter:
        begin = time.perf_counter()
        path = field_.plan_whole_body(robot, start, 0.02, 0.01, 10000, global_fallback=fallback,
                                      global_time_limit=OMPL_TIME_LIMIT, goal_configuration=goal)
        seconds = time.perf_counter() - begin
    assert path.joint_positions is not None and path.trajectory is not None
    status = path.status.name.lower()
    return Outcome(path.success, status, seconds, path.planner, np.array(path.joint_positions),
                   np.array(path.trajectory.times), counter.states,
                   extra={"trajectory": np.array(path.trajectory.positions)})


def _ompl(robot: RobotModel, checker: CollisionChecker, start: np.ndarray, goal: np.ndarray) -> Outcome:
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    n = robot.n_joints
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    for j in range(n):
        bounds.setLow(j, float(robot.lower_limits[j]))
        bounds.setHigh(j, float(robot.upper_limits[j]))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    calls = [0]

    def valid(state: Any) -> bool:
        calls[0] += 1
        return not checker.check([state[j] for j in range(n)]).in_collision

    setup.setStateValidityChecker(valid)
    begin_state, end_state = space.allocState(), space.allocState()
    for j in range(n):
        begin_state[j], end_state[j] = float(start[j]), float(goal[j])
    setup.setStartAndGoalStates(begin_state, end_state)
    setup.setPlanner(og.RRTConnect(setup.getSpaceInformation()))
    begin = time.perf_counter()
    solved = setup.solve(OMPL_TIME_LIMIT)
    seconds = time.perf_counter() - begin
    success = bool(solved) and setup.haveExactSolutionPath()
    if not success:
        return Outcome(False, "timeout", seconds, PLANNERS[2], start[None], np.zeros(1), calls[0])
    path = setup.getSolutionPath()
    positions = np.array([[path.getState(i)[j] for j in range(n)] for i in range(path.getStateCount())])
    return Outcome(True, "reached", seconds, PLANNERS[2], positions, np.arange(len(positions), dtype=float),
                   calls[0])


def _exact(checker: CollisionChecker, positions: np.ndarray) -> tuple[float, bool]:
    """Smallest exact distance (robot–obstacle or self) over every waypoint and ≤ 0.01 rad interpolations."""
    samples = [positions[0]]
    for a, b in itertools.pairwise(positions):
        steps = max(1, math.ceil(float(np.max(np.abs(b - a))) / CHECK_RESOLUTION))
        samples.extend(a + (b - a) * (k / steps) for k in range(1, steps + 1))
    smallest = math.inf
    for q in samples:
        distance, _, own, _ = checker.distances(q)
        smallest = min(smallest, distance, own)
    return smallest, smallest <= 0.0


def _problem(robot: RobotModel, directory: Path, index: int) -> dict[str, Outcome]:
    scene = yaml.safe_load((directory / f"scene{index:04d}.yaml").read_text())
    request = yaml.safe_load((directory / f"request{index:04d}.yaml").read_text())
    start, goal = request_joints(request)
    start = np.clip(start, robot.lower_limits, robot.upper_limits)
    goal = np.clip(goal, robot.lower_limits, robot.upper_limits)
    obstacles = scene_obstacles(scene)
    field_ = PotentialField(CONFIG, robot.forward_kinematics(goal), obstacles)
    checker = CollisionChecker(robot, obstacles)
    results = {PLANNERS[0]: _pfield(robot, field_, start, goal, False),
               PLANNERS[1]: _pfield(robot, field_, start, goal, True),
               PLANNERS[2]: _ompl(robot, checker, start, goal)}
    for outcome in results.values():
        if outcome.success:
            outcome.length = float(np.linalg.norm(np.diff(outcome.positions, axis=0), axis=1).sum())
            outcome.clearance, outcome.colliding = _exact(checker, outcome.positions)
    return results


def _warm_up(robot: RobotModel, root: Path) -> None:
    """Compile every kernel before timing: a table_under_pick problem (the field stagnates, so the fallback
    runs) planned once with each pfield planner."""
    directory = root / SCENES[1]
    scene = yaml.safe_load((directory / "scene0001.yaml").read_text())
    start, goal = request_joints(yaml.safe_load((directory / "request0001.yaml").read_text()))
    start = np.clip(start, robot.lower_limits, robot.upper_limits)
    goal = np.clip(goal, robot.lower_limits, robot.upper_limits)
    field_ = PotentialField(CONFIG, robot.forward_kinematics(goal), scene_obstacles(scene))
    for fallback in (False, True):
        _pfield(robot, field_, start, goal, fallback)


def _percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else math.nan


def _rows(name: str, results: list[dict[str, Outcome]]) -> list[BenchRow]:
    rows = []
    medians = {p: _percentile([r[p].seconds for r in results], 50) for p in PLANNERS}
    solved_alone = [r for r in results if r[PLANNERS[0]].success]
    unchanged = sum(1 for r in solved_alone if r[PLANNERS[1]].planner == "field"
                    and np.array_equal(r[PLANNERS[0]].positions, r[PLANNERS[1]].positions))
    for planner in PLANNERS:
        outcomes = [r[planner] for r in results]
        good = [o for o in outcomes if o.success]
        seconds = [o.seconds for o in outcomes]
        note = (f"{len(good)}/{len(outcomes)}; median {medians[planner] * 1e3:.1f} ms, p95 "
                f"{_percentile(seconds, 95) * 1e3:.1f} ms; path {_percentile([o.length for o in good], 50):.2f} rad; "
                f"min exact clearance {min((o.clearance for o in good), default=math.nan) * 100:.2f} cm; "
                f"in collision {sum(o.colliding for o in good)}; states checked "
                f"{_percentile([float(o.states) for o in outcomes], 50):.0f}")
        if planner == PLANNERS[1]:
            ratio = medians[PLANNERS[2]] / medians[planner] if medians[planner] > 0 else math.inf
            note += (f"; {ratio:.1f}× faster than OMPL (median); fallback used "
                     f"{sum(o.planner == 'field+global' for o in outcomes)}×; field-alone successes unchanged "
                     f"{unchanged}/{len(solved_alone)}")
        rows.append(BenchRow(SECTION, f"{name}: {planner} success", 100.0 * len(good) / len(outcomes), "%",
                             target=95.0 if planner == PLANNERS[1] else None, higher_is_better=True, note=note))
        rows.append(BenchRow(SECTION, f"{name}: {planner} median time", medians[planner] * 1e3, "ms",
                             target=20.0 if planner == PLANNERS[1] else None))
        durations = [float(o.times[-1]) for o in good if o.planner != PLANNERS[2] and len(o.times)]
        if durations:  # what a robot takes to execute the retimed trajectory (the robot's acceleration limits)
            rows.append(BenchRow(SECTION, f"{name}: {planner} median trajectory duration",
                                 _percentile(durations, 50), "s",
                                 note=f"p95 {_percentile(durations, 95):.2f} s over {len(durations)} trajectories"))
    return rows


def _records(name: str, index: int, results: dict[str, Outcome], joint_names: tuple[str, ...]) -> Iterator[str]:
    for outcome in results.values():
        positions = outcome.extra.get("trajectory", outcome.positions)
        yield json.dumps({"scene": name, "index": index, "success": outcome.success, "status": outcome.status,
                          "seconds": outcome.seconds, "planner": outcome.planner, "joint_names": list(joint_names),
                          "positions": np.asarray(positions).tolist(), "times": outcome.times.tolist(),
                          "states_checked": outcome.states})


def bench(limit: int, scenes: tuple[str, ...] = SCENES, out: Path | None = None) -> list[BenchRow]:
    """Plan ``limit`` problems of each scene with the three planners; rows for :mod:`benchmarks.run`."""
    if not ARCHIVE.exists():
        return [BenchRow(SECTION, "skipped", 0.0, "", note=f"{ARCHIVE} not found")]
    robot = panda_open_fingers()
    rows: list[BenchRow] = []
    lines: list[str] = []
    with tempfile.TemporaryDirectory() as tmp:
        with tarfile.open(ARCHIVE) as archive:
            archive.extractall(tmp, filter="data")
        root = next(Path(tmp).rglob(SCENES[0])).parent
        _warm_up(robot, root)
        for name in scenes:
            results = []
            for index in range(1, limit + 1):
                problem = _problem(robot, root / name, index)
                results.append(problem)
                lines.extend(_records(name, index, problem, robot.joint_names))
            rows.extend(_rows(name.removesuffix("_panda"), results))
    if out is not None:
        out.write_text("".join(line + "\n" for line in lines))
    return rows


def run(quick: bool) -> list[BenchRow]:
    return bench(3 if quick else 20)


def _table(rows: list[BenchRow]) -> str:
    lines = ["| scene: planner | value | target | note |", "|---|---|---|---|"]
    for row in rows:
        target = "" if row.target is None else f"{row.target:g}"
        lines.append(f"| {row.name} | {row.value:.1f} {row.unit} | {target} | {row.note} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=20, help="problems per scene (from 1)")
    parser.add_argument("--scenes", nargs="*", default=list(SCENES), help="scene folder names")
    parser.add_argument("--out", type=Path, default=None, help="JSON-lines file of every plan")
    args = parser.parse_args()
    print(_table(bench(args.limit, tuple(args.scenes), args.out)))


if __name__ == "__main__":
    main()
