"""Time parameterisation of sampled joint paths within velocity and acceleration limits.

A planner's joint waypoints q_0 … q_{N−1} are a path; a ros2_control JointTrajectoryController needs a
trajectory: strictly increasing ``time_from_start`` and positions, velocities and accelerations within the
joint limits. :func:`retime_joint_path` keeps every waypoint; *knots* at least :data:`KNOT_SPACING` apart
along the path (the first and last always) carry the timing, chosen as follows:

* start from the planner's own spacing ``dt`` between knots;
* velocities and accelerations at each knot are the derivatives of the parabola through it and its
  two neighbouring knots (exact for quadratic motion on a non-uniform grid), zero velocity at both ends;
* wherever a sample exceeds |q̇_j| ≤ v_j (URDF) or |q̈_j| ≤ a_j (configured), the two intervals around
  it are lengthened by the violation ratio r = max(|q̇|/v, √(|q̈|/a)) (q̇ scales with 1/r, q̈ with 1/r²),
  round after round (compiled: ``src/core/planning/retime.cpp``), and a last uniform stretch removes any remainder;
* the waypoints between two knots get times in proportion to their arc length, and velocities and
  accelerations interpolated linearly between the knots' (so they stay within the limits too).

The stretching is local and cheap (≈0.1 ms for a 10 rad path), not time-optimal: the result is slower
than a time-optimal parameterisation where several limits bind in turn. Why not TOPP-RA (``toppra``)
through a spline of the waypoints: measured on the MotionBenchMaker plans it costs 25–50 ms per plan (more
than planning itself), and its limits hold at its grid points only (up to 5·10⁻⁴ relative excess between
them, so a uniform stretch is needed anyway).

Acceleration limits: the caller's — the planners pass :attr:`RobotModel.acceleration_limits
<pfield.robot.RobotModel.acceleration_limits>` (MoveIt's ``joint_limits.yaml``, else
:data:`~pfield.robot.limits.DEFAULT_JOINT_ACCELERATION` for revolute and
:data:`~pfield.robot.limits.DEFAULT_PRISMATIC_ACCELERATION` for prismatic joints).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import planning as _core
from pfield._validation import positive
from pfield.errors import InvalidInput

__all__ = ["TimedJointTrajectory", "path_length", "retime_joint_path"]

KNOT_SPACING = 0.05
"""rad (or m): least joint-space arc length between consecutive knots (``planning::knot_indices``,
``src/core/planning/retime.hpp``)."""
_ROUNDS = 2000
_MEAN_ROUNDS = 8  # rounds of the waypoint mean-speed check (one or two suffice on the planners' paths)



@dataclass(frozen=True, eq=False)
class TimedJointTrajectory:
    """A time-parameterised joint trajectory (what a JointTrajectoryController executes).

    Attributes:
        joint_names: tree order.
        times: (N,) s, strictly increasing, starting at 0.
        positions: (N, n) rad or m; velocities: (N, n) rad/s or m/s; accelerations: (N, n) rad/s² or m/s².
        velocity_limits, acceleration_limits: (n,) the limits the trajectory respects.
    """

    joint_names: tuple[str, ...]
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]
    velocity_limits: NDArray[np.float64]
    acceleration_limits: NDArray[np.float64]

    def __post_init__(self) -> None:
        for name in ("times", "positions", "velocities", "accelerations", "velocity_limits", "acceleration_limits"):
            array = np.array(getattr(self, name), dtype=np.float64)
            array.setflags(write=False)
            object.__setattr__(self, name, array)
        object.__setattr__(self, "joint_names", tuple(self.joint_names))

    @property
    def duration(self) -> float:
        return float(self.times[-1])


def path_length(points: ArrayLike) -> float:
    """Length of the polyline through ``points`` (N, n): Σ_k ‖w_{k+1} − w_k‖₂ (rad for joint paths, m for
    positions; 0 for a single point). The joint path length the planners report (issue 34)."""
    array = np.asarray(points, dtype=np.float64)
    return float(np.sum(np.linalg.norm(np.diff(array, axis=0), axis=1))) if len(array) > 1 else 0.0


def _limits(name: str, value: ArrayLike, count: int) -> NDArray[np.float64]:
    array = np.array(value, dtype=np.float64).reshape(-1)
    if array.shape != (count,):
        raise InvalidInput(name, value, f"expected {count} values")
    for j, item in enumerate(array):
        positive(f"{name}[{j}]", float(item))
    return array


def retime_joint_path(joint_names: tuple[str, ...], waypoints: ArrayLike, velocity_limits: ArrayLike,
                      acceleration_limits: ArrayLike, dt: float = 0.01) -> TimedJointTrajectory:
    """A trajectory through every waypoint of ``waypoints`` (N, n) within the limits (module doc).

    ``dt`` (s) is the planner's spacing, the shortest interval between knots. A waypoint that repeats the
    previous one gets the next representable time; a path that does not move stays at rest, ``dt`` apart.
    """
    points = np.array(waypoints, dtype=np.float64)
    if points.ndim != 2 or points.shape[0] == 0 or not np.all(np.isfinite(points)):
        raise InvalidInput("waypoints", f"array{points.shape}", "expected finite (N, n) joint positions, N >= 1")
    n = points.shape[1]
    if len(joint_names) != n:
        raise InvalidInput("joint_names", joint_names, f"expected {n} names")
    v_max = _limits("velocity_limits", velocity_limits, n)
    a_max = _limits("acceleration_limits", acceleration_limits, n)
    step = positive("dt", dt)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    if arc[-1] <= 0.0:  # nothing moves: at rest at every waypoint, dt apart
        zeros = np.zeros_like(points)
        resting = np.arange(len(points), dtype=np.float64) * step
        return TimedJointTrajectory(joint_names, resting, points, zeros, zeros, v_max, a_max)
    knots = _core.knot_indices(arc, KNOT_SPACING)
    knot_points = np.ascontiguousarray(points[knots])
    # waypoints between two knots: time in proportion to the arc length, velocity and acceleration
    # interpolated linearly (convex combinations of values within the limits stay within them)
    segment = np.clip(np.searchsorted(knots, np.arange(len(points)), side="right") - 1, 0, len(knots) - 2)
    arc0, arc1 = arc[knots[segment]], arc[knots[segment + 1]]
    share = np.clip((arc - arc0) / (arc1 - arc0), 0.0, 1.0)[:, None]
    steps = np.abs(np.diff(points, axis=0)) / v_max  # (N − 1, n): |Δq_j| / v_j, s
    h = np.full(len(knots) - 1, step)
    for round_ in range(_MEAN_ROUNDS):
        h, knot_v, knot_a = _core.stretch_intervals(knot_points, h, v_max, a_max, _ROUNDS)
        scale = max(1.0, float(np.max(np.abs(knot_v) / v_max)), float(np.sqrt(np.max(np.abs(knot_a) / a_max))))
        if scale > 1.0:  # the rounds stop within 1e-9 of the limits (or at their count): remove the rest uniformly
            h, knot_v, knot_a = h * scale, knot_v / scale, knot_a / scale**2
        times = np.concatenate([[0.0], np.cumsum(h)])[segment] + share[:, 0] * h[segment]
        # the mean speed between consecutive waypoints, |Δq_j| / Δt ≤ v_j: a path that turns back between two
        # knots moves a joint further than the knots' difference says (up to twice as far, measured on random
        # polylines), so a knot interval whose waypoints go too fast is lengthened by its worst ratio and the
        # timing redone (intervals only ever grow, so this settles; the last round stretches uniformly)
        ratio = np.max(steps, axis=1) / np.maximum(np.diff(times), np.finfo(np.float64).tiny)
        worst = np.zeros(len(h))
        np.maximum.at(worst, segment[:-1], ratio)
        excess = float(np.max(worst))
        if excess <= 1.0 + 1e-9:
            break
        if round_ == _MEAN_ROUNDS - 1:  # times are linear in h: a uniform stretch divides every ratio
            h, knot_v, knot_a, times = h * excess, knot_v / excess, knot_a / excess**2, times * excess
            break
        h = h * np.maximum(worst, 1.0)
    velocities = (1.0 - share) * knot_v[segment] + share * knot_v[segment + 1]
    accelerations = (1.0 - share) * knot_a[segment] + share * knot_a[segment + 1]
    times = np.ascontiguousarray(times)
    _core.strictly_increasing(times)
    return TimedJointTrajectory(joint_names, times, points, velocities, accelerations, v_max, a_max)

