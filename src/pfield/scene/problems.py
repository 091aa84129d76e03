"""Planning problems: one value per plan to make, read from pfield scene files and MoveIt problem sets.

A :class:`Problem` carries everything one plan needs (obstacles, start, goal, field parameters, planning
options — for MoveIt problems, those of the robot, :func:`mbm_options`, chosen when it is built — and, for
whole-body problems, the robot to build) as plain picklable values, so a batch can send
it to another process or a Ray worker. :func:`read_problems` turns paths into problems, in a stable order:

* a pfield scene file (``*.yaml``, :mod:`pfield.scene.files`) → one task-space problem;
* a folder of MoveIt ``sceneNNNN.yaml`` / ``requestNNNN.yaml`` pairs (the MotionBenchMaker layout, also
  nested one level: every folder holding such pairs is one scene) → one whole-body problem per pair;
* an archive (``.tar``, ``.tar.gz``, ``.tgz``, ``.tar.bz2``, ``.tar.xz``) of such folders, unpacked within
  the bounds of :mod:`pfield.scene._archives` (64 MiB decompressed, 10 000 members).

Every YAML file is read within the bounds of :func:`pfield.interfaces.load_yaml_file` (a regular file
of at most 8 MiB, 100 levels deep, 250 000 nodes with aliases expanded); a MoveIt file beyond them is one
problem that cannot be read, a scene file or an archive beyond them fails the whole call.

For MoveIt problems the robot is a :class:`~pfield.robot.description.RobotDescription` (``RobotSpec``): a
built-in name (default the Panda) or a URDF with its SRDF, end effector and package paths. Joints are matched
by name (the request's other joints are ignored); the robot's joints a joint goal does not name, and a built-in's
catalog locks, are locked at the request's start values (MotionBenchMaker opens the Panda's fingers to
0.065 m); the goal is a joint goal's end-effector pose (forward kinematics) or the request's pose goal.
"""

from __future__ import annotations

import logging
import re
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pfield._validation import text
from pfield.errors import InvalidInput
from pfield.field import FieldConfig
from pfield.geometry import Obstacle
from pfield.interfaces import load_yaml_file
from pfield.planning.options import PlanOptions
from pfield.robot.description import RobotDescription
from pfield.scene._archives import extract_archive
from pfield.scene.files import load_scene
from pfield.scene.moveit import WORLD_FRAMES, request_from_moveit, scene_obstacles
from pfield.spatial import Pose

if TYPE_CHECKING:
    from pfield.robot.model import RobotModel

__all__ = ["MBM_CONFIG", "MBM_JOINT_STEP", "MBM_OPTIONS", "MBM_STEP_RANGE", "Problem", "RobotSpec", "mbm_options",
           "read_moveit_problem", "read_problems", "scene_folders"]

MBM_CONFIG = FieldConfig(max_linear_velocity=0.25, max_angular_velocity=1.0, rotational_attractive_gain=0.6,
                         max_angular_acceleration=1.0, safety_distance=0.002, influence_distance=0.05,
                         stagnation_window=0.5)
"""Field parameters for MoveIt problem sets: rosYaml, except faster limits (the seed's 5 cm/s makes every
plan slow), a 2 mm safety distance and a 5 cm influence distance (MBM goals are grasp poses next to objects),
and a 0.5 s stagnation window (25 steps at dt 0.02 s) instead of 10 s: these motions take 1–3 s, and a long
window spends the motion's time again confirming a local minimum before the global fallback can start.
Measured on all 1099 valid MotionBenchMaker problems of the Panda and the UR5 (pfield alone, 2026-12-06), window
2 s → 1 s → 0.5 s: every problem solved and no claim in collision with each; per-scene medians 3–16 % lower at
0.5 s (Panda table_under_pick 11.0 → 10.2 → 9.5 ms, table_pick 9.5 → 8.1 → 7.8; UR5 table_under_pick 28.4 → 26.0
→ 24.7); the same plan to the last waypoint on every problem but the 17 (of 1099) whose field attempt, reaching
the goal slowly, now hands over to the fallback: 14 on the Panda box scene, one on its table_pick, two on the UR5's
table_pick; the box scene's median path length went down (4.83 → 4.67 rad) and its p95 up (6 → 9 ms). (From 10 s to 2 s,
earlier: the failing attempts ended after 464–541 steps on average instead of 646–1029.)"""
MBM_OPTIONS = PlanOptions(dt=0.02, goal_tolerance=0.01, max_iterations=10000, global_time_limit=5.0)
"""Planning options for MoveIt problem sets: dt 0.02 s (a plan's robot sets its own: :func:`mbm_options`), 1 cm (and
the config's 0.05 rad), 10000 steps, and the global fallback's search limited to 5 s, MoveIt's own default planning
time (``MoveGroupInterface``'s ``allowed_planning_time``) and the time OMPL gets beside pfield in ``make bench``'s
MotionBenchMaker table. With the library's 2 s, the UR5 cage problems 62 and 80 ended at the limit in the table's run
of 2026-12-05 (98 of 100), where their searches take 1.5–4.7 s; a plan that the field or a short search solves is not
slowed by the longer limit."""
MBM_JOINT_STEP = 0.05
"""rad: how far a robot's fastest joint may move in one step of a MoveIt problem's plan (:func:`mbm_options`)."""
MBM_STEP_RANGE = (0.02, 0.05)
"""s: the shortest and the longest step :func:`mbm_options` chooses."""


def mbm_options(robot: RobotModel) -> PlanOptions:
    """:data:`MBM_OPTIONS` with ``robot``'s step: the time its fastest revolute joint takes to turn
    :data:`MBM_JOINT_STEP` at its velocity limit, within :data:`MBM_STEP_RANGE` (Panda 0.02 s; the UR5 of
    ``../shared/benchmarks/mbm/ur5``, 0.5 rad/s, 0.05 s); a robot without a revolute joint of finite, positive
    limit gets :data:`MBM_OPTIONS`' own 0.02 s (prismatic limits are m/s, another unit).

    The field and its tracking of a searched path take one step per ``dt`` of the motion, so a slow robot at a fixed
    step pays for steps in which its joints hardly move (the UR5 at 0.02 s: 0.01 rad; its plans last 9–12 s, 450–600
    steps). Measured on the 700 MotionBenchMaker UR5 problems (pfield alone, one process, 2026-12-07) against the
    table of 2026-12-06 (0.02 s): every problem solved at 0.05 s, none claimed in contact, median planning time
    18.6 → 13.4 ms (table_pick 17.0 → 11.2, box 8.4 → 5.9, cage 31.5 → 26.4), median joint path length and
    trajectory duration within 2 % on every scene; on 30 problems per scene, at 0.1 s the trajectories lasted
    8–18 % longer (the retiming has fewer waypoints to spread a turn over). The Panda's steps stay at 0.02 s: at
    0.04 s its fastest joints turn 0.1 rad per step and its table_pick paths were 5 % longer, at 0.05 s 26 %."""
    limits = np.asarray(robot.velocity_limits, dtype=np.float64)
    usable = limits[(np.asarray(robot.kinematics.kinds) == 0) & np.isfinite(limits) & (limits > 0.0)]
    if len(usable) == 0:
        return MBM_OPTIONS
    shortest, longest = MBM_STEP_RANGE
    return replace(MBM_OPTIONS, dt=min(longest, max(shortest, MBM_JOINT_STEP / float(np.max(usable)))))


_ARCHIVE = re.compile(r"\.(tar|tar\.gz|tgz|tar\.bz2|tbz2|tar\.xz|txz)$")
_REQUEST = "request[0-9][0-9][0-9][0-9].yaml"


RobotSpec = RobotDescription
"""The robot of a whole-body problem: :class:`pfield.robot.description.RobotDescription` (one type, two names;
``RobotSpec`` is the name this module gave it first)."""


@dataclass(frozen=True)
class Problem:
    """One plan to make.

    ``scene`` and ``index`` name it (the scene folder or file stem, the problem number), and
    ``(scene, index)`` is its key in a result file. ``start`` is a :class:`Pose` (task space) or a mapping
    of joint names to positions (whole body, with ``robot``). The goal is ``goal`` (a pose) or, for a whole-
    body problem, ``goal_joints`` (its end effector's pose by forward kinematics). Joint values outside the
    robot's limits are clipped onto them when the plan is made (MoveIt's Panda limits differ slightly).
    """

    scene: str
    index: int
    obstacles: tuple[Obstacle, ...] = ()
    start: Pose | Mapping[str, float] = field(default_factory=Pose)
    goal: Pose | None = None
    goal_joints: Mapping[str, float] | None = None
    robot: RobotSpec | None = None
    config: FieldConfig = field(default_factory=FieldConfig)
    options: PlanOptions | None = field(default_factory=PlanOptions)
    """None (whole-body problems only): :func:`mbm_options` of the robot, chosen when the robot is built."""
    error: str = ""
    """Why the problem could not be read (:meth:`unreadable`); a batch reports it instead of planning."""

    def __post_init__(self) -> None:
        text("scene", self.scene)
        if isinstance(self.index, bool) or not isinstance(self.index, int):
            raise InvalidInput("index", self.index, "must be an integer")
        if text("error", self.error):
            return
        object.__setattr__(self, "obstacles", tuple(self.obstacles))
        for i, obstacle in enumerate(self.obstacles):
            if not isinstance(obstacle, Obstacle):
                raise InvalidInput(f"obstacles[{i}]", obstacle, "expected a pfield.Obstacle")
        if not isinstance(self.config, FieldConfig):
            raise InvalidInput("config", self.config, "expected a pfield.FieldConfig")
        if self.options is None and self.robot is None:
            raise InvalidInput("options", None, "a task-space problem needs its PlanOptions (None is for a robot's)")
        if self.options is not None and not isinstance(self.options, PlanOptions):
            raise InvalidInput("options", self.options, "expected a pfield.PlanOptions or None")
        if self.options is not None and self.options.cancel is not None:
            raise InvalidInput("options.cancel", self.options.cancel, "a problem's options cannot carry a CancelToken")
        if self.robot is not None and not isinstance(self.robot, RobotSpec):
            raise InvalidInput("robot", self.robot, "expected a pfield.scene.RobotSpec or None")
        whole_body = self.robot is not None
        if whole_body == isinstance(self.start, Pose):
            raise InvalidInput("start", self.start, "a Pose for a task-space problem, joint positions (a mapping of "
                               "names) with a robot")
        if (self.goal is None) == (self.goal_joints is None) or (self.goal_joints is not None and not whole_body):
            raise InvalidInput("goal", self.goal, "give exactly one of goal (a Pose) and goal_joints (with a robot)")
        if self.goal is not None and not isinstance(self.goal, Pose):
            raise InvalidInput("goal", self.goal, "expected a pfield.Pose")

    @property
    def key(self) -> tuple[str, int]:
        return (self.scene, self.index)

    @classmethod
    def unreadable(cls, scene: str, index: int, error: str) -> Problem:
        """A problem whose files could not be read: it keeps its place (and key) in a batch, and its record
        says ``error``."""
        return cls(scene, index, error=text("error", error) or "unreadable problem")


_LOG = logging.getLogger(__name__)
_OTHER_ROBOT = "another robot's problem"  # the words of a problem that names none of the robot's joints


def _description(robot: str | RobotDescription | None) -> RobotDescription:
    if isinstance(robot, RobotDescription):
        return robot
    return RobotDescription("panda" if robot is None else robot)


def read_moveit_problem(scene_file: Path, request_file: Path, index: int, robot: str | RobotDescription = "panda",
                        config: FieldConfig = MBM_CONFIG, options: PlanOptions | None = None) -> Problem:
    """The whole-body problem of one MoveIt scene/request pair for ``robot`` (a built-in name or a
    :class:`RobotDescription`); ``options`` None: :func:`mbm_options` of the robot when it is planned.

    Joints are matched by name: the request's joints the robot does not move (a gripper's joints that are
    fixed in this URDF) are ignored. Of a joint goal, every joint of the robot the goal does not name is locked
    at the request's start value, and so are the catalog's locked joints of a built-in robot (MotionBenchMaker
    opens the Panda's fingers to 0.065 m); the description's own ``locked_joints`` keep their values. The
    robot's root link is also taken as the world frame (the MBM robots stand at the origin). Errors name the
    file and the part: ``InvalidInput("request0003.yaml: request.goal_constraints", …)``.
    """
    description = _description(robot)
    frames = (*WORLD_FRAMES, description.base_link)
    scene_data, request_data = (load_yaml_file(file, file.name) for file in (scene_file, request_file))
    try:
        obstacles = scene_obstacles(scene_data, frames)
        request = request_from_moveit(request_data, frames)
    except InvalidInput as exc:
        where = scene_file.name if exc.field.startswith("scene") else request_file.name
        raise InvalidInput(f"{where}: {exc.field}", exc.value, exc.reason) from None
    end_effector = description.end_effector_link
    if request.goal_link and request.goal_link != end_effector:
        raise InvalidInput(f"{request_file.name}: request.goal_constraints[0].position_constraints[0].link_name",
                           request.goal_link, f"pose goals must name the robot's end effector {end_effector!r}")
    own = dict(description.locked_joints)
    catalog = [name for name in description.locked if name not in own]
    free = [name for name in description.urdf_joints if name not in description.locked]
    named = set(request.start) | set(request.goal_joints or ())
    if free and not named & set(free):  # not one of this robot's joints: the problems of another robot
        raise InvalidInput(f"{request_file.name}: request", sorted(named)[:3],
                           f"names none of the joints of {description} ({', '.join(free)}): {_OTHER_ROBOT}; give "
                           "the robot of these problems (--robot PATH.urdf --srdf ... --end-effector ..., or robot=)")
    if request.goal_joints is not None:
        catalog += [name for name in free if name not in request.goal_joints]
    missing = [name for name in catalog if name not in request.start and name not in description.locked]
    if missing:
        raise InvalidInput(f"{request_file.name}: request.start_state.joint_state.name", sorted(request.start),
                           f"the goal leaves the robot's joints {missing} free and the start state gives no value "
                           "to lock them at")
    _warn_overridden(own, request.start, request.goal_joints or {}, request_file)
    locked = {name: request.start[name] for name in catalog if name in request.start}
    free = [name for name in free if name not in locked]
    start = {name: request.start[name] for name in free if name in request.start}
    goal_joints = None if request.goal_joints is None else \
        {name: request.goal_joints[name] for name in free if name in request.goal_joints}
    return Problem(scene_file.parent.name, index, tuple(obstacles), start, request.goal_pose, goal_joints,
                   description.with_locked(locked), config, options)


_OVERRIDDEN: set[tuple[str, float]] = set()  # (joint, locked value) already warned of


def _warn_overridden(own: dict[str, float], start: Mapping[str, float], goal: Mapping[str, float],
                     request_file: Path) -> None:
    """Warn (once per joint and value) where the caller's locked joints replace the values a request gives them: the
    plan then neither starts nor ends where the request says for that joint."""
    for name, value in own.items():
        given = [f"{what} {values[name]:g}" for what, values in (("start", start), ("goal", goal))
                 if name in values and abs(values[name] - value) > 1e-9]
        if given and (name, value) not in _OVERRIDDEN:
            _OVERRIDDEN.add((name, value))
            _LOG.warning("the locked joint %s=%g replaces the request's %s (%s; warned once per joint)", name, value,
                         " and ".join(given), request_file.name)


def _short(scene: str, robot: RobotDescription) -> str:
    """A scene folder's name without its robot suffix (``box_ur5`` → ``box``, ``cage_panda`` → ``cage``)."""
    for name in (*robot.short_names, "panda"):
        if scene.endswith("_" + name):
            return scene.removesuffix("_" + name)
    return scene


def scene_folders(root: Path) -> list[Path]:
    """Every folder under ``root`` (itself included) holding ``requestNNNN.yaml`` files, sorted by name."""
    return sorted({p.parent for p in root.rglob(_REQUEST)}, key=lambda p: (p.name, str(p)))


def _folder_problems(folder: Path, robot: RobotDescription, config: FieldConfig, options: PlanOptions | None,
                     limit: int | None) -> Iterator[Problem]:
    for request in sorted(folder.glob(_REQUEST))[:limit]:
        number = request.stem.removeprefix("request")
        scene = folder / f"scene{number}.yaml"
        if not scene.exists():
            yield Problem.unreadable(folder.name, int(number), f"{request.name}: no matching {scene.name} beside it")
            continue
        try:
            yield read_moveit_problem(scene, request, int(number), robot, config, options)
        except InvalidInput as exc:  # one bad pair is one failed problem, not a failed batch
            yield Problem.unreadable(folder.name, int(number), str(exc))


def _path_problems(path: Path, robot: RobotDescription, config: FieldConfig | None, options: PlanOptions | None,
                   wanted: set[str] | None, limit: int | None, found: set[str]) -> Iterator[Problem]:
    moveit = (robot, config or MBM_CONFIG, options)
    if path.is_dir():
        folders = scene_folders(path)
        if not folders:
            raise InvalidInput("problems", str(path), "the folder holds no requestNNNN.yaml/sceneNNNN.yaml pairs")
        for folder in folders:
            found.add(folder.name)
            if wanted is None or _short(folder.name, robot) in wanted:
                yield from _folder_problems(folder, *moveit, limit)
    elif _ARCHIVE.search(path.name):
        with tempfile.TemporaryDirectory(prefix="pfield-problems-") as tmp:
            extract_archive(path, Path(tmp))
            # read everything before the folder goes away (meshes are loaded into memory)
            yield from list(_path_problems(Path(tmp), robot, config, options, wanted, limit, found))
    elif path.suffix in (".yaml", ".yml"):
        with tempfile.TemporaryDirectory(prefix="pfield-scene-") as meshes:
            scene = load_scene(path, Path(meshes))
        options = PlanOptions.build(options, dt=scene["dt"], goal_tolerance=scene["goal_tolerance"],
                                    max_iterations=scene["max_iterations"])
        found.add(path.stem)
        yield Problem(path.stem, 0, tuple(scene["obstacles"]), scene["start"], scene["goal"],
                      config=config or scene["config"], options=options)
    elif not path.exists():
        raise InvalidInput("problems", str(path), "no such file or folder")
    else:
        raise InvalidInput("problems", str(path), "expected a scene .yaml, a folder of MoveIt problems or an archive")


def read_problems(paths: Iterable[str | Path], robot: str | RobotDescription | None = None,
                  config: FieldConfig | None = None, options: PlanOptions | None = None,
                  scenes: Sequence[str] | None = None, limit: int | None = None) -> list[Problem]:
    """Every problem of ``paths`` in order (see the module text). ``robot`` is the robot of MoveIt problems: a
    built-in name or a :class:`RobotDescription` (default ``"panda"``); ``config``/``options`` replace the
    defaults (:data:`MBM_CONFIG`, :func:`mbm_options` of the robot for MoveIt problems; a scene file's own for scene
    files).
    ``scenes`` keeps only the scenes of these names (the robot's suffix optional: ``box`` for ``box_ur5``, with
    the URDF's file stem or robot name, or ``_panda``), ``limit`` the first N problems of each scene.
    Two problems with the same ``(scene, index)`` are refused."""
    if isinstance(paths, str | Path):
        paths = [paths]
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int) or limit < 1):
        raise InvalidInput("limit", limit, "must be an integer >= 1 or None")
    description = _description(robot)
    wanted = {_short(s, description) for s in scenes} if scenes else None
    problems: list[Problem] = []
    found: set[str] = set()
    for path in paths:
        problems.extend(_path_problems(Path(path), description, config, options, wanted, limit, found))
    if wanted is not None:
        unknown = wanted - {_short(name, description) for name in found}
        if unknown:
            # another robot's scenes: the asked name and one more word, not one of this robot's suffixes
            ours = {*description.short_names, "panda"}
            near = sorted(name for name in found for u in unknown if name.startswith(f"{u}_")
                          and "_" not in name[len(u) + 1:] and name[len(u) + 1:] not in ours)
            hint = (f"; {', '.join(near)} would match with their robot given (a scene's robot suffix may be left "
                    f"out for the problems' own robot, here {description}): give the robot of these problems"
                    ) if near else ""
            raise InvalidInput("scenes", sorted(unknown), f"no such scene; known: {sorted(found)}{hint}")
        problems = [p for p in problems if _short(p.scene, description) in wanted]
    if problems and all(_OTHER_ROBOT in (p.error or "") for p in problems):  # refused whole, not planned N times
        raise InvalidInput("robot", str(description), problems[0].error or "")
    if limit is not None:
        counts: dict[str, int] = {}
        kept = []
        for problem in problems:
            counts[problem.scene] = counts.get(problem.scene, 0) + 1
            if counts[problem.scene] <= limit:
                kept.append(problem)
        problems = kept
    seen: set[tuple[str, int]] = set()
    for problem in problems:
        if problem.key in seen:
            raise InvalidInput("problems", f"{problem.scene}/{problem.index}", "two problems have this scene and index")
        seen.add(problem.key)
    return problems
