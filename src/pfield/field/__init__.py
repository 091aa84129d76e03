"""The 3D potential field: attraction, rotation, repulsion, velocity dampers and limits.

``FieldConfig`` holds the parameters; ``PotentialField`` evaluates wrenches and constrained twists and
plans task-space paths. The evaluation over an obstacle set and the planning loop run in the compiled core
(``src/core/field``, ``src/core/planning``); :mod:`pfield.field.forces` evaluates the core's laws one call at a
time.
"""

from pfield.field.config import FieldConfig
from pfield.field.field import FieldArrays, PotentialField
from pfield.field.prepared import PreparedTwist

__all__ = ["FieldArrays", "FieldConfig", "PotentialField", "PreparedTwist"]
