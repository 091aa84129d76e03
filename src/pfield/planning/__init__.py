"""Planners and their common result type :class:`PlannedPath`."""

from pfield.planning.cancel import CancelToken
from pfield.planning.result import PlannedPath

__all__ = ["CancelToken", "PlannedPath"]
