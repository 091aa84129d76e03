"""The ``/pfield_manager`` node's state: its parameters, their table, and the immutable snapshot it swaps.

:class:`ManagerState` is one frozen value (config, parameters, obstacles, goal, last path's positions,
version); the node replaces it as a whole under its lock, and anything derived from it (the potential
field, the markers) is memoised on ``version`` (:class:`Memo`).
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from pfield import _validation
from pfield.errors import InvalidInput
from pfield.field.config import POSITIVE_FIELDS as FIELD_POSITIVE
from pfield.field.config import FieldConfig
from pfield.node._frames import PARAMETER as TRANSFORMS
from pfield.node._frames import StaticTransforms, parse_transforms
from pfield.node._params import ParameterRow, ParameterTable, field_docs
from pfield.planning.options import DEFAULT_GLOBAL_TIME_LIMIT
from pfield.shared_control import ARBITRATIONS
from pfield.spatial import Pose

__all__ = ["MAX_MESH_FILE_SIZE", "MAX_OBSTACLES", "Held", "ManagerParameters", "ManagerState", "Memo",
           "manager_table"]

MAX_OBSTACLES = 5000
"""Most obstacles the manager holds. A scene from a perception pipeline has tens to hundreds; 5000 keeps
a whole-body autonomy call and a plan's per-step cost bounded. A message that would exceed it is refused
and changes nothing."""
MAX_MESH_FILE_SIZE = 50_000_000
"""bytes: default ``max_mesh_file_size`` (a detailed robot link mesh is 1–10 MB)."""

MAX_GLOBAL_TIME_LIMIT = 600.0
"""s: the largest ``global_time_limit`` the node accepts (a plan request holds a calls thread that long)."""

T = TypeVar("T")


@dataclass(frozen=True)
class ManagerParameters:
    """Node parameters that are not field parameters."""

    dynamic_obstacle_timeout: float = 2.0
    """s: a ``Dynamic`` obstacle not re-published for this long is removed (0 disables expiry)."""
    fixed_frame: str = "world"
    """The frame every pose is used in; messages in another frame need a ``static_transforms`` entry."""
    static_transforms: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    """``{frame: {translation: [x, y, z] (m), rotation: [qx, qy, qz, qw]}}``: each frame's pose in
    ``fixed_frame`` (entries may also be :class:`~pfield.spatial.Pose`; held as Poses after validation)."""
    max_mesh_file_size: int = MAX_MESH_FILE_SIZE
    """bytes: a Mesh obstacle whose resolved file is larger is refused before it is loaded."""
    global_fallback: bool = True
    """When the field alone stagnates or reaches the iteration limit, search globally and track the result."""
    global_time_limit: float = DEFAULT_GLOBAL_TIME_LIMIT
    """s: wall-clock limit of that global search."""
    assistance_arbitration: str = "linear"
    """compute_assistance's arbitration when a request leaves ``arbitration`` empty: ``linear``, ``linear_goal`` or
    ``safety_only`` (docs/assistance.md)."""
    joint_state_timeout: float = 1.0
    """s: a request without joint angles uses the latest ``/joint_states`` only when it is at most this old (0: any
    age); older or none is refused, saying so."""
    trajectory_controller_action: str = "/joint_trajectory_controller/follow_joint_trajectory"
    """The FollowJointTrajectory action ``/pfield/execute_trajectory`` sends to when a request names none (a
    ros2_control joint_trajectory_controller serves ``/<controller name>/follow_joint_trajectory``)."""

    def __post_init__(self) -> None:
        timeout = self.dynamic_obstacle_timeout
        if isinstance(timeout, bool) or not isinstance(timeout, int | float) or not math.isfinite(timeout) \
                or timeout < 0:
            raise InvalidInput("dynamic_obstacle_timeout", timeout, "must be a finite number of seconds >= 0")
        if not isinstance(self.fixed_frame, str) or not self.fixed_frame:
            raise InvalidInput("fixed_frame", self.fixed_frame, "must be a non-empty frame name")
        _validation.text("fixed_frame", self.fixed_frame)
        size = self.max_mesh_file_size
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise InvalidInput("max_mesh_file_size", size, "must be a positive number of bytes")
        object.__setattr__(self, "dynamic_obstacle_timeout", float(timeout))
        object.__setattr__(self, "global_fallback", _validation.boolean("global_fallback", self.global_fallback))
        object.__setattr__(self, "global_time_limit", _validation.positive("global_time_limit",
                                                                            self.global_time_limit))
        object.__setattr__(self, "static_transforms", parse_transforms(self.static_transforms, self.fixed_frame))
        object.__setattr__(self, "joint_state_timeout", _validation.nonnegative("joint_state_timeout",
                                                                                self.joint_state_timeout))
        if not self.trajectory_controller_action.strip("/"):
            raise InvalidInput("trajectory_controller_action", self.trajectory_controller_action,
                               "must name an action, e.g. /joint_trajectory_controller/follow_joint_trajectory")
        _validation.text("trajectory_controller_action", self.trajectory_controller_action)
        if self.assistance_arbitration not in ARBITRATIONS:
            raise InvalidInput("assistance_arbitration", self.assistance_arbitration,
                               f"must be one of {list(ARBITRATIONS)}")

    def frames(self) -> StaticTransforms:
        return StaticTransforms(self.fixed_frame, self.static_transforms)


# Upper bounds a real manipulator never needs to exceed (SI units); FieldConfig adds > 0 and cross-field rules.
_FIELD_RANGES: dict[str, tuple[float, float, str]] = {
    "attractive_gain": (0.0, 100.0, "1/s"),
    "rotational_attractive_gain": (0.0, 100.0, "1/s"),
    "repulsive_gain": (0.0, 1000.0, "N·m²"),
    "max_linear_velocity": (0.0, 10.0, "m/s"),
    "max_angular_velocity": (0.0, 10.0 * math.pi, "rad/s"),
    "max_linear_acceleration": (0.0, 100.0, "m/s²"),
    "max_angular_acceleration": (0.0, 100.0, "rad/s²"),
    "influence_distance": (0.0, 10.0, "m"),
    "attractive_threshold": (0.0, 100.0, "m"),
    "rotation_tolerance": (0.0, math.pi, "rad"),
    "max_repulsive_force": (0.0, 1.0e4, "N"),
    "safety_distance": (0.0, 10.0, "m"),
    "damper_gain": (0.0, 100.0, ""),
    "circulation_gain": (0.0, 100.0, ""),
    "stagnation_window": (0.0, 3600.0, "s"),
    "stagnation_progress": (0.0, 1.0, "m"),
}


def manager_table(name: str) -> ParameterTable:
    """The parameter table of ``/pfield_manager``: the :class:`FieldConfig` fields, then its own."""
    defaults, docs = FieldConfig(), field_docs(FieldConfig)
    rows = [ParameterRow(f.name, "double", docs[f.name], getattr(defaults, f.name), *_FIELD_RANGES[f.name],
                         positive=f.name in FIELD_POSITIVE) for f in dataclasses.fields(FieldConfig)]
    own, own_docs = ManagerParameters(), field_docs(ManagerParameters)
    rows += [ParameterRow("dynamic_obstacle_timeout", "double", own_docs["dynamic_obstacle_timeout"],
                          own.dynamic_obstacle_timeout, 0.0, 3600.0, "s"),
             ParameterRow("fixed_frame", "string", own_docs["fixed_frame"], own.fixed_frame),
             ParameterRow(TRANSFORMS, "map", own_docs["static_transforms"], {}),
             ParameterRow("max_mesh_file_size", "integer", own_docs["max_mesh_file_size"], own.max_mesh_file_size,
                          1, 2**31 - 1, "bytes", positive=True),
             ParameterRow("global_fallback", "bool", own_docs["global_fallback"], own.global_fallback),
             ParameterRow("global_time_limit", "double", own_docs["global_time_limit"], own.global_time_limit,
                          0.0, MAX_GLOBAL_TIME_LIMIT, "s", positive=True),
             ParameterRow("assistance_arbitration", "string", own_docs["assistance_arbitration"],
                          own.assistance_arbitration, choices=ARBITRATIONS),
             ParameterRow("joint_state_timeout", "double", own_docs["joint_state_timeout"], own.joint_state_timeout,
                          0.0, 3600.0, "s"),
             ParameterRow("trajectory_controller_action", "string", own_docs["trajectory_controller_action"],
                          own.trajectory_controller_action)]
    return ParameterTable(name, rows)


@dataclass(frozen=True)
class Held:
    """An obstacle with the monotonic time (s) of its last update and its world velocity (m/s).

    ``velocity`` is estimated from successive poses of a ``Dynamic`` obstacle, or ``explicit`` (given on
    ``/pfield/obstacle_velocities``); static obstacles keep (0, 0, 0).
    """

    obstacle: Any
    updated: float
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    explicit: bool = False


@dataclass(frozen=True, eq=False)
class ManagerState:
    """Everything the manager holds, as one immutable value; ``version`` grows with every change."""

    config: FieldConfig
    params: ManagerParameters
    obstacles: Mapping[str, Held] = dataclasses.field(default_factory=lambda: MappingProxyType({}))
    goal: Pose | None = None
    path_positions: NDArray[np.float64] | None = None
    version: int = 0

    def evolve(self, **changes: Any) -> ManagerState:
        """The next state: ``changes`` applied (an ``obstacles`` dict is frozen), ``version`` + 1."""
        if "obstacles" in changes:
            changes["obstacles"] = MappingProxyType(dict(changes["obstacles"]))
        return dataclasses.replace(self, **changes, version=self.version + 1)

    def obstacle_list(self) -> list[Any]:
        return [held.obstacle for held in self.obstacles.values()]


class Memo(Generic[T]):
    """A value derived from a :class:`ManagerState`, computed once per state ``version``; with ``depends``
    (the state's fields it reads), once per identity of those fields, so the field survives a change of the
    path alone."""

    def __init__(self, build: Callable[[ManagerState], T], depends: tuple[str, ...] = ()) -> None:
        self._build = build
        self._depends = depends
        self._lock = threading.Lock()
        self._key: tuple[Any, ...] | None = None
        self._version = -1
        self._value: T | None = None

    def _key_of(self, state: ManagerState) -> tuple[Any, ...]:
        return tuple(getattr(state, name) for name in self._depends) if self._depends else (state.version,)

    def _hit(self, key: tuple[Any, ...]) -> bool:
        """Same objects (``is``, not ``==``: the key holds them, so an identity is never reused meanwhile)."""
        return self._key is not None and len(key) == len(self._key) and all(
            a is b or (isinstance(a, int) and a == b) for a, b in zip(key, self._key, strict=True))

    def ready(self, state: ManagerState) -> bool:
        """True when :meth:`get` would return at once (the value for ``state`` is built)."""
        key = self._key_of(state)
        with self._lock:
            return self._hit(key)

    def get(self, state: ManagerState) -> T:
        key = self._key_of(state)
        with self._lock:
            if self._hit(key):
                return self._value  # type: ignore[return-value]
        value = self._build(state)  # built outside the lock: a slow build never blocks other readers
        with self._lock:
            if state.version >= self._version:
                self._key, self._version, self._value = key, state.version, value
        return value
