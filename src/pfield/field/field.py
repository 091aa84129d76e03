"""The 3D potential field over a goal pose and an obstacle set (:class:`PotentialField`).

The object is immutable: it validates its inputs, packs the obstacles and the parameters once into
arrays, binds them to the compiled core once (``src/core/field``, :mod:`pfield._core`), and every query is one
call of the core. Changing the goal, the obstacles or the parameters gives a new field
(:meth:`PotentialField.with_goal` …).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield import safety
from pfield._core import field as _core_field
from pfield._validation import as_points, finite
from pfield.errors import InvalidInput
from pfield.field.config import FieldConfig
from pfield.geometry import Obstacle, PackedObstacles, pack_obstacles, signed_distances
from pfield.geometry.packed import SPHERE, bounding_radius
from pfield.spatial import Pose, Twist, Wrench, twist_from_checked, wrench_from_checked

if TYPE_CHECKING:
    from pfield.planning.options import PlanOptions
    from pfield.planning.result import PlannedPath
    from pfield.planning.whole_body import WholeBodyOptions

__all__ = ["FieldArrays", "PotentialField"]

_LOG = logging.getLogger(__name__)


class FieldArrays(NamedTuple):
    """What the compiled core (and the whole-body kernels) take: C-contiguous float64 arrays.

    ``goal`` (7,) position + quaternion (x, y, z, w); ``params`` (16,) :meth:`FieldConfig.packed`;
    ``packed`` the obstacles; ``aux`` (M, 8) circulation axes, bounding radii, centres and sphere flags.
    """

    goal: NDArray[np.float64]
    params: NDArray[np.float64]
    packed: PackedObstacles
    aux: NDArray[np.float64]


def _readonly(array: NDArray[np.float64]) -> NDArray[np.float64]:
    array.setflags(write=False)
    return array


def obstacle_aux(packed: PackedObstacles, goal_position: NDArray[np.float64]) -> NDArray[np.float64]:
    """(M, 8) circulation axes, bounding radii, centres and sphere flags of packed obstacles for a goal (the core's
    ``ObstacleAux`` rows, ``src/core/field/evaluate.hpp``).

    The circulation axis of obstacle i is c_i = normalize((g − centre_i) × ẑ) (× x̂ when the goal lies
    straight above or below the centre): the tangential motion n × c_i then runs in the vertical plane
    through the centre and the goal, over the top of the obstacle when approaching it head-on.
    """
    count = packed.kinds.shape[0]
    aux = np.zeros((count, 8))
    for i in range(count):
        centre = packed.rows[i, :3]
        toward_goal = goal_position - centre
        axis = np.cross(toward_goal, (0.0, 0.0, 1.0))
        if np.linalg.norm(axis) <= 1e-9 * max(float(np.linalg.norm(toward_goal)), 1e-9):
            axis = np.cross(toward_goal, (1.0, 0.0, 0.0))
        norm = float(np.linalg.norm(axis))
        aux[i, :3] = axis / norm if norm > 1e-12 else (1.0, 0.0, 0.0)
        aux[i, 3] = bounding_radius(packed, i)
        aux[i, 4:7] = centre
        aux[i, 7] = 1.0 if int(packed.kinds[i]) == SPHERE else 0.0
    return aux


def _check_pose(name: str, pose: Any) -> Pose:
    if not isinstance(pose, Pose):
        raise InvalidInput(name, pose, "expected a pfield.Pose")
    return pose


class PotentialField:
    """Attraction to ``goal``, repulsion from ``obstacles`` and the constrained twist, in the world frame.

    ``PotentialField(FieldConfig(), goal=Pose((0.5, 0.2, 0.4)), obstacles=[...])``. Obstacle ids must be
    unique. See ``docs/field.md`` for the laws; the parameters are those of :class:`FieldConfig`.
    """

    __slots__ = ("_arrays", "_config", "_core", "_goal", "_obstacles")

    def __init__(self, config: FieldConfig, goal: Pose, obstacles: Sequence[Obstacle] = ()) -> None:
        if not isinstance(config, FieldConfig):
            raise InvalidInput("config", config, "expected a pfield.FieldConfig")
        goal = _check_pose("goal", goal)
        items = tuple(obstacles)
        seen: set[str] = set()
        for index, obstacle in enumerate(items):
            if not isinstance(obstacle, Obstacle):
                raise InvalidInput(f"obstacles[{index}]", obstacle, "expected a pfield.Obstacle")
            if obstacle.id in seen:
                raise InvalidInput(f"obstacles[{index}].id", obstacle.id, "duplicate obstacle id")
            seen.add(obstacle.id)
        self._build(config, goal, items, pack_obstacles(items))

    def _build(self, config: FieldConfig, goal: Pose, obstacles: tuple[Obstacle, ...], packed: PackedObstacles) -> None:
        self._config, self._goal, self._obstacles = config, goal, obstacles
        goal_array = _readonly(np.concatenate([goal.position, goal.orientation]))
        aux = _readonly(obstacle_aux(packed, goal_array[:3]))
        self._arrays = FieldArrays(goal_array, _readonly(config.packed()), packed, aux)
        self._core = _core_field.Field(goal_array, self._arrays.params, aux, *packed)

    @classmethod
    def _from_parts(
        cls, config: FieldConfig, goal: Pose, obstacles: tuple[Obstacle, ...], packed: PackedObstacles
    ) -> PotentialField:
        field = cls.__new__(cls)
        field._build(config, goal, obstacles, packed)
        return field

    # ---------------------------------------------------------------- properties and derived fields

    @property
    def config(self) -> FieldConfig:
        return self._config

    @property
    def goal(self) -> Pose:
        return self._goal

    @property
    def obstacles(self) -> tuple[Obstacle, ...]:
        return self._obstacles

    @property
    def arrays(self) -> FieldArrays:
        """The packed inputs of the compiled kernels (for other compiled consumers, e.g. whole-body)."""
        return self._arrays

    @property
    def compiled(self) -> Any:
        """The compiled field over :attr:`arrays` (``pfield._core.field.Field``): what the planners and
        :class:`~pfield.field.PreparedTwist` run, on arguments they have checked."""
        return self._core

    def with_goal(self, goal: Pose) -> PotentialField:
        """The same field with another goal (the obstacles are not packed again)."""
        return self._from_parts(self._config, _check_pose("goal", goal), self._obstacles, self._arrays.packed)

    def with_obstacles(self, obstacles: Sequence[Obstacle]) -> PotentialField:
        """The same field with another obstacle set."""
        return PotentialField(self._config, self._goal, obstacles)

    def with_config(self, config: FieldConfig) -> PotentialField:
        """The same field with other parameters."""
        if not isinstance(config, FieldConfig):
            raise InvalidInput("config", config, "expected a pfield.FieldConfig")
        return self._from_parts(config, self._goal, self._obstacles, self._arrays.packed)

    def __repr__(self) -> str:
        return f"PotentialField(goal={self._goal!r}, obstacles={[o.id for o in self._obstacles]})"

    # ---------------------------------------------------------------- single poses

    def wrench(self, pose: Pose) -> Wrench:
        """The raw wrench at ``pose`` (world frame, before any limit).

        force = attraction (quadratic within Γ, conical beyond) + Σ_i saturated Khatib repulsion
        m_i/√(1 + (m_i/F_cap)²) · n_i, m_i = η (1/d_i − 1/Q)/d_i², over obstacles with d_i < Q;
        torque = k_rot · log(q_goal ⊗ q⁻¹). Units N and N·m (unit mass and inertia).
        """
        answer = self._core.wrench_value(pose)  # a Pose read as it was built and checked (twist below)
        if answer is None:
            pose = _check_pose("pose", pose)
            answer = wrench_from_checked(*self._core.wrench(pose.position, pose.orientation))
        return answer

    def twist(self, pose: Pose, previous: Twist | None = None, dt: float = 0.0) -> Twist:
        """The constrained twist at ``pose``: the task-space autonomy vector (m/s, rad/s, world frame).

        Soft-saturated attraction and rotation, velocity dampers with a consistent tangential
        component near obstacles, then — when ``previous`` is given — rate limits
        ‖v − v_prev‖ ≤ a_max·``dt`` and ‖ω − ω_prev‖ ≤ α_max·``dt`` (``dt`` > 0 s required then).
        """
        # A Pose and a Twist were validated when they were built (finite, unit quaternion; read-only arrays): the
        # core reads them as they are and answers a Twist, for exactly those classes and a float dt in (0, inf).
        answer = self._core.twist_value(pose, previous, dt)
        return self._twist_checked(pose, previous, dt) if answer is None else answer

    def _twist_checked(self, pose: Pose, previous: Twist | None, dt: float) -> Twist:
        """:meth:`twist` for the arguments its hot path hands back: checked here (the errors), then answered from
        their arrays; a halted answer (not finite, zeros under the output contract) is logged."""
        if not isinstance(pose, Pose):
            raise InvalidInput("pose", pose, "expected a pfield.Pose")
        if previous is None:
            linear, angular, outcome = self._core.twist(pose.position, pose.orientation, None, None, 0.0)
        else:
            if not isinstance(previous, Twist):
                raise InvalidInput("previous", previous, "expected a pfield.Twist or None")
            step = finite("dt", dt)
            if step <= 0.0:
                raise InvalidInput("dt", dt, "must be > 0 when a previous twist is given")
            linear, angular, outcome = self._core.twist(pose.position, pose.orientation, previous.linear,
                                                        previous.angular, step)
        if outcome:  # the core applied the output contract (pfield.safety): HALTED is the outcome to report
            self._halted(outcome, pose)
        return twist_from_checked(linear, angular)

    @staticmethod
    def _halted(outcome: int, pose: Pose) -> None:
        if outcome == safety.HALTED:
            _LOG.warning("twist at %r was not finite: answered zero (%s)", pose, safety.describe(safety.HALTED))

    # ---------------------------------------------------------------- batches

    def _batch(self, positions: ArrayLike, orientations: ArrayLike | None) -> tuple[NDArray[Any], NDArray[Any]]:
        """Positions (N, 3) and orientations (N or 1, 4) as the core's batches take them (C-contiguous float64, read
        in place): shapes checked here, rows checked (finite, nonzero quaternion) and quaternions normalised by the
        core."""
        points = as_points("positions", positions, check_finite=False)
        if orientations is None:
            return points, self._goal.orientation.reshape(1, 4)
        try:
            quats = np.require(orientations, dtype=np.float64, requirements=["C"])
        except (TypeError, ValueError) as exc:
            raise InvalidInput("orientations", orientations,
                               f"expected an array of shape ({points.shape[0]}, 4)") from exc
        if quats.shape == (4,):
            quats = quats.reshape(1, 4)
        if quats.ndim != 2 or quats.shape[1] != 4 or quats.shape[0] not in (1, points.shape[0]):
            raise InvalidInput("orientations", f"array{quats.shape}", f"expected ({points.shape[0]}, 4) or (4,)")
        return points, quats

    @staticmethod
    def _rows_checked(result: tuple[NDArray[np.float64], int], points: NDArray[Any],
                      quats: NDArray[Any]) -> NDArray[np.float64]:
        """The core's values, or the error naming the first row it refused."""
        values, row = result
        if row >= 0:
            if not np.all(np.isfinite(points[row])):
                raise InvalidInput(f"positions[{row}]", points[row].tolist(), "must be finite (no NaN or inf)")
            quat = quats[row if quats.shape[0] > 1 else 0]
            raise InvalidInput(f"orientations[{row}]", quat.tolist(), "must be a finite, nonzero quaternion")
        return values

    def wrenches(self, positions: ArrayLike, orientations: ArrayLike | None = None) -> NDArray[np.float64]:
        """Raw wrenches (N, 6) = force, torque at N poses; orientations (N, 4) or one (4,) for all (normalised),
        default the goal's.

        One call of the core (``src/core/field/batch.hpp``: poses side by side in SIMD instructions, on every core
        from ``pfield._core.field.PARALLEL_FROM`` poses). Each row is :meth:`wrench`'s value to the bit at the same
        position and unit quaternion (the batch normalises q as q · (1/‖q‖), :class:`~pfield.spatial.Pose` as
        q/‖q‖: the unit quaternions themselves may differ in a last bit)."""
        points, quats = self._batch(positions, orientations)
        return self._rows_checked(self._core.wrenches(points, quats), points, quats)

    def twists(self, positions: ArrayLike, orientations: ArrayLike | None = None) -> NDArray[np.float64]:
        """Constrained twists (N, 6) = linear, angular at N poses, without a previous twist, under the output
        contract (:mod:`pfield.safety`); orientations as :meth:`wrenches`.

        One call of the core, as :meth:`wrenches`; each row is :meth:`twist`'s value (without ``previous``) as
        :meth:`wrenches` says."""
        points, quats = self._batch(positions, orientations)
        return self._rows_checked(self._core.twists(points, quats), points, quats)

    def clearances(self, positions: ArrayLike) -> NDArray[np.float64]:
        """Signed distance (m) of each point (N, 3) to the nearest obstacle (inf without obstacles)."""
        points = np.require(as_points("positions", positions), requirements=["C", "W"])
        if not self._obstacles:
            return np.full(points.shape[0], math.inf)
        distances, _ = signed_distances(self._arrays.packed, points)
        return np.asarray(distances.min(axis=1))

    # ---------------------------------------------------------------- planning

    def plan(
        self,
        start: Pose,
        dt: float | None = None,
        goal_tolerance: float | None = None,
        max_iterations: int | None = None,
        rotation_tolerance: float | None = None,
        *,
        global_fallback: bool | None = None,
        global_time_limit: float | None = None,
        options: PlanOptions | None = None,
    ) -> PlannedPath:
        """Task-space plan from ``start`` to the goal (:func:`pfield.planning.task_space.plan_task_space`).

        The keyword arguments are shorthands for the :class:`~pfield.planning.PlanOptions` fields of the
        same names and override ``options``'s.
        """
        # planning sits above field (DESIGN §1): the one sanctioned lazy delegation upward
        from pfield.planning.task_space import plan_task_space

        return plan_task_space(self, start, dt=dt, goal_tolerance=goal_tolerance, max_iterations=max_iterations,
                               rotation_tolerance=rotation_tolerance, global_fallback=global_fallback,
                               global_time_limit=global_time_limit, options=options)

    def plan_whole_body(
        self, robot: Any, q0: ArrayLike, dt: float | None = None, goal_tolerance: float | None = None,
        max_iterations: int | None = None, rotation_tolerance: float | None = None, *,
        global_fallback: bool | None = None, global_time_limit: float | None = None,
        options: PlanOptions | None = None, goal_configuration: ArrayLike | None = None,
        whole_body_options: WholeBodyOptions | None = None,
    ) -> PlannedPath:
        """Whole-body plan of ``robot`` from joint positions ``q0`` (:mod:`pfield.planning.whole_body`).

        The keyword arguments are shorthands for the :class:`~pfield.planning.PlanOptions` fields of the
        same names and override ``options``'s; ``goal_configuration`` is a joint goal at the field's goal
        pose, which the field's steps are drawn toward and the global fallback searches to; ``whole_body_options``:
        the QP's own settings (:class:`~pfield.planning.WholeBodyOptions`, e.g. ``posture_gain=0`` for no pull
        toward the joint goal). :func:`~pfield.planning.plan_whole_body` says more.
        """
        from pfield.planning.whole_body import plan_whole_body

        return plan_whole_body(self, robot, q0, dt=dt, goal_tolerance=goal_tolerance, max_iterations=max_iterations,
                               rotation_tolerance=rotation_tolerance, options=whole_body_options,
                               global_fallback=global_fallback, global_time_limit=global_time_limit,
                               plan_options=options, goal_configuration=goal_configuration)
