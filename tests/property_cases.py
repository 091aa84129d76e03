"""How many generated cases a property test runs: ``cases(n)`` is ``n`` in ``make test`` (and any run without
``HYPOTHESIS_PROFILE=nightly``), and ``NIGHTLY_FACTOR * n`` in the nightly run (the ``nightly`` hypothesis profile
of tests/conftest.py, which also derandomises). A per-test ``@settings(max_examples=...)`` overrides any profile's
count, so a test whose count should grow at night takes it from here."""

from __future__ import annotations

import os

__all__ = ["NIGHTLY", "NIGHTLY_FACTOR", "cases"]

NIGHTLY_FACTOR = 10
NIGHTLY = os.environ.get("HYPOTHESIS_PROFILE") == "nightly"
"""Whether this is the nightly run (``HYPOTHESIS_PROFILE=nightly``)."""


def cases(ci: int) -> int:
    """``ci`` generated cases in ``make test``, ``NIGHTLY_FACTOR * ci`` in the nightly run."""
    return ci * NIGHTLY_FACTOR if NIGHTLY else ci
