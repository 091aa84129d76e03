"""The outcome of every planner as a value: :class:`PlanStatus` (one enum for every compiled loop).

The compiled core's loops return its ``PlanStatus`` (``src/core/planning/status.hpp``, the same values), the
Python layer carries these members on :attr:`PlannedPath.status`, and ``failure_reason`` is the sentence beside
the value (as nav2's ``TaskResult`` sits beside its message). Compare statuses, never sentences.
"""

from __future__ import annotations

from pfield._enums import NamedIntEnum

__all__ = ["ROOT_CAUSES", "PlanStatus"]


class PlanStatus(NamedIntEnum):
    """Why a plan ended. Only :attr:`REACHED` is a success. Prints its name (``STAGNATION``); compares and
    serialises as its number."""

    REACHED = 0
    """The last waypoint is within the position and rotation tolerances of the goal."""
    STAGNATION = 1
    """Neither goal error improved by ``stagnation_progress`` over one stagnation window."""
    ITERATION_LIMIT = 2
    """``max_iterations`` steps without reaching the goal."""
    COLLISION = 3
    """The next step would bring the end effector (task space) or a link (whole body) into an obstacle;
    the plan stops before it."""
    SELF_COLLISION = 4
    """The next step would bring two links of the robot into contact; the plan stops before it."""
    NOT_FINITE = 5
    """The state became NaN or infinite (a numerical failure)."""
    START_INVALID = 6
    """The start itself is in collision (task space: inside an obstacle; whole body: the exact meshes touch)."""
    GOAL_INVALID = 7
    """The goal cannot be reached at all (inside or within ``safety_distance`` of an obstacle)."""
    CANCELLED = 8
    """A :class:`~pfield.planning.CancelToken` asked the plan to stop."""
    IK_FAILED = 9
    """The task-space path was found, but inverse kinematics failed at a waypoint: the robot cannot follow it."""
    GLOBAL_NO_PATH = 10
    """A global fallback planner proved or gave up that no collision-free path exists."""
    GLOBAL_TIME_LIMIT = 11
    """A global fallback planner ran out of its time budget."""

    @property
    def success(self) -> bool:
        return self is PlanStatus.REACHED


ROOT_CAUSES = frozenset({PlanStatus.GOAL_INVALID, PlanStatus.GLOBAL_NO_PATH})
"""Outcomes of a global fallback that explain why the field stopped short (the goal cannot be reached at all, or
no path exists): a failure reason names them first, then what the field did."""
