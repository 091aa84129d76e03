"""The primitive obstacle shapes, as frozen value types with the seed's parameter names (DESIGN §2).

All sizes are in metres, in the obstacle's local frame (centred at the obstacle pose):

* :class:`Sphere` ``radius``;
* :class:`Box` ``length`` (x), ``width`` (y), ``height`` (z), **full** extents;
* :class:`Cylinder` ``radius`` and ``height`` (full extent along local z);
* :class:`Ellipsoid` ``semi_x``, ``semi_y``, ``semi_z`` semi-axes;
* :class:`Capsule` ``radius`` and ``height`` = length of the straight shaft along local z; the two
  hemispherical caps add ``radius`` at each end (total length ``height + 2·radius``).

Every size must be finite and > 0; anything else raises :class:`~pfield.errors.InvalidInput` naming the
field. The triangle-mesh shape is :class:`pfield.geometry.mesh.Mesh`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import ClassVar

from pfield._validation import positive

__all__ = ["Box", "Capsule", "Cylinder", "Ellipsoid", "Sphere"]


class _Primitive:
    """Validation shared by the primitives: every dataclass field is a positive finite size."""

    type_name: ClassVar[str]

    def __post_init__(self) -> None:
        for item in fields(self):  # type: ignore[arg-type]
            object.__setattr__(self, item.name, positive(item.name, getattr(self, item.name)))

    def packed_sizes(self) -> tuple[float, float, float]:
        """The sizes as stored in a packed row (see :mod:`pfield.geometry.packed`)."""
        raise NotImplementedError

    def bounding_radius(self) -> float:
        """Radius (m) of the smallest sphere about the local origin that contains the shape."""
        raise NotImplementedError


@dataclass(frozen=True)
class Sphere(_Primitive):
    """Ball of ``radius`` (m) about the obstacle position."""

    radius: float
    type_name: ClassVar[str] = "Sphere"

    def packed_sizes(self) -> tuple[float, float, float]:
        return (self.radius, 0.0, 0.0)

    def bounding_radius(self) -> float:
        return self.radius


@dataclass(frozen=True)
class Box(_Primitive):
    """Axis-aligned (in the local frame) box of full extents ``length`` × ``width`` × ``height`` (m)."""

    length: float
    width: float
    height: float
    type_name: ClassVar[str] = "Box"

    def packed_sizes(self) -> tuple[float, float, float]:
        return (0.5 * self.length, 0.5 * self.width, 0.5 * self.height)

    def bounding_radius(self) -> float:
        return 0.5 * float((self.length**2 + self.width**2 + self.height**2) ** 0.5)


@dataclass(frozen=True)
class Cylinder(_Primitive):
    """Solid cylinder of ``radius`` (m) and full ``height`` (m) along local z."""

    radius: float
    height: float
    type_name: ClassVar[str] = "Cylinder"

    def packed_sizes(self) -> tuple[float, float, float]:
        return (self.radius, 0.5 * self.height, 0.0)

    def bounding_radius(self) -> float:
        return float((self.radius**2 + (0.5 * self.height) ** 2) ** 0.5)


@dataclass(frozen=True)
class Ellipsoid(_Primitive):
    """Solid ellipsoid (x/semi_x)² + (y/semi_y)² + (z/semi_z)² ≤ 1, semi-axes in m."""

    semi_x: float
    semi_y: float
    semi_z: float
    type_name: ClassVar[str] = "Ellipsoid"

    def packed_sizes(self) -> tuple[float, float, float]:
        return (self.semi_x, self.semi_y, self.semi_z)

    def bounding_radius(self) -> float:
        return max(self.semi_x, self.semi_y, self.semi_z)


@dataclass(frozen=True)
class Capsule(_Primitive):
    """Points within ``radius`` (m) of the segment z ∈ [−height/2, height/2] on local z (shaft ``height``)."""

    radius: float
    height: float
    type_name: ClassVar[str] = "Capsule"

    def packed_sizes(self) -> tuple[float, float, float]:
        return (self.radius, 0.5 * self.height, 0.0)

    def bounding_radius(self) -> float:
        return self.radius + 0.5 * self.height
