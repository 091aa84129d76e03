"""Shared pytest configuration."""

from __future__ import annotations

import os
from pathlib import Path

# Keep matplotlib headless in every test process.
os.environ.setdefault("MPLBACKEND", "Agg")

# The fitted robot link models of the test run (and of every server, worker and example process it starts, which
# inherit the environment) go under build/ of this checkout, not into the user's ~/.cache/pfield; they persist
# between runs there, as a user's cache does (pfield.robot._fit.cache_root).
os.environ.setdefault("PFIELD_CACHE_DIR", str(Path(__file__).resolve().parents[1] / "build" / "test-cache"))

from hypothesis import settings

# CI runs the property tests on hypothesis's fixed example sequence, so a submission's result does not depend
# on the draw; developers' runs keep exploring new examples.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
