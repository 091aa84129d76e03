"""Shared pytest configuration."""

from __future__ import annotations

import os

# Keep matplotlib headless in every test process.
os.environ.setdefault("MPLBACKEND", "Agg")
