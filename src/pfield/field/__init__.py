"""The 3D potential field: attraction, rotation, repulsion, velocity dampers and limits.

``FieldConfig`` holds the parameters; ``PotentialField`` evaluates wrenches and constrained twists and
plans task-space paths. The compiled laws live in :mod:`pfield.field.forces`, their evaluation over an
obstacle set in :mod:`pfield.field._evaluate`.
"""

from pfield.field.config import FieldConfig
from pfield.field.field import FieldArrays, PotentialField
from pfield.field.prepared import PreparedTwist

__all__ = ["FieldArrays", "FieldConfig", "PotentialField", "PreparedTwist"]
