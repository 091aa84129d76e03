"""Obstacle geometry: shapes, obstacles and exact signed distances (see ``docs/geometry.md``).

Compiled consumers use :mod:`pfield.geometry._sdf` (``obstacle_signed_distance``,
``min_signed_distance``, ``signed_distances``) on a :class:`PackedObstacles`.
"""

from pfield.geometry._packed import PackedObstacles
from pfield.geometry._sdf import empty_packed, min_signed_distance, obstacle_signed_distance, signed_distances

__all__ = [
    "PackedObstacles",
    "empty_packed",
    "min_signed_distance",
    "obstacle_signed_distance",
    "signed_distances",
]
