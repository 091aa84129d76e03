"""Planners, their options, their outcome and their common result type.

* :class:`PlanOptions` — how every planner integrates and when it stops; :class:`PlanStatus` — why it
  stopped; :class:`PlannedPath` — the result (with ``status`` and ``planner``); :class:`CancelToken`.
* :func:`plan_task_space` (:mod:`pfield.planning.task_space`) and :func:`plan_whole_body`
  (:mod:`pfield.planning.whole_body`), also reached as :meth:`PotentialField.plan` / ``plan_whole_body``.
* :class:`WholeBodyStepper` — one whole-body field step, what shared control evaluates each cycle.

The whole-body names load the robot stack (pinocchio) on first use, not at ``import pfield.planning``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pfield._lazy import lazy_exports
from pfield.planning.cancel import CancelToken
from pfield.planning.options import PlanOptions
from pfield.planning.result import PlannedPath
from pfield.planning.status import PlanStatus

if TYPE_CHECKING:
    from pfield.planning.stepper import WholeBodyStep, WholeBodyStepper
    from pfield.planning.task_space import plan_task_space
    from pfield.planning.whole_body import WholeBodyOptions, plan_whole_body

__all__ = ["CancelToken", "PlanOptions", "PlanStatus", "PlannedPath", "WholeBodyOptions", "WholeBodyStep",
           "WholeBodyStepper", "plan_task_space", "plan_whole_body"]

__getattr__, __dir__ = lazy_exports(__name__, {
    "WholeBodyStep": "pfield.planning.stepper", "WholeBodyStepper": "pfield.planning.stepper",
    "plan_task_space": "pfield.planning.task_space", "WholeBodyOptions": "pfield.planning.whole_body",
    "plan_whole_body": "pfield.planning.whole_body"}, globals())
