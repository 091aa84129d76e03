"""Shared pytest configuration."""

from __future__ import annotations

import os

# Keep matplotlib headless in every test process.
os.environ.setdefault("MPLBACKEND", "Agg")

from hypothesis import settings

# CI runs the property tests on hypothesis's fixed example sequence, so a submission's result does not depend
# on the draw; developers' runs keep exploring new examples.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
