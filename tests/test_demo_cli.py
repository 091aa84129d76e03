"""``pfield demo --only``: an unknown section is refused naming the known ones, and nothing runs."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from pfield.cli import app


def test_unknown_demo_section_is_refused(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["demo", "--only", "typo", "-o", str(tmp_path / "out")])
    assert result.exit_code == 2
    output = " ".join(result.output.split())
    assert "--only='typo'" in output
    assert "known: manipulator, whole_body, assisted, node_session, mobile, costmap, viewer" in output
    assert not (tmp_path / "out").exists()
