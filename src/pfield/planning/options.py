"""One options object for every planner: :class:`PlanOptions` (validated once, frozen).

``plan_task_space``, ``plan_whole_body`` and :meth:`PotentialField.plan` / ``plan_whole_body`` take it as
``options=``; their keyword arguments (``dt``, ``goal_tolerance`` …) are a convenience that builds one.
The field's own parameters (gains, limits, dampers) stay in :class:`~pfield.field.FieldConfig`; the
settings here say how long and how finely to plan, and when to give up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

from pfield._validation import boolean, integer, positive
from pfield.errors import InvalidInput
from pfield.planning.cancel import CancelToken

__all__ = ["DEFAULT_GLOBAL_TIME_LIMIT", "DEFAULT_MAX_ITERATIONS", "MAX_ITERATIONS_LIMIT", "MIN_STAGNATION_STEPS",
           "SEED_LIMIT", "PlanOptions"]

DEFAULT_MAX_ITERATIONS = 30000
"""Used when ``max_iterations`` is 0, negative or missing (the PlanPath service's "0 or missing")."""
MAX_ITERATIONS_LIMIT = 2_000_000
"""The library's upper bound of ``max_iterations``, for every planner: a plan keeps every waypoint, and
at this bound the buffers take ~0.25 GB (task space, 112 B per step) or ~0.5 GB (a 7-joint whole-body
plan). Services may cap lower as their own policy (the node's ``MAX_ITERATIONS_CAP``)."""
DEFAULT_GLOBAL_TIME_LIMIT = 2.0
"""Default wall-clock limit (s) of one global fallback search."""
SEED_LIMIT = 2**32
"""``global_seed`` is below this (the search adds its own offsets to it for restarts and racing seeds)."""
_FROM_CONFIG = ("rotation_tolerance", "stagnation_window", "stagnation_progress")
MIN_STAGNATION_STEPS = 10
"""The stagnation window is never shorter than this many steps, whatever ``stagnation_window / dt``."""


@dataclass(frozen=True)
class PlanOptions:
    """How a planner integrates and when it stops (SI units).

    Attributes:
        dt: integration step (s), > 0; waypoint i is at time i·dt.
        goal_tolerance: position tolerance (m), > 0.
        rotation_tolerance: orientation tolerance (rad) in (0, π); None uses ``FieldConfig.rotation_tolerance``.
        max_iterations: step limit; 0 or negative means :data:`DEFAULT_MAX_ITERATIONS` (30000), at most
            :data:`MAX_ITERATIONS_LIMIT`; booleans and non-integers are refused.
        stagnation_window: (s) > 0; None uses ``FieldConfig.stagnation_window``.
        stagnation_progress: (m, and rad for rotation) > 0; None uses ``FieldConfig.stagnation_progress``.
        cancel: a :class:`CancelToken` the compiled loop polls every step; when it is cancelled the plan
            ends with :attr:`PlanStatus.CANCELLED` and the waypoints so far.
        global_fallback: when the field alone ends in stagnation or at the iteration limit (whole body:
            also squeezed into a collision it stopped before), search a path globally and let the field
            track it (:mod:`pfield.planning.fallback`); :attr:`PlannedPath.planner` says which produced the
            path. A bool (1, 0 and strings are refused).
        global_time_limit: wall-clock limit (s, > 0, finite) of that search; running out of it ends the
            plan with :attr:`PlanStatus.GLOBAL_TIME_LIMIT`.
        global_seed: seed of that search's random samples (an integer in [0, 2³²)): the same seed gives the same
            path; another seed another path, as another run of a randomised planner would (a retry after a
            failure, or a benchmark that measures a planner's times over several seeds, not one).

    Stagnation (one rule for every planner, ``src/core/planning/status.hpp``'s ``Progress``): every
    ``stagnation_steps`` steps the best position error and the best rotation error so far are compared
    with their values one window earlier; when neither improved by ``stagnation_progress``, the plan ends
    with :attr:`PlanStatus.STAGNATION`. The global fallback's tracking reads the same two values: it ends with
    ``STAGNATION`` when, for ``stagnation_steps`` steps, neither its target moved along the searched path nor the
    arm by ``stagnation_progress`` (rad or m, the largest joint change): held still short of the target
    (``src/core/planning/track.hpp``).
    """

    dt: float = 0.01
    goal_tolerance: float = 0.01
    rotation_tolerance: float | None = None
    max_iterations: int = DEFAULT_MAX_ITERATIONS
    stagnation_window: float | None = None
    stagnation_progress: float | None = None
    cancel: CancelToken | None = None
    global_fallback: bool = True
    global_time_limit: float = DEFAULT_GLOBAL_TIME_LIMIT
    global_seed: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "dt", positive("dt", self.dt))
        object.__setattr__(self, "goal_tolerance", positive("goal_tolerance", self.goal_tolerance))
        if self.rotation_tolerance is not None:
            angle = positive("rotation_tolerance", self.rotation_tolerance)
            if angle >= math.pi:
                raise InvalidInput("rotation_tolerance", self.rotation_tolerance, "must be < pi rad")
            object.__setattr__(self, "rotation_tolerance", angle)
        count = integer("max_iterations", self.max_iterations)
        if count > MAX_ITERATIONS_LIMIT:
            raise InvalidInput("max_iterations", self.max_iterations,
                               f"must be <= {MAX_ITERATIONS_LIMIT} (0 or negative means {DEFAULT_MAX_ITERATIONS})")
        object.__setattr__(self, "max_iterations", count if count > 0 else DEFAULT_MAX_ITERATIONS)
        for name in ("stagnation_window", "stagnation_progress"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, positive(name, value))
        object.__setattr__(self, "global_fallback", boolean("global_fallback", self.global_fallback))
        object.__setattr__(self, "global_time_limit", positive("global_time_limit", self.global_time_limit))
        seed = integer("global_seed", self.global_seed)
        if not 0 <= seed < SEED_LIMIT:
            raise InvalidInput("global_seed", self.global_seed, f"must be in [0, {SEED_LIMIT})")
        object.__setattr__(self, "global_seed", seed)
        if self.cancel is not None and not isinstance(self.cancel, CancelToken):
            raise InvalidInput("cancel", self.cancel, "expected a pfield.planning.CancelToken or None")

    @classmethod
    def build(cls, options: PlanOptions | None = None, **overrides: Any) -> PlanOptions:
        """``options`` (or the defaults) with the keyword arguments that are not None applied.

        This is how the planners' keyword arguments become options: ``plan(start, dt=0.02)`` equals
        ``plan(start, options=PlanOptions(dt=0.02))``. Unknown names raise ``InvalidInput``.
        """
        if options is not None and not isinstance(options, PlanOptions):
            raise InvalidInput("options", options, "expected a pfield.PlanOptions or None")
        if not _FIELD_NAMES.issuperset(overrides):
            for name in overrides:
                if name not in _FIELD_NAMES:
                    raise InvalidInput(name, overrides[name],
                                       f"unknown PlanOptions field; known: {sorted(_FIELD_NAMES)}")
        changes = {name: value for name, value in overrides.items() if value is not None}
        if options is None:
            # the defaults are one frozen value: validated once, at import (a plan without options builds them
            # at every call)
            return _DEFAULTS if not changes and cls is PlanOptions else cls(**changes)
        return replace(options, **changes) if changes else options

    def resolved(self, config: Any) -> PlanOptions:
        """These options with the None fields taken from ``config`` (a :class:`~pfield.field.FieldConfig`,
        whose values are already validated: they are copied, not checked again)."""
        if self is _DEFAULTS:
            cached = _resolved_defaults.get(id(config))
            if cached is not None and cached[0] is config:
                return cached[1]
        missing = [name for name in _FROM_CONFIG if getattr(self, name) is None]
        if not missing:
            return self
        out = object.__new__(PlanOptions)
        out.__dict__.update(self.__dict__, **{name: getattr(config, name) for name in missing})
        if self is _DEFAULTS:
            if len(_resolved_defaults) >= _RESOLVED_CACHE_SIZE:
                _resolved_defaults.clear()
            _resolved_defaults[id(config)] = (config, out)
        return out

    @property
    def stagnation_steps(self) -> int:
        """The stagnation window in steps: max(:data:`MIN_STAGNATION_STEPS`, round(window / dt)).

        Needs a resolved ``stagnation_window`` (see :meth:`resolved`)."""
        if self.stagnation_window is None:
            raise InvalidInput("stagnation_window", None, "resolve the options against a FieldConfig first")
        return max(MIN_STAGNATION_STEPS, round(self.stagnation_window / self.dt))


_FIELD_NAMES = frozenset(spec.name for spec in fields(PlanOptions))
_DEFAULTS = PlanOptions()
# The defaults resolved against the last few configs (FieldConfig is frozen), by identity: each entry holds its
# config, so that config's id is not reused while it is cached.
_RESOLVED_CACHE_SIZE = 8
_resolved_defaults: dict[int, tuple[Any, PlanOptions]] = {}
