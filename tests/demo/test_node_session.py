"""The node-session demo sends inputs that agree with each other: no "query pose … disagrees" warning."""

from __future__ import annotations

import io
import logging
from pathlib import Path

import pytest
from rich.console import Console

from pfield.demo import node_session


def test_node_session_demo_raises_no_pose_mismatch(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    out = io.StringIO()
    with caplog.at_level(logging.WARNING):
        node_session.run(tmp_path, Console(file=out, width=160))
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert not [w for w in warnings if "disagrees" in w], warnings
    assert "whole_body" in out.getvalue()
