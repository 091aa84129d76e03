"""The mobile examples run (in-process, short horizon) and write their pictures.

``seed_grid.py`` is the simulation of ``test_mobile_sim.py`` plus ``render_png`` (``test_mobile_plots.py``).
"""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "mobile"


@pytest.mark.parametrize(("script", "extra", "pictures"), [
    ("field_api.py", [], ["mobile_field_api.png"]),
    ("assisted_teleop.py", ["--seconds", "4"], ["mobile_assisted_teleop.png"]),
])
def test_example_runs(script, extra, pictures, tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "argv", [script, "--output-dir", str(tmp_path), *extra])
    runpy.run_path(str(EXAMPLES / script), run_name="__main__")
    for name in pictures:
        assert (tmp_path / name).stat().st_size > 10_000
