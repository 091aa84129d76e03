"""Shared helpers for the benchmark modules: timing and the result row."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np


@dataclass(frozen=True)
class BenchRow:
    """One measured figure.

    ``value`` is in ``unit``; ``reference`` is the C++ original's figure in the same unit (REFERENCE.md),
    ``target`` the issue's target; either may be None. Lower is better unless ``higher_is_better``.
    ``old_value`` is the numba engine's figure of the same row, measured in the same run
    (``benchmarks/_old_engine.py``); None when it was not run. A row only the numba engine has keeps its figure
    there and NaN as ``value``.
    """

    section: str
    name: str
    value: float
    unit: str
    reference: float | None = None
    target: float | None = None
    higher_is_better: bool = False
    note: str = ""
    old_value: float | None = None

    def ratio(self) -> float | None:
        """value / reference (speed-up factor is 1/ratio for time-like figures)."""
        if self.reference is None or self.reference == 0 or math.isnan(self.value):
            return None
        return self.value / self.reference

    def new_old(self) -> float | None:
        """The new engine against the numba engine, oriented so that ≤ 1 means no worse: value / old_value, or
        old_value / value where higher is better (plans/s, success). None without both figures or with a zero."""
        if self.old_value is None or math.isnan(self.value) or math.isnan(self.old_value):
            return None
        top, bottom = (self.old_value, self.value) if self.higher_is_better else (self.value, self.old_value)
        if bottom == 0:
            return 1.0 if top == 0 else None
        return top / bottom

    def meets_target(self) -> bool | None:
        if self.target is None or math.isnan(self.value):
            return None
        return self.value >= self.target if self.higher_is_better else self.value <= self.target

    def as_dict(self) -> dict[str, Any]:
        return asdict(self) | {"ratio": self.ratio(), "meets_target": self.meets_target(), "new_old": self.new_old()}


def median_time(fn: Callable[[], object], *, repeat: int = 7, number: int = 1, warmup: int = 2,
                clock: Callable[[], float] = time.perf_counter) -> float:
    """Median time of ``fn`` in seconds per call on ``clock`` (wall time by default), after ``warmup`` calls."""
    for _ in range(warmup):
        fn()
    samples = []
    for _ in range(repeat):
        start = clock()
        for _ in range(number):
            fn()
        samples.append((clock() - start) / number)
    samples.sort()
    return samples[len(samples) // 2]


class Report(NamedTuple):
    """What a module's ``run`` may return instead of bare rows: the rows and other views of them (file name →
    Markdown or CSV text, or a picture's bytes), which the runner writes beside the rows."""

    rows: list[BenchRow]
    files: dict[str, str | bytes]


HOST_CHECK = "host check: sum(range(10**6)) in pure Python"


def host_check_ms() -> float:
    """A fixed pure-Python workload, median of 5 runs (ms): the host's speed when a module ran.

    Hosts differ and a shared one changes speed from hour to hour; a single-thread figure that moved between two
    runs by about the same factor as this one most likely moved with the host, not with the code (figures of
    several processes or of memory traffic need not follow it)."""
    return 1e3 * median_time(lambda: sum(range(10**6)), repeat=5, warmup=1)


def cpu_time(fn: Callable[[], object], repeat: int, number: int = 1) -> float:
    """Median CPU time of this process per call of ``fn`` (s), after one warm-up call: unlike wall time,
    it does not grow when other processes share the machine."""
    return median_time(fn, repeat=repeat, number=number, warmup=1, clock=time.process_time)


def auto_number(fn: Callable[[], object], budget_s: float = 0.05) -> int:
    """How many calls of ``fn`` fill about ``budget_s`` seconds (at least 1)."""
    fn()
    start = time.perf_counter()
    fn()
    once = max(time.perf_counter() - start, 1e-9)
    return max(1, int(budget_s / once))


# ---------------------------------------------------------------------------------------------------------------
# The benchmarks' own exact collision check, independent of the planner's (pfield.planning.certify and
# pfield.robot.collision's checker are not used): the robot is read from its URDF by pinocchio with its collision
# meshes, obstacles become coal shapes (by pfield.robot.collision.coal_geometry, the one conversion of a shape to
# coal, which tests/test_every_shape.py holds to the core's signed distances), and a pair is in contact when coal's
# collision test finds the link mesh (a BVH of its triangles) touching the obstacle's solid shape or the other link's
# mesh. Filters that never hide a contact come first: world bounding boxes, then the meshes' convex hulls
# (coal/qhull; a hull contains its mesh).
# Not detected: one link mesh wholly inside another's without touching its triangles.


def _local_box(geometry: Any) -> tuple[np.ndarray, np.ndarray]:
    """(centre (3,), half extents (3,)) of a coal geometry's bounding box in its own frame."""
    geometry.computeLocalAABB()
    low, high = np.asarray(geometry.aabb_local.min_), np.asarray(geometry.aabb_local.max_)
    return 0.5 * (low + high), 0.5 * (high - low)


def _world_boxes(centres: np.ndarray, halves: np.ndarray, rotations: np.ndarray, translations: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """World axis-aligned bounds (low (G, 3), high (G, 3)) of local boxes (centres, halves (G, 3)) placed at
    (R (G, 3, 3), t (G, 3)): centre R c + t, half extents |R| h."""
    centre = np.matmul(rotations, centres[:, :, None])[:, :, 0] + translations
    half = np.matmul(np.abs(rotations), halves[:, :, None])[:, :, 0]
    return centre - half, centre + half


class ExactRobot:
    """A robot's collision geometry for the benchmarks' independent check (pinocchio + coal, nothing of pfield's).

    ``urdf`` is read with its COLLISION geometry; ``package_dirs`` are the folders in which ``package://NAME/…``
    resolves as ``DIR/NAME/…`` (the URDF's own folder is added for paths relative to it). ``joint_names`` are the
    planner's joints, in the order of the configurations given to :meth:`scene`'s check; ``fixed`` gives the other
    joints' values (rad or m; e.g. the Panda's fingers; unnamed ones stay at 0). Self pairs: every pair of geometries on
    different links, except the SRDF's ``disable_collisions`` pairs, pairs that no joint motion can move (attached
    to the same moving joint) and links joined by one URDF joint (which meet there by construction; MoveIt's
    "Adjacent").
    """

    def __init__(self, urdf: str | Path, package_dirs: list[str | Path], joint_names: tuple[str, ...] | list[str],
                 srdf: str | Path | None = None, fixed: dict[str, float] | None = None) -> None:
        import xml.etree.ElementTree as ET

        import coal
        import pinocchio as pin

        urdf = Path(urdf)
        dirs = [str(p) for p in package_dirs] + [str(urdf.parent)]
        self.model, self.geometry, _ = pin.buildModelsFromUrdf(str(urdf), dirs,
                                                                geometry_types=[pin.GeometryType.COLLISION,
                                                                                pin.GeometryType.VISUAL])
        self.data = self.model.createData()
        self.geometry_data = self.geometry.createData()
        self._pin = pin
        names = list(self.model.names)
        missing = [n for n in [*joint_names, *(fixed or {})] if n not in names]
        if missing:
            raise ValueError(f"joints {missing} are not movable joints of {urdf.name} (its joints: {names[1:]})")
        self.joint_names = tuple(joint_names)
        self._q0 = pin.neutral(self.model)
        for name, value in (fixed or {}).items():
            self._set(self._q0, name, value)
        self.shapes: list[Any] = []  # coal geometries in their joint's frame: meshes (BVH) or primitives
        self.hulls: list[Any] = []  # the meshes' convex hulls (the primitives themselves)
        self.links: list[str] = []
        for obj in self.geometry.geometryObjects:
            shape = hull = obj.geometry
            if isinstance(shape, coal.BVHModelBase):
                shape.buildConvexHull(True, "Qt")
                hull = shape.convex
            self.shapes.append(shape)
            self.hulls.append(hull)
            self.links.append(self.model.frames[obj.parentFrame].name)
        boxes = [_local_box(s) for s in self.shapes]
        self.centres, self.halves = np.array([b[0] for b in boxes]), np.array([b[1] for b in boxes])
        disabled: set[frozenset[str]] = set()
        if srdf is not None:
            for item in ET.parse(srdf).getroot().iter("disable_collisions"):
                disabled.add(frozenset((item.get("link1", ""), item.get("link2", ""))))
        for joint in ET.parse(urdf).getroot().iter("joint"):  # links one joint apart meet there by construction
            parent, child = joint.find("parent"), joint.find("child")
            if parent is not None and child is not None:
                disabled.add(frozenset((parent.get("link", ""), child.get("link", ""))))
        joints = [obj.parentJoint for obj in self.geometry.geometryObjects]
        self.self_pairs = np.array([(a, b) for a in range(len(self.shapes)) for b in range(a + 1, len(self.shapes))
                                    if self.links[a] != self.links[b] and joints[a] != joints[b]
                                    and frozenset((self.links[a], self.links[b])) not in disabled],
                                   dtype=np.int64).reshape(-1, 2)

    def _set(self, q: np.ndarray, name: str, value: float) -> None:
        joint = self.model.joints[self.model.getJointId(name)]
        if joint.nq == 2:  # a continuous joint: (cos, sin)
            q[joint.idx_q:joint.idx_q + 2] = (math.cos(value), math.sin(value))
        else:
            q[joint.idx_q] = value

    def placements(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World rotations (G, 3, 3) and translations (G, 3) of the collision geometries at joint values ``q``."""
        full = self._q0.copy()
        for name, value in zip(self.joint_names, np.asarray(q, dtype=float), strict=True):
            self._set(full, name, float(value))
        self._pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data, full)
        placed = self.geometry_data.oMg
        return (np.array([m.rotation for m in placed]), np.array([m.translation for m in placed]))

    def scene(self, obstacles: Any) -> ExactScene:
        """This robot among ``obstacles`` (pfield :class:`~pfield.geometry.Obstacle` s)."""
        return ExactScene(self, list(obstacles))


class ExactScene:
    """:class:`ExactRobot` among fixed obstacles: :meth:`contact` at one configuration, :meth:`path_contact` along
    a joint path."""

    def __init__(self, robot: ExactRobot, obstacles: list[Any]) -> None:
        import coal

        from pfield.robot.collision import coal_geometry

        self.robot, self._coal = robot, coal
        self.names = [o.id for o in obstacles]
        self.shapes = [coal_geometry(o) for o in obstacles]
        self.transforms: list[Any] = []
        for o in obstacles:
            x, y, z, w = (float(v) for v in o.pose.orientation)
            rotation = coal.Quaternion(w, x, y, z).toRotationMatrix()
            self.transforms.append(coal.Transform3s(rotation, np.asarray(o.pose.position, dtype=float)))
        if obstacles:
            boxes = [_local_box(s) for s in self.shapes]
            rotations = np.array([t.getRotation() for t in self.transforms])
            translations = np.array([t.getTranslation() for t in self.transforms])
            self.low, self.high = _world_boxes(np.array([b[0] for b in boxes]), np.array([b[1] for b in boxes]),
                                               rotations, translations)
        else:
            self.low = self.high = np.zeros((0, 3))
        self.checks = 0

    def _collide(self, a: Any, ta: Any, b: Any, tb: Any) -> bool:
        request, result = self._coal.CollisionRequest(), self._coal.CollisionResult()
        return bool(self._coal.collide(a, ta, b, tb, request, result))

    def _touch(self, g: int, tg: Any, other: Any, hull: Any, to: Any) -> bool:
        """Robot geometry ``g`` at ``tg`` against ``other`` (its hull ``hull``) at ``to``: the hulls first (they
        contain the meshes: apart, the meshes are too), then the meshes themselves."""
        robot = self.robot
        if not self._collide(robot.hulls[g], tg, hull, to):
            return False
        if robot.hulls[g] is robot.shapes[g] and hull is other:
            return True
        return self._collide(robot.shapes[g], tg, other, to)

    def contact(self, q: np.ndarray) -> str:
        """"" when the robot at joint values ``q`` touches neither an obstacle nor itself (over its checked self
        pairs); else the first pair in contact, ``link/obstacle`` or ``link/link``."""
        self.checks += 1
        robot = self.robot
        rotations, translations = robot.placements(q)
        low, high = _world_boxes(robot.centres, robot.halves, rotations, translations)
        placed: dict[int, Any] = {}

        def at(g: int) -> Any:
            if g not in placed:
                placed[g] = self._coal.Transform3s(rotations[g], translations[g])
            return placed[g]

        if len(self.shapes):
            near = np.argwhere(np.all(low[:, None, :] <= self.high[None], axis=2)
                               & np.all(high[:, None, :] >= self.low[None], axis=2))
            for g, o in near.tolist():
                if self._touch(g, at(g), self.shapes[o], self.shapes[o], self.transforms[o]):
                    return f"{robot.links[g]}/{self.names[o]}"
        pairs = robot.self_pairs
        if len(pairs):
            a, b = pairs[:, 0], pairs[:, 1]
            near_pairs = pairs[np.all(low[a] <= high[b], axis=1) & np.all(high[a] >= low[b], axis=1)]
            for g, h in near_pairs.tolist():
                if self._touch(g, at(g), robot.shapes[h], robot.hulls[h], at(h)):
                    return f"{robot.links[g]}/{robot.links[h]}"
        return ""

    def path_contact(self, positions: np.ndarray, resolution: float = 0.01) -> tuple[int, float, str] | None:
        """The first contact along the joint path ``positions`` (N, n), checked at every waypoint and at most
        ``resolution`` (rad or m, max-norm of the joint change) between consecutive ones: (waypoint k, fraction
        of the segment k → k + 1, pair), or None when the whole path is clear."""
        positions = np.asarray(positions, dtype=float)
        pair = self.contact(positions[0])
        if pair:
            return 0, 0.0, pair
        for k in range(len(positions) - 1):
            a, b = positions[k], positions[k + 1]
            steps = max(1, math.ceil(float(np.max(np.abs(b - a))) / resolution))
            for i in range(1, steps + 1):
                pair = self.contact(a + (b - a) * (i / steps))
                if pair:
                    return k, i / steps, pair
        return None


def ros2_session(module: str, args: list[str], environment: dict[str, str], timeout: float) -> Any:
    """``python -m MODULE ARGS…`` in a private network namespace (loopback up) with ``environment`` added: the JSON
    of its last output line, or a string saying why the session could not run."""
    if shutil.which("unshare") is None:
        return "unshare not found (needs a private network namespace)"
    if importlib.util.find_spec("potential_fields_interfaces") is None:
        return "ros2 extra or interfaces missing (make ros2-interfaces)"
    inner = ["unshare", "-n", "sh", "-c", 'ip link set lo up && exec "$@"', "sh",
             sys.executable, "-m", module, *args]
    process = subprocess.run(inner, env=dict(os.environ, **environment), cwd=Path(__file__).resolve().parents[1],
                             capture_output=True, text=True, timeout=timeout, check=False)
    if process.returncode != 0:
        return f"session failed: {process.stderr.strip().splitlines()[-1:]}"
    return json.loads(process.stdout.strip().splitlines()[-1])
