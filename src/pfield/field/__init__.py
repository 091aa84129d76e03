"""The 3D potential field: attraction, rotation, repulsion, velocity dampers and limits.

``FieldConfig`` holds the parameters; ``PotentialField`` evaluates wrenches and constrained twists and
plans task-space paths. The compiled kernels live in :mod:`pfield.field._kernels`.
"""

from pfield.field.config import FieldConfig

__all__ = ["FieldConfig"]
