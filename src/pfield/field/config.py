"""Parameters of the 3D potential field and its constrained twist (:class:`FieldConfig`).

Field names equal the ROS parameter names of the ``/pfield_manager`` node, and the defaults of the
original's ROS configuration are kept where one exists (DESIGN §2). The parameters added by pfield
(attraction threshold, repulsion cap, velocity dampers, circulation, stagnation) are documented on the
fields and explained in ``docs/field.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from dataclasses import replace as _dataclass_replace
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfield._layout import Layout
from pfield._validation import finite
from pfield.errors import InvalidInput

__all__ = ["POSITIVE_FIELDS", "FieldConfig"]

POSITIVE_FIELDS: Mapping[str, str] = MappingProxyType({
    "max_linear_velocity": "a speed limit of 0 would forbid all motion",
    "max_angular_velocity": "a speed limit of 0 would forbid all rotation",
    "max_linear_acceleration": "an acceleration limit of 0 would keep the twist at its first value",
    "max_angular_acceleration": "an acceleration limit of 0 would keep the twist at its first value",
    "influence_distance": "it is the reach of the repulsion; switch repulsion off with repulsive_gain 0",
    "attractive_threshold": "a zero threshold makes the attraction conical everywhere, which chatters at "
                            "the goal; switch attraction off with attractive_gain 0",
    "rotation_tolerance": "a rotation is never exactly reached in floating point",
    "max_repulsive_force": "it is the repulsion's saturation bound (divides m/F_cap); switch repulsion off "
                           "with repulsive_gain 0",
    "stagnation_window": "a window of 0 s would report stagnation at once",
    "stagnation_progress": "every step would count as progress, so stagnation could never be reported",
})
"""Fields that must be > 0, with the reason zero makes no sense; every other field must be >= 0. The gains
(attractive, rotational, repulsive, damper, circulation) may be 0: a zero gain switches its term off
(attractive_gain 0 is the "repulsive only" field of the seed's plots)."""


@dataclass(frozen=True)
class FieldConfig:
    """Gains, limits and avoidance parameters of :class:`~pfield.field.PotentialField` (SI units).

    Every field is a ROS parameter of ``/pfield_manager`` with the same name. Gains may be 0 (the term is
    off); speed and acceleration limits, distances, tolerances and the stagnation test must be > 0. Invalid
    values (NaN, inf, negative, zero where a positive value is needed, inconsistent distances, non-numbers) raise
    :class:`~pfield.errors.InvalidInput` naming the field; the object is never half-built.
    """

    attractive_gain: float = 3.0
    """k_att (1/s): attraction F = −k_att (p − p_goal) within ``attractive_threshold``; 0 switches it off."""
    rotational_attractive_gain: float = 0.15
    """k_rot (1/s): torque τ = k_rot · log(q_goal ⊗ q⁻¹), the world-frame rotation error."""
    repulsive_gain: float = 0.3
    """η (N·m²): Khatib repulsion η (1/d − 1/Q)/d² along the outward normal, for d < Q."""
    max_linear_velocity: float = 0.05
    """v_max (m/s): soft (tanh) saturation bound of the linear twist."""
    max_angular_velocity: float = 0.4
    """ω_max (rad/s): soft (tanh) saturation bound of the angular twist."""
    max_linear_acceleration: float = 1.0
    """a_max (m/s²): the linear twist changes by at most a_max·dt between steps."""
    max_angular_acceleration: float = 0.2
    """α_max (rad/s²): the angular twist changes by at most α_max·dt between steps."""
    influence_distance: float = 0.1
    """Q (m): obstacles farther than Q exert no repulsion and no velocity damping."""
    attractive_threshold: float = 1.0
    """Γ (m): quadratic attraction within Γ of the goal, conical (constant magnitude k_att·Γ) beyond."""
    rotation_tolerance: float = 0.05
    """Rotational goal tolerance (rad) of :meth:`PotentialField.plan` when none is given."""
    max_repulsive_force: float = 10.0
    """F_cap (N): the Khatib magnitude m is saturated smoothly as m/√(1 + (m/F_cap)²); F_cap at d ≤ 0."""
    safety_distance: float = 0.01
    """d_s (m): the velocity dampers stop any approach at distance d_s (must be < ``influence_distance``)."""
    damper_gain: float = 1.0
    """ξ (−): approach speed toward an obstacle ≤ ξ·v_max·(d − d_s)/(Q − d_s) (NEO velocity damper); 0 allows
    no approach at all within Q."""
    circulation_gain: float = 1.0
    """κ (−): weight of the consistent circulation direction n × c when a damper redirects motion."""
    stagnation_window: float = 10.0
    """(s) a plan fails with "stagnation" when a window this long brings no progress toward the goal."""
    stagnation_progress: float = 0.001
    """(m, and rad for rotation) the least improvement of the goal error that counts as progress."""

    def __post_init__(self) -> None:
        for spec in fields(self):
            value = getattr(self, spec.name)
            number = finite(spec.name, value)
            if spec.name in POSITIVE_FIELDS and number <= 0.0:
                raise InvalidInput(spec.name, value, f"must be > 0 ({POSITIVE_FIELDS[spec.name]})")
            if number < 0.0:
                raise InvalidInput(spec.name, value, "must be >= 0")
            object.__setattr__(self, spec.name, number)
        if self.safety_distance >= self.influence_distance:
            raise InvalidInput(
                "safety_distance",
                self.safety_distance,
                f"must be smaller than influence_distance ({self.influence_distance})",
            )
        if self.rotation_tolerance >= math.pi:
            raise InvalidInput("rotation_tolerance", self.rotation_tolerance, "must be < pi rad")

    def replace(self, **changes: Any) -> FieldConfig:
        """A copy with ``changes`` applied (validated; unknown names raise ``InvalidInput``)."""
        known = {spec.name for spec in fields(self)}
        for name in changes:
            if name not in known:
                raise InvalidInput(name, changes[name], f"unknown FieldConfig parameter; known: {sorted(known)}")
        return _dataclass_replace(self, **changes)

    def as_dict(self) -> dict[str, float]:
        """Parameter name → value, in declaration order (what the node exposes as ROS parameters)."""
        return asdict(self)

    def packed(self) -> NDArray[np.float64]:
        """The parameters as the float64 array the compiled core reads (layout :data:`PARAMS`)."""
        return PARAMS.pack({name: getattr(self, name) for name in PARAM_NAMES})


PARAM_NAMES: tuple[str, ...] = tuple(spec.name for spec in fields(FieldConfig))
"""Field order of :meth:`FieldConfig.packed`."""
PARAMS = Layout("field parameters", [(name, ()) for name in PARAM_NAMES])
"""The packed parameter vector: one scalar slot per field, in declaration order — the memory of the core's
``FieldParams`` struct (``src/core/field/evaluate.hpp``), whose member offsets the binding exports
(``pfield._core.field.PARAM_OFFSETS``, held equal to this order by tests/field/test_forces.py)."""
