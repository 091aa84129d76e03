"""The robot model: a URDF loaded with pinocchio, packed into arrays for the compiled kinematics.

Pinocchio (Carpentier et al., "The Pinocchio C++ library", SII 2019) parses the URDF, locks joints and
stays the reference the compiled kinematics are tested against: the core's (``src/core/robot/kinematics``, bound
once per model, which every public method here calls).

Joint angles policy (every public entry point): a wrong count or a non-finite value raises
:class:`~pfield.errors.InvalidInput`; an angle outside the URDF limits by more than
``LIMIT_TOLERANCE`` (1e-4 rad or m, the size of a float32 rounding of a ROS message) is **rejected**
with an error naming the joint and its limits; smaller excursions are clamped onto the limit. Rejecting
is safer than clamping: a configuration outside the limits means the caller's state is wrong. A *measured* state
(:meth:`RobotModel.check_measured_joint_angles`: ``/joint_states``, the servo's input) may be up to
``MEASURED_BOUNDS_ERROR`` beyond a limit and is then taken at the limit: a robot held there reports positions past it.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from pfield._core import robot as _robot_core
from pfield._core import robot_kinematics as _core_kinematics
from pfield._validation import as_vector, positive
from pfield.errors import InvalidInput
from pfield.robot._loader import (
    LoadedRobot,
    joint_axis,
    load_urdf,
    resolve_mesh_uri,
    write_angle,
)
from pfield.robot.catalog import builtin_spec, example_robot_data_root
from pfield.robot.limits import default_accelerations, missing_velocity_limit, read_joint_limits
from pfield.robot.srdf import check_srdf_links, read_disabled_pairs, read_group_states
from pfield.spatial import Pose, pose_from_checked

if TYPE_CHECKING:
    from pfield.geometry.resources import PackagePaths, ResourceResolver
    from pfield.robot.geometry import RobotGeometry

__all__ = ["LIMIT_TOLERANCE", "MEASURED_BOUNDS_ERROR", "KinematicArrays", "RobotModel"]

_LOG = logging.getLogger(__name__)
LIMIT_TOLERANCE = 1e-4
MEASURED_BOUNDS_ERROR = 0.05
"""rad or m: how far beyond a joint's limit a measured position is still taken, clamped onto the limit
(:meth:`RobotModel.check_measured_joint_angles`; MoveIt's ``start_state_max_bounds_error``, 0.05 by default, lets its
planners start that far out the same way). A robot held at a limit reports positions past it: its controller
overshoots, its encoders round (the tests' MuJoCo Panda showed panda_joint4 0.9 mrad below its lower limit after
teleop pressed it there); refusing those states left the servo without a state exactly where the operator has to
steer back."""
_NOT_FINITE, _BEYOND_LIMITS = _core_kinematics.LimitStatus.NotFinite, _core_kinematics.LimitStatus.BeyondLimits

_BUILTIN_ALIASES: dict[str, dict[str, str]] = {"panda": {"ready": "default"}}
"""Extra names of SRDF group states of the built-in robots: the Panda SRDF's ``default`` state
(0, −π/4, 0, −3π/4, 0, π/2, π/4) is the pose MoveIt's panda_moveit_config calls ``ready``."""


class KinematicArrays(NamedTuple):
    """The packed kinematic tree and the end-effector frame, as the core's kinematics read them
    (``src/core/robot/kinematics.hpp``'s ``KinematicsView``).

    The field order is the argument order of the core's robot constructors, so ``*robot.kinematics`` passes them.
    """

    parents: NDArray[np.int64]  # (n,)
    place_rot: NDArray[np.float64]  # (n, 3, 3)
    place_pos: NDArray[np.float64]  # (n, 3)
    axes: NDArray[np.float64]  # (n, 3)
    kinds: NDArray[np.int64]  # (n,)
    support: NDArray[np.int64]  # (n, n)
    ee_joint: int
    ee_rot: NDArray[np.float64]  # (3, 3)
    ee_pos: NDArray[np.float64]  # (3,)


def _pack_kinematics(model: pin.Model, ee_frame: pin.Frame) -> KinematicArrays:
    n = model.njoints - 1
    parents = np.array([model.parents[j] - 1 for j in range(1, n + 1)], dtype=np.int64)
    place_rot = np.array([model.jointPlacements[j].rotation for j in range(1, n + 1)]).reshape(n, 3, 3)
    place_pos = np.array([model.jointPlacements[j].translation for j in range(1, n + 1)]).reshape(n, 3)
    axes_kinds = [joint_axis(model, j) for j in range(1, n + 1)]
    axes = np.array([a for a, _ in axes_kinds], dtype=np.float64).reshape(n, 3)
    kinds = np.array([k for _, k in axes_kinds], dtype=np.int64)
    support = np.zeros((n, n), dtype=np.int64)
    for k in range(n):
        j = k
        while j >= 0:
            support[k, j] = 1
            j = int(parents[j])
    return KinematicArrays(parents, np.ascontiguousarray(place_rot), np.ascontiguousarray(place_pos), axes, kinds,
                           support, int(ee_frame.parentJoint) - 1,
                           np.ascontiguousarray(ee_frame.placement.rotation, dtype=np.float64),
                           np.ascontiguousarray(ee_frame.placement.translation, dtype=np.float64))


def _joint_names(loaded: LoadedRobot) -> tuple[str, ...]:
    model = loaded.model
    return tuple(model.names[j] for j in range(1, model.njoints))


class RobotModel:
    """A kinematic robot: joint names in tree order, limits, end-effector FK and Jacobian, link geometry.

    Build with :meth:`from_urdf` or :meth:`builtin`. ``forward_kinematics(q)`` gives the end-effector pose
    in the robot's root (world) frame; ``jacobian(q)`` its 6×n world-aligned Jacobian, linear rows first
    (pinocchio's ``LOCAL_WORLD_ALIGNED``). Joint angles are in rad (revolute) or m (prismatic).
    """

    def __init__(self, loaded: LoadedRobot, end_effector: str, disabled_pairs: set[frozenset[str]] | None = None,
                 name: str | None = None, named_configurations: Mapping[str, ArrayLike] | None = None,
                 joint_limits: str | Path | None = None) -> None:
        if not isinstance(loaded, LoadedRobot):  # RobotModel("robot.urdf", ...): the constructor takes a loaded model
            raise InvalidInput("loaded", loaded, "RobotModel takes a loaded model: use RobotModel.from_urdf(path, "
                               "end_effector=LINK) or RobotModel.builtin(name)")
        model = loaded.model
        if not model.existFrame(end_effector, pin.FrameType.BODY):  # a link, as RobotDescription and the CLI ask
            links = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
            what = "a joint, not a link" if model.existFrame(end_effector) else "no such link in the URDF"
            raise InvalidInput("end_effector", end_effector, f"{what}; links: {links}")
        self._loaded = loaded
        self.name = name or loaded.robot_name
        self.end_effector = end_effector
        self.disabled_pairs = frozenset(disabled_pairs) if disabled_pairs is not None else None
        self.kinematics = _pack_kinematics(model, model.frames[model.getFrameId(end_effector, pin.FrameType.BODY)])
        n = model.njoints - 1
        self._joint_names = tuple(model.names[j] for j in range(1, n + 1))
        idx_q = [model.joints[j].idx_q for j in range(1, n + 1)]
        idx_v = [model.joints[j].idx_v for j in range(1, n + 1)]
        self._continuous = np.array([model.joints[j].nq == 2 for j in range(1, n + 1)])
        lower = np.where(self._continuous, -np.inf, model.lowerPositionLimit[idx_q])
        upper = np.where(self._continuous, np.inf, model.upperPositionLimit[idx_q])
        self._lower, self._upper = _frozen(lower), _frozen(upper)
        self._velocity = _frozen(np.asarray(model.velocityLimit)[idx_v])
        self._acceleration = _frozen(default_accelerations(self.kinematics.kinds))
        if joint_limits is not None:
            limits = read_joint_limits(joint_limits, self._joint_names, self._velocity, self.kinematics.kinds)
            self._velocity, self._acceleration = _frozen(limits.velocity), _frozen(limits.acceleration)
        missing = missing_velocity_limit(self._joint_names, self._velocity, loaded.urdf_path.name)
        if missing:  # refused where it matters (planning.whole_body.pack_robot); said now, while the robot is built
            _LOG.warning("%s; whole-body plans, steps and assistance refuse this robot until then", missing)
        self._idx_q = np.array(idx_q)
        # the core's robot (pfield._core.robot.Robot: the tree and the limits, without the link model, which is
        # fitted on first use), bound once with its kinematics: each kinematics call passes only q
        robot = _robot_core.Robot(*self.kinematics, self._lower, self._upper, self._velocity, self._acceleration)
        self._core_kinematics = _core_kinematics.Kinematics(robot, LIMIT_TOLERANCE)
        self._named = {str(key): _frozen(self.check_joint_angles(value, f"named_configurations[{key!r}]"))
                       for key, value in (named_configurations or {}).items()}
        self._skipped: dict[str, str] = {}  # group states of the SRDF not adopted, and why

    # ---- construction -------------------------------------------------------------------------------
    @classmethod
    def from_urdf(cls, path: str | Path, end_effector: str, package_paths: PackagePaths | None = None,
                  srdf: str | Path | None = None, locked_joints: dict[str, float] | None = None,
                  resolver: ResourceResolver | None = None, joint_limits: str | Path | None = None) -> RobotModel:
        """Load a URDF. ``package_paths`` maps package names to their root folders (for ``package://``): a mapping,
        ``(NAME, DIR)`` pairs or ``"NAME=DIR"`` strings, a relative ``DIR`` relative to the current directory.

        ``srdf`` (optional) supplies the disabled self-collision pairs and the named configurations (its group
        states); without it adjacent links are excluded. ``locked_joints`` maps joint names to fixed values
        (e.g. gripper fingers). ``resolver`` (optional) resolves mesh URIs instead, e.g. the node's resolver.
        ``joint_limits`` (optional): MoveIt's ``joint_limits.yaml`` for velocity and acceleration limits
        (:mod:`pfield.robot.limits`; without it: the URDF's velocities and the documented accelerations).
        """
        loaded = load_urdf(path, package_paths, locked_joints, resolver)
        disabled = read_disabled_pairs(srdf) if srdf is not None else None
        if disabled is not None:
            check_srdf_links(disabled, (frame.name for frame in loaded.model.frames), srdf,  # type: ignore[arg-type]
                             (*_joint_names(loaded), *(locked_joints or {})))
        robot = cls(loaded, end_effector, disabled, joint_limits=joint_limits)
        if srdf is not None:
            robot._adopt_group_states(read_group_states(srdf, _joint_names(loaded)), srdf)
        return robot

    def _adopt_group_states(self, states: Mapping[str, NDArray[np.float64]], source: str | Path) -> None:
        """Add an SRDF's group states as named configurations. A state outside the URDF's joint limits is
        skipped with a warning, not refused: robot packages ship such states (example-robot-data's Kinova
        ``arm_up`` puts a joint at -1.5707 rad beyond a -1.5 rad limit), and MoveIt loads those files too; a
        caller's own ``named_configurations`` stay strict."""
        for name, q in states.items():
            try:
                self._named[str(name)] = _frozen(self.check_joint_angles(q, f"group_state[{name!r}]"))
            except InvalidInput as exc:
                _LOG.warning("SRDF %s: group state %r skipped: %s", source, name, exc)
                self._skipped[str(name)] = (f"the SRDF's group state {name!r} was skipped when {self.name} loaded "
                                            f"({exc})")

    @classmethod
    def builtin(cls, name: str, locked_joints: dict[str, float] | None = None) -> RobotModel:
        """``"xarm7"`` or ``"panda"`` from the installed example-robot-data files (see :mod:`.catalog`).

        ``locked_joints`` adds joints to lock or overrides the catalog's values, e.g. the Panda's fingers
        opened to 0.065 m as MotionBenchMaker's robot allows (a locked joint's value may lie outside its URDF
        limits: it becomes part of a fixed placement).
        """
        spec = builtin_spec(name)
        root = example_robot_data_root()
        locked = {**spec.locked_joints, **(locked_joints or {})}
        loaded = load_urdf(root / spec.urdf, {"example-robot-data": root}, locked)
        key = str(name).strip().lower()
        named = read_group_states(root / spec.srdf, _joint_names(loaded))
        named |= {alias: named[state] for alias, state in _BUILTIN_ALIASES.get(key, {}).items() if state in named}
        return cls(loaded, spec.end_effector, read_disabled_pairs(root / spec.srdf), name=key,
                   named_configurations=named)

    # ---- properties -----------------------------------------------------------------------------------
    @property
    def joint_names(self) -> tuple[str, ...]:
        """Actuated joints in kinematic-tree order (parents before children)."""
        return self._joint_names

    @property
    def n_joints(self) -> int:
        return len(self._joint_names)

    @property
    def lower_limits(self) -> NDArray[np.float64]:
        """Lower position limits (rad or m); −inf for continuous joints."""
        return self._lower

    @property
    def upper_limits(self) -> NDArray[np.float64]:
        """Upper position limits (rad or m); +inf for continuous joints."""
        return self._upper

    @property
    def mid_configuration(self) -> NDArray[np.float64]:
        """The middle of every joint's range, 0 for a continuous joint (rad or m): a configuration away from
        the limits (a fresh array)."""
        finite = np.isfinite(self._lower) & np.isfinite(self._upper)
        middle = np.zeros_like(self._lower)
        middle[finite] = 0.5 * (self._lower[finite] + self._upper[finite])
        return middle

    @property
    def velocity_limits(self) -> NDArray[np.float64]:
        """Joint speed limits from the URDF (rad/s or m/s)."""
        return self._velocity

    @property
    def acceleration_limits(self) -> NDArray[np.float64]:
        """(n,) joint acceleration limits (rad/s² or m/s²) of retimed trajectories: ``joint_limits.yaml``'s, else
        :data:`~pfield.robot.limits.DEFAULT_JOINT_ACCELERATION` / ``DEFAULT_PRISMATIC_ACCELERATION``."""
        return self._acceleration

    @property
    def pinocchio_model(self) -> pin.Model:
        """The (reduced) pinocchio model; the reference for every kinematic quantity."""
        return self._loaded.model

    @property
    def collision_model(self) -> pin.GeometryModel:
        """Pinocchio's collision geometry (coal shapes) of the URDF's ``<collision>`` elements."""
        return self._loaded.collision_model

    @property
    def urdf_path(self) -> Path:
        return self._loaded.urdf_path

    @property
    def resolver(self) -> ResourceResolver:
        """The :class:`~pfield.geometry.ResourceResolver` the URDF's mesh URIs were read through: its package
        paths (absolute) and allowed roots travel with the model (the viewer and its HTML export use it)."""
        return self._loaded.resolver

    def resolve_mesh(self, uri: str) -> Path:
        """The file a mesh URI of this robot's URDF names, as the loader read it: ``package://`` through
        :attr:`resolver`, relative paths from the URDF's folder. Raises :class:`~pfield.errors.ResourceNotFound`
        / :class:`~pfield.errors.ResourceNotAllowed` as loading does."""
        return resolve_mesh_uri(uri, self._loaded.urdf_path.parent, self._loaded.resolver)

    @cached_property
    def geometry(self) -> RobotGeometry:
        """The fitted link model (spheres/capsules and bounding capsules) and self-collision pairs, fitted on
        first use (each link's fit is cached in memory and on disk, see :mod:`pfield.robot._fit`)."""
        from pfield.robot.geometry import fit_robot_geometry

        return fit_robot_geometry(self)

    def named_configurations(self) -> dict[str, NDArray[np.float64]]:
        """Name → joint angles (tree order) of the SRDF's group states that set every joint (MoveIt's named
        targets), plus built-in aliases (the Panda's ``ready`` = its SRDF's ``default``)."""
        return dict(self._named)

    @property
    def skipped_group_states(self) -> dict[str, str]:
        """The SRDF's group states that were not adopted as named configurations, each with why (outside the joint
        limits: :meth:`_adopt_group_states`)."""
        return dict(self._skipped)

    def named_configuration(self, name: str) -> NDArray[np.float64]:
        """Joint angles of the named configuration ``name`` (see :meth:`named_configurations`)."""
        if name in self._skipped:
            raise InvalidInput("name", name, self._skipped[name])
        if name not in self._named:
            known = ", ".join(sorted(self._named)) or "none (load the robot with an SRDF that has group states)"
            raise InvalidInput("name", name, f"no such named configuration of {self.name}; known: {known}")
        return self._named[name]

    def refit(self, target_gap: float | None = None, *, one_capsule: bool = False) -> RobotGeometry:
        """Replace :attr:`geometry` by a fit with stand-off bound ``target_gap`` (m), or with one capsule per
        link (``one_capsule=True``: the single covering capsule of each link, for comparisons)."""
        from pfield.robot._fit import TARGET_GAP
        from pfield.robot.geometry import fit_robot_geometry

        gap = TARGET_GAP if target_gap is None else positive("target_gap", target_gap)
        geometry = fit_robot_geometry(self, gap, one_capsule=one_capsule)
        self.__dict__["geometry"] = geometry
        return geometry

    # ---- validation -------------------------------------------------------------------------------------
    def check_joint_angles(self, q: ArrayLike, field: str = "joint_angles") -> NDArray[np.float64]:
        """Validated copy of ``q`` (see the module docstring for the limits policy)."""
        return self._checked_angles(q, field, LIMIT_TOLERANCE)

    def check_measured_joint_angles(self, q: ArrayLike, field: str = "joint_angles") -> NDArray[np.float64]:
        """Validated copy of a *measured* ``q``: as :meth:`check_joint_angles`, except that a position at most
        :data:`MEASURED_BOUNDS_ERROR` beyond a limit is taken at the limit (module docstring)."""
        return self._checked_angles(q, field, MEASURED_BOUNDS_ERROR)

    def _checked_angles(self, q: ArrayLike, field: str, tolerance: float) -> NDArray[np.float64]:
        """``q`` as a float64 copy of n finite values, each at most ``tolerance`` beyond its limits and clamped onto
        them (the core's check_limits), else ``InvalidInput`` naming the field."""
        try:
            values = np.array(q, dtype=np.float64)
        except (TypeError, ValueError):
            values = np.zeros(0)
        if values.shape != (self.n_joints,):
            as_vector(field, q, self.n_joints)  # raises the standard message (count / not numbers)
            values = np.array(values, dtype=np.float64).reshape(-1)
        status, bad = self._core_kinematics.check_limits(values, tolerance)
        if status is _NOT_FINITE:
            raise InvalidInput(field, q, "must be finite (no NaN or inf)")
        if status is _BEYOND_LIMITS:
            raise InvalidInput(f"{field}[{bad}]", float(values[bad]),
                               f"outside the limits of {self._joint_names[bad]} "
                               f"[{self._lower[bad]:.6g}, {self._upper[bad]:.6g}]")
        return values

    def pinocchio_configuration(self, q: ArrayLike) -> NDArray[np.float64]:
        """Pinocchio's configuration vector for angles ``q`` (continuous joints become (cos, sin))."""
        values = np.asarray(q, dtype=np.float64)
        config = np.zeros(self.pinocchio_model.nq)
        for i, start in enumerate(self._idx_q):
            write_angle(config, int(start), bool(self._continuous[i]), float(values[i]))
        return config

    # ---- kinematics -----------------------------------------------------------------------------------
    def joint_frames(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World rotations (n, 3, 3) and origins (n, 3) of every joint frame at validated ``q``."""
        rotations, origins = self._core_kinematics.joint_frames(self.check_joint_angles(q))
        return rotations, origins

    def forward_kinematics(self, q: ArrayLike) -> Pose:
        """End-effector pose in the world (robot root) frame at joint angles ``q``."""
        # the core checks q as check_joint_angles does (None when q breaks the rule, TypeError when it is not an
        # array the core reads as float64, e.g. a list): then check_joint_angles raises its error or converts
        try:
            parts = self._core_kinematics.forward_kinematics(q)
        except TypeError:
            parts = None
        if parts is None:
            parts = self._core_kinematics.forward_kinematics(self.check_joint_angles(q))
        return pose_from_checked(*parts)

    def jacobian(self, q: ArrayLike) -> NDArray[np.float64]:
        """6×n end-effector Jacobian, world-aligned axes, linear rows first: ``[v; ω] = J(q) q̇``."""
        jac = np.empty((6, len(self._joint_names)))
        try:  # as forward_kinematics
            done = self._core_kinematics.jacobian(q, jac)
        except TypeError:
            done = False
        if not done:
            self._core_kinematics.jacobian(self.check_joint_angles(q), jac)
        return jac

    def condition_number(self, q: ArrayLike) -> float:
        """κ = σ_max / σ_min of the end-effector Jacobian at ``q`` (``inf`` at a singularity): MoveIt Servo's measure
        of the distance to a singularity, from the eigenvalues λ of J Jᵀ (σ² = λ; a 6×6 symmetric eigenproblem in the
        core, ``robot::condition_number``)."""
        try:  # as forward_kinematics
            kappa = self._core_kinematics.condition_number(q)
        except TypeError:
            kappa = None
        if kappa is None:
            kappa = self._core_kinematics.condition_number(self.check_joint_angles(q))
        return float(kappa)

    def end_effector_positions(self, qs: ArrayLike) -> NDArray[np.float64]:
        """End-effector positions (N, 3) of N configurations (not validated: trajectory post-processing)."""
        array = np.ascontiguousarray(np.asarray(qs, dtype=np.float64).reshape(-1, self.n_joints))
        positions: NDArray[np.float64] = self._core_kinematics.end_effector_positions(array)
        return positions

    def __repr__(self) -> str:
        return f"RobotModel({self.name!r}, joints={list(self._joint_names)}, end_effector={self.end_effector!r})"


def _frozen(values: ArrayLike) -> NDArray[np.float64]:
    array = np.array(values, dtype=np.float64)
    array.setflags(write=False)
    return array
