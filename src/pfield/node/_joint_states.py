"""The robot's measured joint state (``/joint_states``) and the end-effector frame of operator twists.

:class:`JointStateCache` keeps the latest ``sensor_msgs/JointState`` as joint angles in the robot model's tree
order: a message may list the joints in any order and carry joints the model does not have (a gripper's, another
arm's), which are ignored; it must name every joint of the model, with finite positions within the limits (a
measured state: up to :data:`~pfield.robot.model.MEASURED_BOUNDS_ERROR` beyond one is taken at the limit), else it is
refused whole (``InvalidInput`` naming the field) and the previous state stays. Velocities are kept when the message
has them for every joint. The age of a state is measured on the node's monotonic clock from the moment it
was received (the header stamp is the publisher's clock, which need not be this machine's).

A request that leaves ``joint_angles`` empty is answered at :meth:`JointStateCache.latest`; a state older than
``max_age`` seconds (the manager's ``joint_state_timeout`` parameter), or none at all, is an ``InvalidInput`` that
says what to do. :func:`end_effector_rotation` turns a twist given in the end-effector frame into the fixed frame:
linear and angular parts are both rotated by the end effector's orientation R = FK(q).R (the twist's reference
point stays the end-effector origin, so no lever-arm term appears): v_fixed = R v_ee, ω_fixed = R ω_ee.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield.errors import InvalidInput
from pfield.spatial import Twist, rotate_vectors

__all__ = ["JOINT_STATES_TOPIC", "JointStateCache", "MeasuredState", "rotate_twist"]

JOINT_STATES_TOPIC = "/joint_states"


@dataclass(frozen=True, eq=False)
class MeasuredState:
    """One received joint state: ``positions`` (n,) in the model's order, ``velocities`` (n,) or None, and the
    monotonic second it was received."""

    positions: NDArray[np.float64]
    velocities: NDArray[np.float64] | None
    received: float


class JointStateCache:
    """The latest joint state of ``robot`` (see the module docstring). Thread-safe."""

    def __init__(self, robot: Any) -> None:
        self.robot = robot
        self._lock = threading.Lock()
        self._state: MeasuredState | None = None
        self._index: dict[tuple[str, ...], NDArray[np.intp]] = {}
        self._refused: tuple[int, str] = (0, "")  # messages refused since the last one taken, and the last reason

    def _order(self, names: list[str]) -> NDArray[np.intp]:
        """Indices into a message's arrays of the model's joints, cached per name list (publishers repeat theirs)."""
        key = tuple(names)
        index = self._index.get(key)
        if index is None:
            where = {name: i for i, name in enumerate(names)}
            if len(where) != len(names):
                duplicate = next(n for n in names if names.count(n) > 1)
                raise InvalidInput("joint_states.name", duplicate, "a joint is named twice in one message")
            missing = [name for name in self.robot.joint_names if name not in where]
            if missing:
                raise InvalidInput("joint_states.name", names, f"lacks the joints {missing} of {self.robot.name} "
                                   f"(it must name all of {list(self.robot.joint_names)}; extra joints are ignored)")
            index = np.array([where[name] for name in self.robot.joint_names], dtype=np.intp)
            if len(self._index) < 16:  # a few publishers' layouts; anything beyond is recomputed
                self._index[key] = index
        return index

    def update(self, names: list[str], positions: list[float], velocities: list[float],
               now: float | None = None) -> MeasuredState:
        """Take one message's fields (validated first; nothing changes when refused but the count of refusals that
        :meth:`latest` reports)."""
        try:
            state = self._checked(names, positions, velocities, now)
        except InvalidInput as exc:
            with self._lock:
                self._refused = (self._refused[0] + 1, str(exc))
            raise
        with self._lock:
            self._state, self._refused = state, (0, "")
        return state

    def _checked(self, names: list[str], positions: list[float], velocities: list[float],
                 now: float | None) -> MeasuredState:
        if len(positions) != len(names):
            raise InvalidInput("joint_states.position", f"{len(positions)} values",
                               f"must have one value per name ({len(names)} names)")
        if velocities and len(velocities) != len(names):
            raise InvalidInput("joint_states.velocity", f"{len(velocities)} values",
                               f"must be empty or have one value per name ({len(names)} names)")
        index = self._order(names)
        q = self.robot.check_measured_joint_angles(np.asarray(positions, dtype=np.float64)[index],
                                                   "joint_states.position")
        qd = None
        if velocities:
            picked = np.asarray(velocities, dtype=np.float64)[index]
            qd = picked if np.isfinite(picked).all() else None  # unknown velocities: positions alone still count
        return MeasuredState(q, qd, time.monotonic() if now is None else now)

    def latest(self, max_age: float, field: str = "joint_angles", now: float | None = None) -> MeasuredState:
        """The latest state if it is at most ``max_age`` s old (0: any age), else ``InvalidInput`` on ``field``."""
        with self._lock:
            state, (refused, reason) = self._state, self._refused
        given = field != "joint_states"  # a request's field (joint_angles …) may also be filled in by the caller
        empty = "empty and " if given else ""
        # messages that arrive and are refused are not a silent driver: say so, with the last reason
        why = f"; {refused} message(s) on {JOINT_STATES_TOPIC} were refused since, the last: {reason}" if refused \
            else ""
        if state is None:
            if refused:
                raise InvalidInput(field, [], f"{empty}no joint state taken yet: {refused} message(s) on "
                                   f"{JOINT_STATES_TOPIC} were refused, the last: {reason}")
            raise InvalidInput(field, [], f"{empty}no joint state received yet: publish sensor_msgs/JointState on "
                               f"{JOINT_STATES_TOPIC} (joint_state_broadcaster does)"
                               + (f" or give {field}" if given else ""))
        age = (time.monotonic() if now is None else now) - state.received
        if max_age > 0 and age > max_age:
            raise InvalidInput(field, [], f"{empty}the last joint state on {JOINT_STATES_TOPIC} is {age:.3g} s old, "
                               f"beyond joint_state_timeout = {max_age:g} s"
                               + (why or ": is the robot driver running?")
                               + (f" (give {field}, or raise joint_state_timeout)" if given
                                  else " (or raise joint_state_timeout)"))
        return state

    @property
    def held(self) -> MeasuredState | None:
        """The latest state of any age (None before the first)."""
        return self._state


def rotate_twist(twist: Twist, orientation: Any) -> Twist:
    """``twist`` re-expressed through the rotation ``orientation`` (x, y, z, w): R v and R ω (module docstring)."""
    if not all(math.isfinite(v) for v in (*twist.linear, *twist.angular)):
        raise InvalidInput("twist", twist, "must be finite")
    return Twist(rotate_vectors(orientation, twist.linear), rotate_vectors(orientation, twist.angular))
