"""Planners and their common result type :class:`PlannedPath`."""

from pfield.planning.result import PlannedPath

__all__ = ["PlannedPath"]
