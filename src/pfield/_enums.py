"""Enumerations that print their names: :class:`NamedIntEnum`.

Python 3.11's ``IntEnum`` prints its number (``print(PlanStatus.STAGNATION)`` → ``1``), which tells a user
nothing. pfield's outcome enums print their names instead, and stay integers everywhere else: they compare,
index and serialise (JSON, ROS messages) as their numbers, so no wire format changes.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = ["NamedIntEnum"]


class NamedIntEnum(IntEnum):
    """An ``IntEnum`` whose ``str()`` and plain ``f"{…}"`` are its name (a format spec such as ``:d`` formats the
    number); ``int(member)`` and ``member.value`` give the number."""

    def __str__(self) -> str:
        return self.name

    def __format__(self, spec: str) -> str:
        return self.name if not spec else format(int(self), spec)
