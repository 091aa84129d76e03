"""Spatial value types (:class:`Pose`, :class:`Twist`, :class:`Wrench`) and vectorised SO(3) helpers.

Conventions (DESIGN §2): SI units, quaternions in ROS order ``(x, y, z, w)`` and normalised on input.
A :class:`Pose` maps points from its local frame to the parent (world) frame:
``p_world = R(q) p_local + position``. The vectorised functions accept one element (shape ``(4,)`` or
``(3,)``) or a batch (``(N, 4)``, ``(N, 3)``) and return the same rank. Math: Sola, Deray & Atchuthan,
"A micro Lie theory for state estimation in robotics" (2018).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfield._core import spatial as _core
from pfield._validation import as_vector
from pfield.errors import InvalidInput

__all__ = [
    "Points",
    "Pose",
    "Quat",
    "Twist",
    "Vec3",
    "Wrench",
    "euler_zyx_from_quaternion",
    "geodesic_angle",
    "matrix_from_quaternion",
    "normalize_quaternion",
    "pose_from_checked",
    "quaternion_exp",
    "quaternion_from_euler_zyx",
    "quaternion_from_matrix",
    "quaternion_inverse",
    "quaternion_log",
    "quaternion_multiply",
    "readonly_parts",
    "rotate_vectors",
    "twist_from_checked",
    "wrench_from_checked",
]

Vec3: TypeAlias = NDArray[np.float64]  # (3,)
Quat: TypeAlias = NDArray[np.float64]  # (4,) x, y, z, w
Points: TypeAlias = NDArray[np.float64]  # (N, 3)

_IDENTITY_QUAT = (0.0, 0.0, 0.0, 1.0)
MIN_QUATERNION_NORM = 1e-9
"""Smallest quaternion norm taken as a rotation (below it: refused as a zero quaternion), everywhere in pfield."""


def _batched(value: ArrayLike, width: int) -> tuple[NDArray[np.float64], bool]:
    array = np.ascontiguousarray(value, dtype=np.float64)
    single = array.ndim == 1
    return _kernel_input(array.reshape(-1, width)), single


def _kernel_input(array: NDArray[np.float64]) -> NDArray[np.float64]:
    """A C-contiguous float64 array (copied only when needed), as the compiled core reads it in place."""
    return np.require(array, dtype=np.float64, requirements=["C"])


def _unbatch(array: NDArray[np.float64], single: bool) -> NDArray[np.float64]:
    return array[0] if single else array


def normalize_quaternion(q: ArrayLike, field_name: str = "orientation") -> Quat:
    """Unit quaternion from ``q`` (x, y, z, w); rejects non-finite and (near) zero quaternions."""
    quat = np.array(as_vector(field_name, q, 4))
    # the norm check in scalars (pfield._validation.scaled_norm's formula: scale by the largest magnitude first)
    x, y, z, w = quat.tolist()
    largest = max(abs(x), abs(y), abs(z), abs(w))
    if largest == 0.0 or largest * math.sqrt((x / largest) ** 2 + (y / largest) ** 2 + (z / largest) ** 2
                                             + (w / largest) ** 2) < MIN_QUATERNION_NORM:
        raise InvalidInput(field_name, q, "zero quaternion: give a unit quaternion, e.g. {w: 1.0}")
    if largest > 1e150:  # components whose squares would overflow: scale them first
        quat /= largest
    norm = float(np.linalg.norm(quat))
    quat /= norm
    quat.setflags(write=False)
    return quat


def quaternion_multiply(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Hamilton product ``a ⊗ b`` (rotation ``b`` then ``a``), broadcast over batches."""
    qa, single_a = _batched(a, 4)
    qb, single_b = _batched(b, 4)
    qa, qb = np.broadcast_arrays(qa, qb)
    return _unbatch(_core.multiply(_kernel_input(qa), _kernel_input(qb)), single_a and single_b)


def quaternion_inverse(q: ArrayLike) -> NDArray[np.float64]:
    """Inverse of unit quaternions (the conjugate)."""
    quat = np.array(q, dtype=np.float64)
    quat[..., :3] *= -1.0
    return quat


def rotate_vectors(q: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Rotate vectors ``v`` by unit quaternions ``q`` (broadcast over batches)."""
    quat, single_q = _batched(q, 4)
    vec, single_v = _batched(v, 3)
    quat, _ = np.broadcast_arrays(quat, np.empty((vec.shape[0], 4)))
    vec, _ = np.broadcast_arrays(vec, np.empty((quat.shape[0], 3)))
    out = _core.rotate(_kernel_input(quat), _kernel_input(vec))
    return _unbatch(out, single_q and single_v)


def quaternion_exp(rotvec: ArrayLike) -> NDArray[np.float64]:
    """Exponential map: rotation vector(s) (axis·angle, rad) to unit quaternion(s)."""
    vec, single = _batched(rotvec, 3)
    return _unbatch(_core.exp(vec), single)


def quaternion_log(q: ArrayLike) -> NDArray[np.float64]:
    """Logarithm map: unit quaternion(s) to rotation vector(s) with angle in [0, π] (short arc)."""
    quat, single = _batched(q, 4)
    return _unbatch(_core.log(quat), single)


def geodesic_angle(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64] | float:
    """Angle (rad, in [0, π]) of the rotation taking ``a`` to ``b``: 2·acos(|⟨a, b⟩|)."""
    qa, single_a = _batched(a, 4)
    qb, single_b = _batched(b, 4)
    qa, qb = np.broadcast_arrays(qa, qb)
    out = _core.angle(_kernel_input(qa), _kernel_input(qb))
    return float(out[0]) if single_a and single_b else out


def matrix_from_quaternion(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix (3×3, or N×3×3) of unit quaternion(s)."""
    quat, single = _batched(q, 4)
    return _unbatch(_core.to_matrix(quat), single)


def quaternion_from_matrix(r: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion(s) (w ≥ 0) of rotation matrix (matrices), Shepperd's method."""
    mat = np.ascontiguousarray(r, dtype=np.float64)
    single = mat.ndim == 2
    out = _core.from_matrix(_kernel_input(mat.reshape(-1, 3, 3)))
    return _unbatch(out, single)


def quaternion_from_euler_zyx(yaw: ArrayLike, pitch: ArrayLike, roll: ArrayLike) -> NDArray[np.float64]:
    """Quaternion of intrinsic Z-Y-X Euler angles (yaw about z, then pitch about y', roll about x'').

    q = q_z(yaw) ⊗ q_y(pitch) ⊗ q_x(roll), the ROS ``tf2`` RPY convention.
    """
    cy, sy = np.cos(np.asarray(yaw) * 0.5), np.sin(np.asarray(yaw) * 0.5)
    cp, sp = np.cos(np.asarray(pitch) * 0.5), np.sin(np.asarray(pitch) * 0.5)
    cr, sr = np.cos(np.asarray(roll) * 0.5), np.sin(np.asarray(roll) * 0.5)
    return np.stack(
        [
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ],
        axis=-1,
    )


def euler_zyx_from_quaternion(q: ArrayLike) -> NDArray[np.float64]:
    """(yaw, pitch, roll) of unit quaternion(s); pitch in [−π/2, π/2] (gimbal lock gives roll = 0 form)."""
    quat = np.asarray(q, dtype=np.float64)
    x, y, z, w = quat[..., 0], quat[..., 1], quat[..., 2], quat[..., 3]
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    pitch = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    return np.stack([yaw, pitch, roll], axis=-1)


def _frozen_vector(field_name: str, value: Any, length: int) -> NDArray[np.float64]:
    return as_vector(field_name, value, length)


@dataclass(frozen=True, eq=False, init=False, slots=True)
class Pose:
    """A rigid transform: ``position`` (m) and unit ``orientation`` quaternion (x, y, z, w).

    ``Pose(position=(0.4, 0, 0.1))`` has the identity orientation. Orientation is normalised on input;
    a zero or non-finite quaternion raises :class:`~pfield.errors.InvalidInput`.
    """

    position: Vec3
    orientation: Quat

    def __init__(self, position: ArrayLike = (0.0, 0.0, 0.0), orientation: ArrayLike = _IDENTITY_QUAT) -> None:
        object.__setattr__(self, "position", _frozen_vector("position", position, 3))
        object.__setattr__(self, "orientation", normalize_quaternion(orientation))

    @classmethod
    def identity(cls) -> Pose:
        return cls()

    @classmethod
    def from_matrix(cls, matrix: ArrayLike) -> Pose:
        """Pose of a 4×4 homogeneous transform."""
        mat = np.asarray(matrix, dtype=np.float64)
        if mat.shape != (4, 4):
            raise InvalidInput("matrix", f"array{mat.shape}", "expected a 4x4 homogeneous transform")
        return cls(mat[:3, 3], quaternion_from_matrix(mat[:3, :3]))

    @property
    def rotation(self) -> NDArray[np.float64]:
        """3×3 rotation matrix (local to parent)."""
        return matrix_from_quaternion(self.orientation)

    def matrix(self) -> NDArray[np.float64]:
        """4×4 homogeneous transform (local to parent)."""
        mat = np.eye(4)
        mat[:3, :3] = self.rotation
        mat[:3, 3] = self.position
        return mat

    def inverse(self) -> Pose:
        q_inv = quaternion_inverse(self.orientation)
        return Pose(-rotate_vectors(q_inv, self.position), q_inv)

    def __mul__(self, other: Pose) -> Pose:
        """Composition ``self ∘ other``: first ``other``, then ``self`` (T_a_c = T_a_b * T_b_c)."""
        return Pose(
            self.position + rotate_vectors(self.orientation, other.position),
            quaternion_multiply(self.orientation, other.orientation),
        )

    def transform_points(self, points: ArrayLike) -> NDArray[np.float64]:
        """Map points (3,) or (N, 3) from the local frame to the parent frame."""
        return rotate_vectors(self.orientation, points) + self.position

    def translation_distance(self, other: Pose) -> float:
        """Euclidean distance (m) between the positions; ``inf`` where it exceeds the largest float (absurd but
        finite positions: no overflow warning, math.dist scales its sum)."""
        return math.dist(self.position.tolist(), other.position.tolist())

    def rotation_distance(self, other: Pose) -> float:
        """Geodesic angle (rad) between the two orientations."""
        return float(geodesic_angle(self.orientation, other.orientation))

    @property
    def yaw(self) -> float:
        """Heading about +z (rad), for planar use."""
        return float(euler_zyx_from_quaternion(self.orientation)[0])

    @classmethod
    def planar(cls, x: float, y: float, yaw: float) -> Pose:
        """A pose in the z = 0 plane with heading ``yaw`` about +z."""
        return cls((x, y, 0.0), (0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw)))

    def isclose(self, other: Pose, atol: float = 1e-9) -> bool:
        """Same position within ``atol`` and same rotation (q and −q alike) within ``atol`` rad."""
        return bool(
            np.allclose(self.position, other.position, atol=atol, rtol=0.0)
            and self.rotation_distance(other) <= max(atol, 1e-7)
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Pose):
            return NotImplemented
        return bool(
            np.array_equal(self.position, other.position) and np.array_equal(self.orientation, other.orientation)
        )

    def __hash__(self) -> int:
        return hash((self.position.tobytes(), self.orientation.tobytes()))

    def __repr__(self) -> str:
        p, q = self.position, self.orientation
        return (
            f"Pose(position=({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}), "
            f"orientation=({q[0]:.6g}, {q[1]:.6g}, {q[2]:.6g}, {q[3]:.6g}))"
        )


@dataclass(frozen=True, eq=False, init=False, slots=True)
class Twist:
    """Spatial velocity: ``linear`` (m/s) and ``angular`` (rad/s), both in the world frame."""

    linear: Vec3
    angular: Vec3

    def __init__(self, linear: ArrayLike = (0.0, 0.0, 0.0), angular: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        object.__setattr__(self, "linear", _frozen_vector("linear", linear, 3))
        object.__setattr__(self, "angular", _frozen_vector("angular", angular, 3))

    def as_array(self) -> NDArray[np.float64]:
        """(6,) array, linear first."""
        return np.concatenate([self.linear, self.angular])

    @classmethod
    def from_array(cls, values: ArrayLike) -> Twist:
        array = as_vector("twist", values, 6)
        return cls(array[:3], array[3:])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Twist):
            return NotImplemented
        return bool(np.array_equal(self.linear, other.linear) and np.array_equal(self.angular, other.angular))

    def __hash__(self) -> int:
        return hash((self.linear.tobytes(), self.angular.tobytes()))


@dataclass(frozen=True, eq=False, init=False, slots=True)
class Wrench:
    """Generalised force: ``force`` (N) and ``torque`` (N·m), both in the world frame."""

    force: Vec3
    torque: Vec3

    def __init__(self, force: ArrayLike = (0.0, 0.0, 0.0), torque: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        object.__setattr__(self, "force", _frozen_vector("force", force, 3))
        object.__setattr__(self, "torque", _frozen_vector("torque", torque, 3))

    def as_array(self) -> NDArray[np.float64]:
        """(6,) array, force first."""
        return np.concatenate([self.force, self.torque])

    @classmethod
    def from_array(cls, values: ArrayLike) -> Wrench:
        array = as_vector("wrench", values, 6)
        return cls(array[:3], array[3:])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Wrench):
            return NotImplemented
        return bool(np.array_equal(self.force, other.force) and np.array_equal(self.torque, other.torque))

    def __hash__(self) -> int:
        return hash((self.force.tobytes(), self.torque.tobytes()))


# Value types of values a caller has already checked: a control loop's kernel outputs (the core answers in new
# read-only arrays) and validated messages become Poses, Twists and Wrenches without their checks run twice. The
# core's hot bindings (PotentialField.twist) read these slotted classes' arrays and answer in new instances
# themselves, as these functions build them (src/core/python/values.hpp).
_core.register_value_types(Pose, Twist, Wrench)


def pose_from_checked(position: NDArray[np.float64], orientation: NDArray[np.float64]) -> Pose:
    """The :class:`Pose` of a finite (3,) position and a unit quaternion (4,) that a caller has checked: float64,
    read-only and held by nothing else (a kernel's answer); adopted as they are, without copies or checks."""
    pose: Pose = _core.adopt_pose(position, orientation)
    return pose


def twist_from_checked(linear: NDArray[np.float64], angular: NDArray[np.float64]) -> Twist:
    """The :class:`Twist` of two finite (3,) parts a caller has checked, as :func:`pose_from_checked` takes them."""
    twist: Twist = _core.adopt_twist(linear, angular)
    return twist


def wrench_from_checked(force: NDArray[np.float64], torque: NDArray[np.float64]) -> Wrench:
    """The :class:`Wrench` of two finite (3,) parts a caller has checked, as :func:`pose_from_checked` takes them."""
    wrench: Wrench = _core.adopt_wrench(force, torque)
    return wrench


def readonly_parts(values: NDArray[np.float64], split: int = 3) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``values[:split]`` and ``values[split:]`` as read-only views (``values`` becomes read-only): the parts of a
    fresh array that nothing else holds, for the constructors above."""
    values.setflags(write=False)
    return values[:split], values[split:]
