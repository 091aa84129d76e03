"""The result of every planner: :class:`PlannedPath` (task-space or whole-body), and its CSV export.

A plan is a sequence of N waypoints sampled every ``dt`` seconds: the end-effector pose (world frame),
the twist commanded at that waypoint, the clearance to the nearest obstacle and, for whole-body plans,
the joint positions and velocities in the robot's tree order. The first waypoint is the start.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pfield.errors import InvalidInput
from pfield.planning.retime import TimedJointTrajectory, path_length
from pfield.planning.status import PlanStatus
from pfield.spatial import Pose, Twist

__all__ = ["PLANNERS", "PlannedPath"]

PLANNERS = ("field", "field+global")
"""Values of :attr:`PlannedPath.planner`."""


def _frozen(name: str, value: object, shape: tuple[int | None, ...]) -> NDArray[np.float64]:
    array = np.array(value, dtype=np.float64)
    if array.ndim != len(shape) or any(
        want is not None and got != want for got, want in zip(array.shape, shape, strict=True)
    ):
        expected = tuple("N" if size is None else size for size in shape)
        raise InvalidInput(name, f"array{array.shape}", f"expected shape {expected}")
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False, repr=False)
class PlannedPath:
    """A planned trajectory with its status (DESIGN §3.3).

    Attributes:
        success: True when the last waypoint is within the goal tolerances (``status`` is REACHED).
        failure_reason: empty on success, else a sentence saying why and what blocks (the obstacle, or the
            link and obstacle, their distance and where).
        times: (N,) s, ``i·dt`` from the start.
        positions: (N, 3) m, end-effector positions in the world frame.
        orientations: (N, 4) unit quaternions (x, y, z, w), world frame.
        twists: (N, 6) the world-frame twist (linear m/s, angular rad/s) applied from each waypoint.
        clearances: (N,) m, signed distance to the nearest obstacle (``inf`` without obstacles). Task space: of the
            end-effector point. Whole body: of the planner's link model (:mod:`pfield.robot.geometry`), which
            contains each link's collision meshes, so it is a lower bound of the meshes' distance; it can be
            negative where the model overlaps an obstacle the meshes clear (a link whose model already overlaps
            it at the start may stay as deep; a coarse fit, such as a large gap on a link, shows most). Whether the
            meshes touch is the certificate's to say (:func:`pfield.planning.certify.certify_path`): a reached plan
            passed it.
        iterations: integration steps taken (N − 1 for a plan that was not cut short).
        joint_names: joint names in tree order (empty for task-space plans).
        joint_positions: (N, n) rad or m, or None for task-space plans.
        joint_velocities: (N, n) rad/s or m/s, or None.
        status: why the plan ended (:class:`PlanStatus`); compare this, not ``failure_reason``. May be
            omitted only for a successful path (then REACHED).
        planner: what produced the path (one of :data:`PLANNERS`): ``"field"`` (the potential field alone)
            or ``"field+global"`` (the field tracking the path of the global fallback search).
        trajectory: the joint path time-parameterised within the joint velocity and acceleration limits
            (what a JointTrajectoryController executes), or None (task-space plans without joints).

    Per-plan measures (properties, computed from the fields): :attr:`joint_path_length` (rad) and
    :attr:`trajectory_duration` (s).
    """

    success: bool
    failure_reason: str
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    orientations: NDArray[np.float64]
    twists: NDArray[np.float64]
    clearances: NDArray[np.float64]
    iterations: int = 0
    joint_names: tuple[str, ...] = ()
    joint_positions: NDArray[np.float64] | None = field(default=None)
    joint_velocities: NDArray[np.float64] | None = field(default=None)
    status: PlanStatus = field(default=None)  # type: ignore[assignment]  # None → REACHED for a success
    planner: str = PLANNERS[0]
    trajectory: TimedJointTrajectory | None = None

    def __post_init__(self) -> None:
        self._check_status()
        times = _frozen("times", self.times, (None,))
        count = times.shape[0]
        if count == 0:
            raise InvalidInput("times", "array(0,)", "a plan has at least the start waypoint")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "positions", _frozen("positions", self.positions, (count, 3)))
        object.__setattr__(self, "orientations", _frozen("orientations", self.orientations, (count, 4)))
        object.__setattr__(self, "twists", _frozen("twists", self.twists, (count, 6)))
        object.__setattr__(self, "clearances", _frozen("clearances", self.clearances, (count,)))
        object.__setattr__(self, "joint_names", tuple(str(name) for name in self.joint_names))
        width = len(self.joint_names)
        for name in ("joint_positions", "joint_velocities"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _frozen(name, value, (count, width)))
        if self.success and self.failure_reason:
            raise InvalidInput("failure_reason", self.failure_reason, "must be empty when success is True")
        object.__setattr__(self, "success", bool(self.success))
        object.__setattr__(self, "iterations", int(self.iterations))
        if self.planner not in PLANNERS:
            raise InvalidInput("planner", self.planner, f"must be one of {PLANNERS}")

    @classmethod
    def _owned(cls, status: PlanStatus, failure_reason: str, times: NDArray[np.float64],
               positions: NDArray[np.float64], orientations: NDArray[np.float64], twists: NDArray[np.float64],
               clearances: NDArray[np.float64], planner: str) -> PlannedPath:
        """A task-space path from arrays a planner has just made for it and shares with nobody: float64,
        C-contiguous, of consistent shapes (N,), (N, 3), (N, 4), (N, 6), (N,), N ≥ 1. They are frozen in place,
        not copied and checked again as the constructor does with arrays it is given (those may be the caller's,
        which it must not freeze). The same value as ``PlannedPath(...)`` with these fields."""
        for array in (times, positions, orientations, twists, clearances):
            array.flags.writeable = False
        path = object.__new__(cls)
        path.__dict__.update(
            success=status is PlanStatus.REACHED, failure_reason=failure_reason, times=times, positions=positions,
            orientations=orientations, twists=twists, clearances=clearances, iterations=len(times) - 1,
            joint_names=(), joint_positions=None, joint_velocities=None, status=status, planner=planner,
            trajectory=None)
        return path

    def _check_status(self) -> None:
        status = self.status
        if status is None:
            if not self.success:
                raise InvalidInput("status", None, "a failed plan needs its PlanStatus")
            status = PlanStatus.REACHED
        try:
            status = PlanStatus(status)
        except ValueError:
            raise InvalidInput("status", self.status, "expected a pfield.PlanStatus") from None
        if bool(self.success) != status.success:
            raise InvalidInput("status", status.name, f"contradicts success={bool(self.success)}")
        object.__setattr__(self, "status", status)

    def __len__(self) -> int:
        return int(self.times.shape[0])

    def __repr__(self) -> str:
        """A summary, not the arrays: ``PlannedPath(REACHED by field+global: 475 waypoints over 9.48 s, ...)``."""
        parts = [f"{len(self)} waypoints over {self.duration:.3g} s"]
        if self.joint_positions is not None:
            parts.append(f"{len(self.joint_names)} joints, joint path {self.joint_path_length:.3g} rad")
        if self.trajectory_duration is not None:
            parts.append(f"trajectory {self.trajectory_duration:.3g} s")
        parts.append(f"min clearance {self.min_clearance:.3g} m")
        reason = "" if self.success else f"; {self.failure_reason}"
        return f"PlannedPath({self.status.name} by {self.planner}: {', '.join(parts)}{reason})"

    @property
    def poses(self) -> list[Pose]:
        """The waypoints as :class:`~pfield.spatial.Pose` objects (world frame)."""
        return [Pose(p, q) for p, q in zip(self.positions, self.orientations, strict=True)]

    @property
    def twist_list(self) -> list[Twist]:
        """The twists as :class:`~pfield.spatial.Twist` objects (world frame)."""
        return [Twist(t[:3], t[3:]) for t in self.twists]

    @property
    def final_pose(self) -> Pose:
        return Pose(self.positions[-1], self.orientations[-1])

    @property
    def duration(self) -> float:
        """Time of the last waypoint (s)."""
        return float(self.times[-1])

    @property
    def joint_path_length(self) -> float | None:
        """Σ_i ‖q_{i+1} − q_i‖₂ over ``joint_positions`` (rad; a prismatic joint's metres count as they are),
        or None for a task-space plan without joints (:func:`pfield.planning.retime.path_length`)."""
        return None if self.joint_positions is None else path_length(self.joint_positions)

    @property
    def trajectory_duration(self) -> float | None:
        """Duration (s) of ``trajectory``, the joint path retimed within the robot's velocity and acceleration
        limits (what a controller takes to execute it; not :attr:`duration`, the planner's own step time), or
        None without one."""
        return None if self.trajectory is None else self.trajectory.duration

    @property
    def min_clearance(self) -> float:
        """Smallest clearance along the path (m; :attr:`clearances`: whole body, of the link model, a lower bound of
        the meshes'); ``inf`` without obstacles."""
        return float(np.min(self.clearances))

    def csv_header(self) -> list[str]:
        """Column names of :meth:`to_csv`."""
        header = ["time", "x", "y", "z", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz", "clearance"]
        if self.joint_positions is not None:
            header += [f"position_{name}" for name in self.joint_names]
        if self.joint_velocities is not None:
            header += [f"velocity_{name}" for name in self.joint_names]
        return header

    def to_csv(self, path: str | Path) -> Path:
        """Write one row per waypoint (columns: :meth:`csv_header`, SI units, world frame); return the path.

        Values are written with ``repr`` precision, so reading the file back gives the same floats;
        ``inf`` clearances are written as ``inf``.
        """
        target = Path(path)
        columns = [self.times[:, None], self.positions, self.orientations, self.twists, self.clearances[:, None]]
        if self.joint_positions is not None:
            columns.append(self.joint_positions)
        if self.joint_velocities is not None:
            columns.append(self.joint_velocities)
        table = np.hstack(columns)
        with target.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(self.csv_header())
            for row in table:
                writer.writerow([repr(float(v)) if math.isfinite(v) else str(float(v)) for v in row])
        return target

