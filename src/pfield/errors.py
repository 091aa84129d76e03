"""The pfield exception hierarchy.

Every error pfield raises on purpose derives from :class:`PfieldError`, so callers (the node, the CLI)
can catch one base class, report ``str(error)`` to the user and keep running. Messages name the field
and the offending value, and where possible say what to do next.
"""

from __future__ import annotations

__all__ = [
    "InvalidInput",
    "PfieldError",
    "PlanningFailed",
    "ResourceNotAllowed",
    "ResourceNotFound",
    "UnknownFrame",
]


class PfieldError(Exception):
    """Base class of every error raised by pfield."""


class InvalidInput(PfieldError, ValueError):
    """A value supplied by a caller is malformed, out of range or inconsistent.

    ``field`` names the offending field (dotted path for nested fields, e.g. ``obstacles[2].radius``)
    and ``value`` holds the rejected value, so transports can report both.
    """

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field = field
        self.value = value
        self.reason = reason
        super().__init__(f"{field}={value!r}: {reason}")


class UnknownFrame(InvalidInput):
    """A message refers to a coordinate frame pfield has no transform for."""


class ResourceNotFound(PfieldError, FileNotFoundError):
    """A file or package resource (mesh, URDF, map) could not be found or read."""


class ResourceNotAllowed(PfieldError, PermissionError):
    """A resource URI resolves outside the configured allowed roots."""


class PlanningFailed(PfieldError):
    """A planner could not produce a result at all (not merely an unsuccessful plan)."""
