"""MotionBenchMaker on several robots: pfield's whole-body planner against OMPL RRT-Connect, every claim checked.

Robots (:data:`ROBOTS`) and their data (``../shared/benchmarks/mbm``, READMEs there), extracted to a temporary
directory at run time and never copied into the project:

* **panda** — the built-in Panda with both fingers locked at **0.065 m** (the requests' value; the data set's
  robot allows it, example-robot-data's URDF limit is 0.04 m); ``panda_problems_dev.tar.bz2`` holds 4 of MBM's
  7 Panda scenes (table_pick, table_under_pick, box, bookshelf_small): the other three are not on this machine
  and the table says so;
* **ur5** — the UR5 with a Robotiq 85 gripper, written only from its files (``ur5/ur5.urdf``, ``ur5.srdf``,
  ``meshes/``; ``RobotModel.from_urdf(..., end_effector="tool0", package_paths={"meshes": ...})``), its 7 scenes
  in ``ur5/ur5_problems.tar.bz2``. The requests' six Robotiq joints are fixed joints of this URDF.

Per problem (problem loading: :func:`benchmarks.bench_mbm.read_problem`; joint values clipped onto the limits):

* **valid** — start and goal are clear under the bench's own exact check (:class:`benchmarks._common.ExactRobot`:
  pinocchio + coal on the link meshes, the obstacles' exact shapes, the self pairs the SRDF does not disable);
  only valid problems are planned, and success counts over them;
* **pfield** — ``PotentialField(MBM_CONFIG, FK(goal), obstacles).plan_whole_body(robot, start,
  options=mbm_options(robot), goal_configuration=goal)``: the field, and when it stagnates its global
  fallback (5 s, the time limit of ``MBM_OPTIONS``), as a user calls it (``pfield batch`` plans MoveIt problems with
  the same options: the robot's step, Panda 0.02 s, UR5 0.05 s), once with each of the search's seeds
  :data:`SEEDS` (``PlanOptions.global_seed``; 0 is a user's default): the figures pool every seed's plans, so that
  they measure the planner and not one seed's luck;
* **OMPL RRT-Connect** — ``ompl`` 2.0.1 (the ``bench`` extra), default range, from the start joints to the goal
  joints within :data:`OMPL_TIME_LIMIT` s, then ``simplifySolution`` within the remaining time (at most
  :data:`SIMPLIFY_TIME` s; OMPL looks at its deadline only between its steps, so a plan may overrun it); states are
  checked by the same exact check, and motions every :data:`OMPL_RESOLUTION` rad (L2, so also in max-norm).

Every claimed success is then checked independently — the executed trajectory (pfield's retimed
``path.trajectory``; OMPL's simplified path) at every waypoint and at most 0.01 rad (max-norm) between them
(:meth:`benchmarks._common.ExactScene.path_contact`, none of the planner's collision code): the ``colliding``
column counts the claims it finds in contact, and must be 0.

Reported per robot, scene and planner: valid/total problems, success over the valid ones, median and p95 wall
planning time (every valid problem; a failure counts with the time it took; the CPU is often shared, so the JSON
records also hold CPU time), median joint path length (rad, L2 over the waypoints, successes), median trajectory
duration (s, pfield's retimed trajectories) and the colliding claims. The failures and collisions are listed by
scene, index and status. ``make bench`` also writes every plan's figures (:data:`PLANS_CSV`) and draws the planning
times from them (:data:`TIMES_PICTURE`; ``--redraw CSV`` draws it again from a saved file).

Run: ``python -m benchmarks.bench_fallback [--robot panda|ur5 ...] [--limit N] [--scenes NAME ...]
[--seeds SEED ...] [--out FILE.jsonl]`` (default: both robots, every problem, the seeds of :data:`SEEDS`; ``make
bench`` runs :data:`QUICK_LIMIT` problems per scene, a full ``make bench`` every problem). ``--out`` writes one JSON
object per plan (``robot``, ``scene``, ``index``, ``planner``, ``seed``, ``success``, ``status``, ``seconds``,
``cpu_seconds``, ``joint_names``, ``positions``,
``times``, ``contact``).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import logging
import math
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from rich.progress import Progress

from benchmarks._common import BenchRow, ExactRobot, ExactScene, Report
from benchmarks.bench_mbm import ARCHIVE, CONFIG, extracted_scene_folders, problem_indices, read_problem
from pfield.field import PotentialField
from pfield.planning.options import SEED_LIMIT
from pfield.robot import RobotModel
from pfield.robot._loader import load_urdf
from pfield.robot.catalog import builtin_spec, example_robot_data_root
from pfield.robot.srdf import read_disabled_pairs
from pfield.scene import mbm_options

SECTION = "MotionBenchMaker: pfield (field + global fallback) and OMPL RRT-Connect, exact check"
FINGER_OPENING = 0.065
OMPL_TIME_LIMIT = 5.0
OMPL_RESOLUTION = 0.01
SIMPLIFY_TIME = 1.0
CHECK_RESOLUTION = 0.01
QUICK_LIMIT = 2
PLANNERS = ("pfield", "OMPL RRT-Connect")
MBM_SCENES = ("table_pick", "table_under_pick", "box", "bookshelf_small", "bookshelf_tall", "bookshelf_thin", "cage")
UR5_DIR = ARCHIVE.parent / "ur5"
SEEDS = (0, 1, 2)
"""The global search's seeds (``PlanOptions.global_seed``) pfield plans every valid problem with: RRT-Connect's time
to a path is heavy-tailed and differs from seed to seed, so one seed's median can be luck (the UR5's cage on this
machine, 2026-12-08: median 22.8, 66.6 and 50.9 ms with seeds 0, 1 and 2). The table's figures pool every seed's
plans; 0 is the default a user's plan runs with."""


def panda_open_fingers() -> RobotModel:
    """The built-in Panda with both finger joints locked at :data:`FINGER_OPENING` (m)."""
    spec = builtin_spec("panda")
    root = example_robot_data_root()
    locked = {name: FINGER_OPENING for name in spec.locked_joints}
    loaded = load_urdf(root / spec.urdf, {"example-robot-data": root}, locked)
    return RobotModel(loaded, spec.end_effector, read_disabled_pairs(root / spec.srdf), name="panda")


def _panda_exact(robot: RobotModel) -> ExactRobot:
    spec = builtin_spec("panda")
    root = example_robot_data_root()
    return ExactRobot(root / spec.urdf, [root.parent], robot.joint_names, root / spec.srdf,
                      fixed={name: FINGER_OPENING for name in spec.locked_joints})


def ur5_robot() -> RobotModel:
    """The MBM UR5 with its Robotiq gripper, from its files only (``../shared/benchmarks/mbm/ur5``)."""
    return RobotModel.from_urdf(UR5_DIR / "ur5.urdf", end_effector="tool0",
                                package_paths={"meshes": UR5_DIR / "meshes"}, srdf=UR5_DIR / "ur5.srdf")


def _ur5_exact(robot: RobotModel) -> ExactRobot:
    return ExactRobot(UR5_DIR / "ur5.urdf", [UR5_DIR], robot.joint_names, UR5_DIR / "ur5.srdf")


@dataclass(frozen=True)
class MbmRobot:
    """A robot of the table: its problem archive, its scene folders' suffix, its base link, how to build it for
    pfield (``model``) and for the bench's exact check (``exact``)."""

    name: str
    archive: Path
    suffix: str
    base_link: str
    model: Callable[[], RobotModel]
    exact: Callable[[RobotModel], ExactRobot]


ROBOTS = {
    "panda": MbmRobot("panda", ARCHIVE, "_panda", "panda_link0", panda_open_fingers, _panda_exact),
    "ur5": MbmRobot("ur5", UR5_DIR / "ur5_problems.tar.bz2", "_ur5", "base_link", ur5_robot, _ur5_exact),
}


@dataclass
class Outcome:
    """One plan of one planner on one valid problem."""

    success: bool
    status: str
    seconds: float
    cpu_seconds: float
    planner: str
    positions: np.ndarray  # the waypoints (N, n)
    executed: np.ndarray  # what is checked: the retimed trajectory's positions (pfield) or the path (OMPL)
    times: np.ndarray
    states: int = 0
    length: float = math.nan  # rad, L2 over the waypoints
    duration: float = math.nan  # s, the retimed trajectory
    contact: str = ""  # the independent check's first contact of a claimed success ("" when clear)
    seed: int = 0  # pfield's: the global search's seed (PlanOptions.global_seed)


@dataclass
class Result:
    """One problem: whether it is valid, and each planner's outcome (none when invalid); ``reruns``: pfield's plans
    with the further seeds of :data:`SEEDS` (its first seed's is ``outcomes["pfield"]``)."""

    robot: str
    scene: str
    index: int
    start_contact: str
    goal_contact: str
    outcomes: dict[str, Outcome] = field(default_factory=dict)
    reruns: list[Outcome] = field(default_factory=list)

    def plans(self, planner: str) -> list[Outcome]:
        """Every plan of ``planner`` on this problem: pfield's under each seed, OMPL's one."""
        first = [self.outcomes[planner]] if planner in self.outcomes else []
        return first + self.reruns if planner == PLANNERS[0] else first

    @property
    def valid(self) -> bool:
        return not self.start_contact and not self.goal_contact


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


def _pfield(robot: RobotModel, field_: PotentialField, start: np.ndarray, goal: np.ndarray, seed: int = 0) -> Outcome:
    options = replace(mbm_options(robot), global_seed=seed)
    with _counting() as counter:
        begin, cpu = time.perf_counter(), time.process_time()
        path = field_.plan_whole_body(robot, start, options=options, goal_configuration=goal)
        seconds, cpu = time.perf_counter() - begin, time.process_time() - cpu
    assert path.joint_positions is not None
    positions = np.array(path.joint_positions)
    trajectory = path.trajectory
    executed = positions if trajectory is None else np.array(trajectory.positions)
    times = np.zeros(1) if trajectory is None else np.array(trajectory.times)
    return Outcome(bool(path.success), path.status.name.lower(), seconds, cpu, path.planner, positions, executed,
                   times, counter.states, duration=float(times[-1]) if trajectory is not None else math.nan,
                   seed=seed)


def _ompl(robot: RobotModel, scene: ExactScene, start: np.ndarray, goal: np.ndarray, time_limit: float) -> Outcome:
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
    checks_before = scene.checks

    def valid(state: Any) -> bool:
        return not scene.contact(np.array([state[j] for j in range(n)]))

    setup.setStateValidityChecker(valid)
    information = setup.getSpaceInformation()
    information.setStateValidityCheckingResolution(OMPL_RESOLUTION / space.getMaximumExtent())
    begin_state, end_state = space.allocState(), space.allocState()
    for j in range(n):
        begin_state[j], end_state[j] = float(start[j]), float(goal[j])
    setup.setStartAndGoalStates(begin_state, end_state)
    setup.setPlanner(og.RRTConnect(information))
    begin, cpu = time.perf_counter(), time.process_time()
    solved = setup.solve(time_limit)
    success = bool(solved) and setup.haveExactSolutionPath()
    if success:
        # at most 1 s of simplification, within the limit (OMPL checks its deadline between steps only)
        setup.simplifySolution(min(SIMPLIFY_TIME, max(0.0, time_limit - (time.perf_counter() - begin))))
    seconds, cpu = time.perf_counter() - begin, time.process_time() - cpu
    states = scene.checks - checks_before
    if not success:
        return Outcome(False, "timeout", seconds, cpu, PLANNERS[1], start[None], start[None], np.zeros(1), states)
    path = setup.getSolutionPath()
    positions = np.array([[path.getState(i)[j] for j in range(n)] for i in range(path.getStateCount())])
    return Outcome(True, "reached", seconds, cpu, PLANNERS[1], positions, positions,
                   np.arange(len(positions), dtype=float), states)


def solve(spec: MbmRobot, robot: RobotModel, exact: ExactRobot, directory: Path, index: int,
          ompl_time: float | None = OMPL_TIME_LIMIT, seeds: Sequence[int] = (0,)) -> Result:
    """Problem ``index`` of the scene folder ``directory``: validity, pfield with each of ``seeds``, OMPL (unless
    ``ompl_time`` is None), and the independent check of every claimed success."""
    start, goal, obstacles, _ = read_problem(directory, index, robot.joint_names, spec.base_link)
    start = np.clip(start, robot.lower_limits, robot.upper_limits)
    goal = np.clip(goal, robot.lower_limits, robot.upper_limits)
    scene = exact.scene(obstacles)
    result = Result(spec.name, directory.name.removesuffix(spec.suffix), index, scene.contact(start),
                    scene.contact(goal))
    if not result.valid:
        return result
    field_ = PotentialField(CONFIG, robot.forward_kinematics(goal), obstacles)
    first, *others = seeds
    result.outcomes[PLANNERS[0]] = _pfield(robot, field_, start, goal, first)
    result.reruns = [_pfield(robot, field_, start, goal, seed) for seed in others]
    if ompl_time is not None:
        result.outcomes[PLANNERS[1]] = _ompl(robot, scene, start, goal, ompl_time)
    for outcome in [*result.outcomes.values(), *result.reruns]:
        if outcome.success:
            outcome.length = float(np.linalg.norm(np.diff(outcome.positions, axis=0), axis=1).sum())
            found = scene.path_contact(outcome.executed, CHECK_RESOLUTION)
            if found is not None:
                waypoint, fraction, pair = found
                outcome.contact = f"{pair} at waypoint {waypoint} + {fraction:.2f}"
    return result


def _percentile(values: Sequence[float], q: float) -> float:
    return float(np.percentile(values, q)) if len(values) else math.nan


@dataclass(frozen=True)
class SceneFigures:
    """One line of the table: a planner on one scene of one robot."""

    robot: str
    scene: str
    planner: str
    problems: int
    valid: int
    solved: int
    median_ms: float
    p95_ms: float
    cpu_median_ms: float
    length: float
    duration: float
    colliding: int
    statuses: str
    attempts: int  # the plans counted: valid problems × seeds (pfield), the valid problems (OMPL)
    seed_medians: tuple[tuple[int, float], ...] = ()  # pfield's median time (ms) under each seed, when several

    @property
    def success(self) -> float:
        return 100.0 * self.solved / self.attempts if self.attempts else math.nan

    def seeds_note(self) -> str:
        """"seeds 0, 1, 2: median 22.8 / 66.6 / 50.9 ms" ("" for one seed)."""
        if len(self.seed_medians) < 2:
            return ""
        return (f"seeds {', '.join(str(seed) for seed, _ in self.seed_medians)}: median "
                f"{' / '.join(f'{ms:.1f}' for _, ms in self.seed_medians)} ms")


ALL_SCENES = "all scenes"
"""The scene name of each robot's line over every problem of every scene (:func:`figures`)."""
VAMP_PATH_LENGTH = {"panda": 4.90, "ur5": 6.52}
"""(rad) VAMP's median simplified joint path (L2) over its whole MotionBenchMaker set per robot (RRT-Connect with
simplification; the UR5's from ``../shared/benchmarks/mbm/ur5/README.md``, the Panda's as issue 34 quotes it, over
MBM's 7 Panda scenes, of which this machine's archive holds 4): a median over every scene, so it compares with the
:data:`ALL_SCENES` line (over the scenes and problems that ran: the row's note says how many); issue 34's target is
at most 1.1 times it."""
PATH_LENGTH_FACTOR = 1.1


def figures(results: Sequence[Result]) -> list[SceneFigures]:
    """The table's lines: per robot, scene and planner (in the order they were run), then per robot and planner a
    line over all its scenes (:data:`ALL_SCENES`; when it ran more than one)."""
    lines = []
    for robot in dict.fromkeys(r.robot for r in results):
        mine = [r for r in results if r.robot == robot]
        scenes = list(dict.fromkeys(r.scene for r in mine))
        for scene in scenes:
            lines += _scene_figures(robot, scene, [r for r in mine if r.scene == scene])
        if len(scenes) > 1:
            lines += _scene_figures(robot, ALL_SCENES, mine)
    return lines


def _scene_figures(robot: str, scene: str, here: Sequence[Result]) -> list[SceneFigures]:
    valid = [r for r in here if r.valid]
    planners = dict.fromkeys(p for r in valid for p in r.outcomes) or dict.fromkeys(PLANNERS[:1])
    lines = []
    for planner in planners:
        outcomes = [o for r in valid for o in r.plans(planner)]  # pfield: every seed's plans, pooled
        good = [o for o in outcomes if o.success]
        ms = [o.seconds * 1e3 for o in outcomes]
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(Counter(o.status for o in outcomes).items()))
        seeds = sorted({o.seed for o in outcomes})
        medians = tuple((seed, _percentile([o.seconds * 1e3 for o in outcomes if o.seed == seed], 50))
                        for seed in seeds) if len(seeds) > 1 else ()
        lines.append(SceneFigures(robot, scene, planner, len(here), len(valid), len(good), _percentile(ms, 50),
                                  _percentile(ms, 95), _percentile([o.cpu_seconds * 1e3 for o in outcomes], 50),
                                  _percentile([o.length for o in good], 50),
                                  _percentile([o.duration for o in good if not math.isnan(o.duration)], 50),
                                  sum(bool(o.contact) for o in good), statuses, len(outcomes), medians))
    return lines


def table(lines: Sequence[SceneFigures], missing: dict[str, list[str]]) -> str:
    """The Markdown table of :func:`figures`, with its note."""

    def cell(value: float, digits: int) -> str:
        return "—" if math.isnan(value) else f"{value:.{digits}f}"

    out = ["| robot | scene | planner | valid | success | median ms | p95 ms | CPU median ms | path rad | duration s "
           "| colliding | status |", "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for f in lines:
        statuses = "; ".join(part for part in (f.statuses, f.seeds_note()) if part)
        out.append(f"| {f.robot} | {f.scene} | {f.planner} | {f.valid}/{f.problems} | {f.solved}/{f.attempts} "
                   f"({cell(f.success, 1)} %) | {cell(f.median_ms, 1)} | {cell(f.p95_ms, 1)} "
                   f"| {cell(f.cpu_median_ms, 1)} | {cell(f.length, 2)} | {cell(f.duration, 2)} | **{f.colliding}** "
                   f"| {statuses} |")
    notes = [f"{robot}: scenes {', '.join(names)} are not in its archive on this machine (not measured)"
             for robot, names in missing.items() if names]
    out.append("")
    out.append("valid: start and goal clear under the bench's exact check (pinocchio + coal on the link meshes); "
               "success over the valid problems (pfield: each planned once per seed of its global search, the "
               "figures over every seed's plans, the status column giving each seed's median); times: wall clock "
               "of every valid problem (CPU: this process's CPU "
               "time, which does not grow when other processes share the machine); path: "
               "median joint path length (L2) of the successes; duration: pfield's retimed trajectory; colliding: "
               "claimed successes that the independent check finds in contact (every waypoint and ≤ 0.01 rad between)."
               + ("" if not notes else " " + "; ".join(notes) + "."))
    return "\n".join(out)


def problems_list(results: Sequence[Result]) -> str:
    """Every invalid problem, failure and colliding claim: robot, scene, index, planner, status."""
    out = ["| robot | scene | index | planner | status |", "|---|---|---:|---|---|"]
    for r in results:
        if not r.valid:
            what = "; ".join(f"{k} in contact: {v}" for k, v in (("start", r.start_contact), ("goal", r.goal_contact))
                             if v)
            out.append(f"| {r.robot} | {r.scene} | {r.index} | — | invalid ({what}) |")
        for planner, o in _labelled(r):
            if not o.success:
                out.append(f"| {r.robot} | {r.scene} | {r.index} | {planner} | {o.status} ({o.seconds:.2f} s) |")
            elif o.contact:
                out.append(f"| {r.robot} | {r.scene} | {r.index} | {planner} | **claimed reached, in contact: "
                           f"{o.contact}** |")
    return "\n".join(out)


def _labelled(result: Result) -> list[tuple[str, Outcome]]:
    """Every plan of ``result`` with its planner's name, pfield's further seeds as "pfield (seed k)"."""
    return [*result.outcomes.items(), *((f"{PLANNERS[0]} (seed {o.seed})", o) for o in result.reruns)]


def rows(lines: Sequence[SceneFigures]) -> list[BenchRow]:
    """:mod:`benchmarks.run`'s rows: success (target 99 % for pfield), median and p95 time (targets 10/100 ms),
    path length (on the :data:`ALL_SCENES` lines: at most 1.1 times VAMP's, named in the note), duration
    and colliding claims (target 0) per robot, scene and planner."""
    out = []
    for f in lines:
        name = f"{f.robot} {f.scene}: {f.planner}"
        ours = f.planner == PLANNERS[0]
        vamp = VAMP_PATH_LENGTH.get(f.robot) if f.scene == ALL_SCENES else None
        out += [
            BenchRow(SECTION, f"{name} success", f.success, "%", target=99.0 if ours else None, higher_is_better=True,
                     note=f"{f.solved}/{f.attempts} plans of {f.valid} valid ({f.problems} problems); {f.statuses}"),
            BenchRow(SECTION, f"{name} median time", f.median_ms, "ms", target=10.0 if ours else None,
                     note=f.seeds_note()),
            BenchRow(SECTION, f"{name} p95 time", f.p95_ms, "ms", target=100.0 if ours else None),
            BenchRow(SECTION, f"{name} median path length", f.length, "rad",
                     target=None if vamp is None or not ours else PATH_LENGTH_FACTOR * vamp,
                     note="" if vamp is None else f"VAMP's median simplified path over its whole set: {vamp:.2f} "
                                                  f"rad; this line: the {f.solved} solved of {f.valid} valid problems"),
            BenchRow(SECTION, f"{name} claimed successes in collision", float(f.colliding), "",
                     target=0.0 if ours else None),
        ]
        if not math.isnan(f.duration):
            out.append(BenchRow(SECTION, f"{name} median trajectory duration", f.duration, "s"))
    return out


def _record(result: Result, planner: str, outcome: Outcome, joint_names: Sequence[str]) -> str:
    return json.dumps({"robot": result.robot, "scene": result.scene, "index": result.index, "planner": planner,
                       "seed": outcome.seed, "used": outcome.planner,
                       "success": outcome.success, "status": outcome.status, "seconds": outcome.seconds,
                       "cpu_seconds": outcome.cpu_seconds, "states_checked": outcome.states,
                       "joint_names": list(joint_names), "positions": outcome.executed.tolist(),
                       "times": outcome.times.tolist(), "length": outcome.length, "duration": outcome.duration,
                       "contact": outcome.contact})


def bench(robots: Sequence[str] = tuple(ROBOTS), limit: int | None = None, scenes: Sequence[str] | None = None,
          out: Path | None = None, ompl_time: float | None = OMPL_TIME_LIMIT, progress: bool = False,
          seeds: Sequence[int] = SEEDS) -> tuple[list[Result], dict[str, list[str]]]:
    """Plan at most ``limit`` problems of each scene (all when None; ``scenes`` names them without the robot
    suffix, all when None) of each robot in ``robots``, pfield once with each of ``seeds``. Returns the results
    and, per robot, the MBM scenes its archive lacks. ``out`` receives one JSON line per plan as it is made."""
    results: list[Result] = []
    missing: dict[str, list[str]] = {}
    stream = out.open("w") if out is not None else None
    try:
        with Progress(transient=True, disable=not progress) as bar:
            for name in robots:
                spec = ROBOTS[name]
                if not spec.archive.exists():
                    missing[name] = list(MBM_SCENES)
                    continue
                robot = spec.model()
                exact = spec.exact(robot)
                with extracted_scene_folders(spec.archive) as extracted:
                    folders = {f.name.removesuffix(spec.suffix): f for f in extracted}
                    missing[name] = [s for s in MBM_SCENES if s not in folders]
                    wanted = [s for s in (scenes or MBM_SCENES) if s in folders]
                    work = [(s, i) for s in wanted for i in problem_indices(folders[s])[:limit]]
                    if work:  # warm-up, untimed: the first plan builds the robot's kernels and caches
                        solve(spec, robot, exact, folders[work[0][0]], work[0][1], None)
                    task = bar.add_task(f"{name}: MBM problems", total=len(work))
                    for scene, index in work:
                        result = solve(spec, robot, exact, folders[scene], index, ompl_time, seeds)
                        results.append(result)
                        if stream is not None:
                            for planner, outcome in _labelled(result):
                                stream.write(_record(result, planner, outcome, robot.joint_names) + "\n")
                            stream.flush()
                        bar.advance(task)
    finally:
        if stream is not None:
            stream.close()
    return results, missing


PLANS_CSV = "mbm_plans.csv"
"""The file beside the table with one line per plan (:func:`plans_csv`)."""
TIMES_PICTURE = "mbm_times.png"
"""The picture of the planning times (:func:`times_picture`), drawn from the plans' lines."""
TIME_TARGETS_MS = (10.0, 100.0)
"""(ms) Issue 34's median and p95 planning time per scene, drawn across the picture."""
_CSV_COLUMNS = ("robot", "scene", "index", "planner", "seed", "status", "success", "ms", "cpu_ms", "path_rad",
                "duration_s", "contact")
_CSV_COLUMNS_ONE_SEED = tuple(column for column in _CSV_COLUMNS if column != "seed")
"""The columns of the files written before pfield was planned with several seeds (read as seed 0)."""


@dataclass(frozen=True)
class PlanLine:
    """One plan of the table (a planner on one valid problem), as :data:`PLANS_CSV` keeps it."""

    robot: str
    scene: str
    index: int
    planner: str
    seed: int
    status: str
    success: bool
    ms: float
    cpu_ms: float
    path_rad: float
    duration_s: float
    contact: str


def plan_lines(results: Sequence[Result]) -> list[PlanLine]:
    """Every plan of ``results`` (valid problems only), in the order they ran."""
    return [PlanLine(r.robot, r.scene, r.index, planner, o.seed, o.status, o.success, 1e3 * o.seconds,
                     1e3 * o.cpu_seconds, o.length, o.duration, o.contact)
            for r in results for planner in r.outcomes for o in r.plans(planner)]


def plans_csv(lines: Sequence[PlanLine]) -> str:
    """:data:`PLANS_CSV`'s text: a header, then one row per plan (times in ms; path and duration empty where not
    measured; ``contact``: the independent check's first contact of a claimed success, empty when clear)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(_CSV_COLUMNS)

    def number(value: float, digits: int) -> str:
        return "" if math.isnan(value) else f"{value:.{digits}f}"

    for p in lines:
        writer.writerow([p.robot, p.scene, p.index, p.planner, p.seed, p.status, int(p.success), number(p.ms, 3),
                         number(p.cpu_ms, 3), number(p.path_rad, 4), number(p.duration_s, 3), p.contact])
    return out.getvalue()


def read_plans_csv(text: str) -> list[PlanLine]:
    """The plans of a :func:`plans_csv` text."""
    reader = csv.DictReader(io.StringIO(text))
    columns = tuple(reader.fieldnames or ())
    if columns not in (_CSV_COLUMNS, _CSV_COLUMNS_ONE_SEED):
        raise ValueError(f"not a {PLANS_CSV}: its columns are {reader.fieldnames}, expected {list(_CSV_COLUMNS)}")

    def number(cell: str) -> float:
        return float(cell) if cell else math.nan

    lines = []
    for row in reader:
        if None in row or None in row.values():  # a row with more (key None) or fewer (values None) cells
            cells = sum(v is not None for k, v in row.items() if k is not None) + len(row.get(None) or ())
            raise ValueError(f"line {reader.line_num} has {cells} of {len(columns)} cells")
        lines.append(PlanLine(row["robot"], row["scene"], int(row["index"]), row["planner"], int(row.get("seed", 0)),
                              row["status"],
                              row["success"] == "1", number(row["ms"]), number(row["cpu_ms"]),
                              number(row["path_rad"]), number(row["duration_s"]), row["contact"]))
    return lines


_PLANNER_COLOURS = {PLANNERS[0]: "#1f77b4", PLANNERS[1]: "#ff7f0e"}  # matplotlib's tab10 blue and orange


def times_picture(lines: Sequence[PlanLine]) -> bytes:
    """A PNG of the planning times: a panel per robot, per scene a box per planner (the box: quartiles; the line
    inside: the median; the whiskers: 5th and 95th percentiles; the plans beyond them as dots) on a log scale,
    every valid problem counted as the table counts it (a failure with the time it took), the share solved
    above each box, and :data:`TIME_TARGETS_MS` across."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    grouped: dict[tuple[str, str, str], list[PlanLine]] = {}  # (robot, scene, planner) -> its plans, in run order
    for p in lines:
        grouped.setdefault((p.robot, p.scene, p.planner), []).append(p)
    robots = list(dict.fromkeys(robot for robot, _, _ in grouped))
    scenes = {robot: list(dict.fromkeys(scene for r, scene, _ in grouped if r == robot)) for robot in robots}
    planners = [name for name in PLANNERS if any(planner == name for _, _, planner in grouped)]
    widths = [max(len(scenes[robot]), 1) for robot in robots] or [1]
    figure = Figure(figsize=(2.0 + 1.45 * sum(widths), 4.6))
    FigureCanvasAgg(figure)
    grid = figure.add_gridspec(1, len(widths), width_ratios=widths, wspace=0.08)
    axes = [figure.add_subplot(grid[0, k]) for k in range(len(widths))]
    for k, (ax, robot) in enumerate(zip(axes, robots, strict=False)):
        names = scenes[robot]
        for s, scene in enumerate(names):
            for j, planner in enumerate(planners):
                here = grouped.get((robot, scene, planner))
                if here is None:
                    continue
                where = s + (j - (len(planners) - 1) / 2) * 0.38
                colour = _PLANNER_COLOURS[planner]
                ax.boxplot([p.ms for p in here], positions=[where], widths=0.32, whis=(5, 95), patch_artist=True,
                           boxprops={"facecolor": colour, "alpha": 0.55, "edgecolor": colour},
                           medianprops={"color": "black"}, whiskerprops={"color": colour},
                           capprops={"color": colour},
                           flierprops={"marker": ".", "markersize": 3, "markeredgecolor": colour})
                solved = sum(p.success for p in here)
                ax.annotate(f"{100.0 * solved / len(here):.0f} %", (where, 1.0), xycoords=("data", "axes fraction"),
                            xytext=(0, -11), textcoords="offset points", ha="center", fontsize=7, color=colour)
        for target, label in zip(TIME_TARGETS_MS, ("median target", "p95 target"), strict=True):
            ax.axhline(target, color="0.35", linestyle="--", linewidth=0.8)
            if k == 0:
                ax.annotate(f"{label} {target:g} ms", (0.0, target), xycoords=("axes fraction", "data"),
                            xytext=(3, 2), textcoords="offset points", fontsize=7, color="0.35")
        ax.set_yscale("log")
        ax.set_xticks(range(len(names)), [name.replace("_", "\n", 1) for name in names], fontsize=8)
        ax.set_xlim(-0.6, len(names) - 0.4)
        ax.set_title(f"{robot}: {len({(p.scene, p.index) for p in lines if p.robot == robot})} valid problems",
                     fontsize=10)
        ax.grid(axis="y", which="major", color="0.9")
        if k == 0:
            ax.set_ylabel("planning time per problem (ms, wall)")
        else:
            ax.tick_params(labelleft=False)
    low = min((p.ms for p in lines if p.ms > 0.0), default=1.0)
    high = max((p.ms for p in lines), default=1e4)
    for ax in axes:
        ax.set_ylim(low / 1.5, high * 3.0)
    figure.suptitle("MotionBenchMaker: planning time per scene (share solved above each box)", fontsize=10, y=1.05)
    figure.legend(handles=[Patch(facecolor=_PLANNER_COLOURS[p], alpha=0.55, label=p) for p in planners],
                  loc="upper center", bbox_to_anchor=(0.5, 1.01), ncol=len(planners), fontsize=8, frameon=False)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    return buffer.getvalue()


SECTION_CHECK = "global search: a UR5 state check (µs, one thread)"
CHECK_PROBLEMS = (("cage", 5), ("cage", 16))
"""UR5 problems whose searches check many states (the cage's tail): RRT-Connect from seed 0 on each, as the fallback
runs it (the fitted self pairs, a 3 mm margin, edges every 0.03 rad), with and without the self pairs' tables."""


def state_check_rows(budget: int = 150_000) -> list[BenchRow]:
    """µs per state check of RRT-Connect on :data:`CHECK_PROBLEMS` (thread CPU over at most ``budget`` checks each),
    with the self pairs' tables (``src/core/robot/pair_tables.hpp``) and with the primitives alone: the same states
    are checked either way (the tables give the primitives' own verdicts), so the figures compare one check."""
    from pfield._core import rrt
    from pfield.geometry import pack_obstacles
    from pfield.planning._whole_body_core import core_scene
    from pfield.planning.global_search import GlobalOptions, search_margin, self_contact_slack
    from pfield.planning.whole_body import WholeBodyOptions, make_scene, pack_robot

    spec = ROBOTS["ur5"]
    if not spec.archive.exists():
        return []
    robot = spec.model()
    arrays = pack_robot(robot, CONFIG, WholeBodyOptions())
    options = GlobalOptions()
    margin = search_margin(CONFIG, options)
    spent = {"tables": 0.0, "primitives": 0.0}
    counts = {"tables": 0, "primitives": 0}
    with extracted_scene_folders(spec.archive) as folders:
        by_name = {f.name.removesuffix(spec.suffix): f for f in folders}
        for scene, index in CHECK_PROBLEMS:
            start, goal, obstacles, _ = read_problem(by_name[scene], index, robot.joint_names, spec.base_link)
            for name, tables in (("primitives", None), ("tables", arrays.pair_tables)):
                packed = arrays._replace(pair_tables=tables)
                searched = make_scene(pack_obstacles(obstacles), packed)
                # the search's own self pairs: on the fitted primitives, which may touch
                searched = searched._replace(fitted_self=True, self_offsets=searched.self_offsets
                                             - self_contact_slack(packed, margin))
                checker = rrt.Checker(core_scene(packed, searched), margin, options.joint_resolution)
                trees = rrt.Trees(np.clip(start, robot.lower_limits, robot.upper_limits),
                                  np.clip(goal, robot.lower_limits, robot.upper_limits)[None], options.capacity, 0)
                began = time.thread_time()
                checker.connect(trees, robot.lower_limits, robot.upper_limits, options.joint_step, budget, None, None)
                spent[name] += time.thread_time() - began
                counts[name] += checker.states_checked
    if counts["tables"] != counts["primitives"]:
        raise AssertionError(f"the tables changed the states checked: {counts}")
    problems = ", ".join(f"{scene} {index}" for scene, index in CHECK_PROBLEMS)
    note = (f"RRT-Connect from seed 0 on {problems}: {counts['tables']} states either way; the tables filled as "
            "the search meets their cells")
    return [BenchRow(SECTION_CHECK, "self pairs moved by one or two joints from their tables", 1e6 * spent["tables"]
                     / counts["tables"], "µs", note=note),
            BenchRow(SECTION_CHECK, "every self pair on its fitted primitives", 1e6 * spent["primitives"]
                     / counts["primitives"], "µs", note=note)]


def run(quick: bool) -> Report:
    results, missing = bench(limit=QUICK_LIMIT if quick else None)
    lines = figures(results)
    plans = plan_lines(results)
    return Report(rows(lines) + state_check_rows(), {"mbm_table.md": table(lines, missing) + "\n",
                                "mbm_problems.md": problems_list(results) + "\n", PLANS_CSV: plans_csv(plans),
                                TIMES_PICTURE: times_picture(plans)})


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_fallback", description=__doc__.splitlines()[0])
    parser.add_argument("--robot", nargs="+", choices=sorted(ROBOTS), default=list(ROBOTS), help="robots to run")
    parser.add_argument("--limit", type=int, default=None, help="problems per scene (default: all)")
    parser.add_argument("--scenes", nargs="*", default=None, choices=MBM_SCENES, help="scenes (default: all)")
    parser.add_argument("--ompl-time", type=float, default=OMPL_TIME_LIMIT, help="OMPL's time limit (s)")
    parser.add_argument("--no-ompl", action="store_true", help="run pfield only")
    parser.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS), metavar="SEED",
                        help=f"pfield's global search seeds, each problem planned once per seed (default: "
                             f"{' '.join(map(str, SEEDS))})")
    parser.add_argument("--out", type=Path, default=None, help="JSON-lines file of every plan")
    parser.add_argument("--redraw", type=Path, default=None, metavar="CSV",
                        help=f"draw {TIMES_PICTURE} again from a saved {PLANS_CSV} (beside it) and plan nothing")
    args = parser.parse_args(argv)
    if args.redraw is not None:
        try:
            plans = read_plans_csv(args.redraw.read_text())
        except (OSError, ValueError) as error:
            parser.error(f"--redraw {args.redraw}: {error}")
        picture = args.redraw.with_name(TIMES_PICTURE)
        picture.write_bytes(times_picture(plans))
        print(f"wrote {picture} ({len(plans)} plans)")
        return
    if args.limit is not None and args.limit < 1:
        parser.error(f"--limit must be at least 1, got {args.limit}")
    if not args.ompl_time > 0:
        parser.error(f"--ompl-time must be a positive number of seconds, got {args.ompl_time}")
    bad = [seed for seed in args.seeds if not 0 <= seed < SEED_LIMIT]
    if bad or len(set(args.seeds)) != len(args.seeds):
        parser.error(f"--seeds must be distinct integers in [0, {SEED_LIMIT}), got {' '.join(map(str, args.seeds))}")
    results, missing = bench(args.robot, args.limit, args.scenes, args.out,
                             None if args.no_ompl else args.ompl_time, progress=True, seeds=args.seeds)
    lines = figures(results)
    print(table(lines, missing))
    print()
    print(problems_list(results))


if __name__ == "__main__":
    main()
