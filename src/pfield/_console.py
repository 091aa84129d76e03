"""The rich console of pfield's commands and demo: one place for how they print."""

from __future__ import annotations

from rich.console import Console

LOG_WIDTH = 120
"""Columns of tables when the output is not a terminal (make, a CI log, a pipe, a file)."""


def console(stderr: bool = False) -> Console:
    """A console on stdout (``stderr``: on stderr). In a terminal, the terminal's width. Elsewhere rich would wrap
    every line at 80 columns, splitting values and file names across the lines of a log; there, tables get
    :data:`LOG_WIDTH` columns and lines are never wrapped (``soft_wrap``)."""
    shown = Console(stderr=stderr)
    if shown.is_terminal:
        return shown
    return Console(stderr=stderr, width=LOG_WIDTH, soft_wrap=True)
