"""Parameters of the 2D vector field (:class:`VectorFieldParams`), named as the original ROS node's.

Seed document 004 ("Vector field controller"): the potential

    V(p) = ‖p − p_a‖^ka + Σ_i (kr_height / kr_slope) · exp(kr_slope · (kr_dist − ‖p − p_ri‖))

makes the attractive point ``p_a`` a hole (shape set by ``ka``) and each repulsive point ``p_ri`` a hill
(``kr_height`` = the hill's gradient magnitude at distance ``kr_dist``, ``kr_slope`` its steepness in 1/m).
The robot follows −∇V, clamped between ``min_spd_norm`` and ``max_spd_norm`` (m/s); see
:mod:`pfield.mobile.clamping`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any, Literal

from pfield._core import mobile as _mobile
from pfield._validation import finite, nonnegative, positive
from pfield.errors import InvalidInput

__all__ = ["ATTRACTION_LAWS", "CLAMPING_MODES", "VectorFieldParams"]

ATTRACTION_LAWS = ("power", "linear")
"""``power``: V_a = ‖p − p_a‖^ka (the seed's potential). ``linear``: −∇V_a = ka·(p_a − p), i.e.
V_a = (ka/2)·‖p − p_a‖² (the original ROS node's law)."""
CLAMPING_MODES = ("hard", "tanh")
"""``hard``: the original's norm clamps (default). ``tanh``: smooth saturation with the same bounds."""

_MAX_KA = 10.0
_MAX_EXPONENT = 300.0  # kr_slope·kr_dist bound: keeps exp() of the hill's peak finite (e^300 ≈ 2e130)


@dataclass(frozen=True)
class VectorFieldParams:
    """Shape of the 2D field and the speed bounds (SI units; defaults = the seed's Gazebo parameter set).

    Attributes:
        ka: attractive exponent (``power``) or gain (``linear``), in [0, 10]; 0 switches attraction off.
        kr_dist: distance (m) at which one repulsive hill's gradient magnitude equals ``kr_height``.
        kr_height: repulsive gradient magnitude (m/s) at ``kr_dist``, ≥ 0; 0 switches repulsion off.
        kr_slope: exponential steepness of the hills (1/m), > 0.
        min_spd_norm: lower bound (m/s) of the attractive speed away from the goal, ≥ 0.
        max_spd_norm: upper bound (m/s) of every commanded speed, > 0 and ≥ ``min_spd_norm``.
        goal_tolerance: distance (m) to the goal under which the goal counts as reached, ≥ 0.
        attraction: ``"power"`` (seed, default) or ``"linear"`` (original node), see ``ATTRACTION_LAWS``.
        clamping: ``"hard"`` (original, default) or ``"tanh"``, see ``CLAMPING_MODES``.
    """

    ka: float = 3.0
    kr_dist: float = 0.8
    kr_height: float = 1.0
    kr_slope: float = 30.0
    min_spd_norm: float = 0.1
    max_spd_norm: float = 1.0
    goal_tolerance: float = 0.1
    attraction: Literal["power", "linear"] = "power"
    clamping: Literal["hard", "tanh"] = "hard"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "ka", nonnegative("ka", self.ka))
        if self.ka > _MAX_KA:
            raise InvalidInput("ka", self.ka, f"must be <= {_MAX_KA:g} (‖p − p_a‖^ka overflows far away)")
        set_(self, "kr_dist", finite("kr_dist", self.kr_dist))
        set_(self, "kr_height", nonnegative("kr_height", self.kr_height))
        set_(self, "kr_slope", positive("kr_slope", self.kr_slope))
        set_(self, "min_spd_norm", nonnegative("min_spd_norm", self.min_spd_norm))
        set_(self, "max_spd_norm", positive("max_spd_norm", self.max_spd_norm))
        set_(self, "goal_tolerance", nonnegative("goal_tolerance", self.goal_tolerance))
        if self.min_spd_norm > self.max_spd_norm:
            raise InvalidInput("min_spd_norm", self.min_spd_norm,
                               f"must be <= max_spd_norm ({self.max_spd_norm})")
        if self.kr_slope * self.kr_dist > _MAX_EXPONENT:
            raise InvalidInput("kr_dist", self.kr_dist,
                               f"kr_slope*kr_dist must be <= {_MAX_EXPONENT:g} (the hill's peak overflows)")
        if not math.isfinite(self.kr_height / self.kr_slope):
            raise InvalidInput("kr_slope", self.kr_slope, "kr_height/kr_slope must be finite")
        if self.attraction not in ATTRACTION_LAWS:
            raise InvalidInput("attraction", self.attraction, f"must be one of {ATTRACTION_LAWS}")
        if self.clamping not in CLAMPING_MODES:
            raise InvalidInput("clamping", self.clamping, f"must be one of {CLAMPING_MODES}")

    @cached_property
    def core_field(self) -> _mobile.FieldParams:
        """The field's parameters as the compiled core takes them (built once)."""
        return _mobile.FieldParams(ka=self.ka, law=_mobile.Attraction(ATTRACTION_LAWS.index(self.attraction)),
                                   kr_dist=self.kr_dist, kr_height=self.kr_height, kr_slope=self.kr_slope)

    @cached_property
    def core_limits(self) -> _mobile.SpeedLimits:
        """The clamping's speed limits as the compiled core takes them (built once)."""
        return _mobile.SpeedLimits(min_speed=self.min_spd_norm, max_speed=self.max_spd_norm,
                                   mode=_mobile.Clamping(CLAMPING_MODES.index(self.clamping)))

    def as_dict(self) -> dict[str, Any]:
        """Parameters by ROS parameter name (JSON-compatible)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The ROS parameter names, in declaration order."""
        return tuple(f.name for f in fields(cls))
