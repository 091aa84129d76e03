"""``python -m benchmarks.run``: a partial run (``--only``/``--quick``) never rewrites the tracked results."""

from __future__ import annotations

import json
import math
import sys
import types
from pathlib import Path

import pytest
from benchmarks import run as bench_run  # the repository root is on pytest's pythonpath (pyproject.toml)
from benchmarks._common import HOST_CHECK, BenchRow, Report

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def fake_benchmarks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A benchmarks folder with two modules (bench_alpha, bench_beta) and tracked results of both."""
    results = tmp_path / "results"
    results.mkdir()
    for name, value in (("alpha", 1.0), ("beta", 2.0)):
        (tmp_path / f"bench_{name}.py").write_text("")
        module = types.ModuleType(f"benchmarks.bench_{name}")
        module.run = lambda quick, name=name, value=value: [BenchRow(name, f"{name} figure", value, "ms")]  # type: ignore[attr-defined]
        monkeypatch.setitem(sys.modules, f"benchmarks.bench_{name}", module)
        (results / f"bench_{name}.json").write_text(json.dumps({"rows": [{"section": name, "name": "old",
                                                                           "value": 9.0, "unit": "ms"}]}))
    (results / "latest.md").write_text("tracked\n")
    monkeypatch.setattr(bench_run, "HERE", tmp_path)
    monkeypatch.setattr(bench_run, "RESULTS", results)
    return results


def _snapshot(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in folder.iterdir() if p.is_file()}


@pytest.mark.parametrize("argv", [["--only", "alpha"], ["--quick"], ["--only", "alpha", "--quick"]])
def test_partial_runs_write_elsewhere(fake_benchmarks: Path, monkeypatch: pytest.MonkeyPatch,
                                      argv: list[str]) -> None:
    before = _snapshot(fake_benchmarks)
    monkeypatch.setattr(sys, "argv", ["benchmarks.run", *argv])
    bench_run.main()
    assert _snapshot(fake_benchmarks) == before
    partial = fake_benchmarks / "partial"
    saved = json.loads((partial / "bench_alpha.json").read_text())
    host, figure = saved["rows"]
    assert figure["value"] == 1.0
    assert host["name"] == HOST_CHECK and host["section"] == "alpha" and host["value"] == saved["host_check_ms"] > 0
    assert "alpha figure" in (partial / "latest.md").read_text()


def test_out_directory_of_a_partial_run(fake_benchmarks: Path, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "argv", ["benchmarks.run", "--only", "beta", "--out", str(tmp_path / "mine")])
    bench_run.main()
    assert (tmp_path / "mine" / "bench_beta.json").is_file() and not (fake_benchmarks / "partial").exists()


def test_a_full_run_updates_the_tracked_results(fake_benchmarks: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "argv", ["benchmarks.run"])
    bench_run.main()
    latest = (fake_benchmarks / "latest.md").read_text()
    assert "alpha figure" in latest and "beta figure" in latest
    assert not (fake_benchmarks / "partial").exists()


def test_a_reports_tables_go_where_the_run_writes(fake_benchmarks: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    module = sys.modules["benchmarks.bench_alpha"]
    rows = module.run(False)
    monkeypatch.setattr(module, "run", lambda quick: Report(rows, {"alpha_table.md": "a table\n"}))
    before = _snapshot(fake_benchmarks)
    monkeypatch.setattr(sys, "argv", ["benchmarks.run", "--only", "alpha"])
    bench_run.main()
    assert _snapshot(fake_benchmarks) == before
    assert (fake_benchmarks / "partial" / "alpha_table.md").read_text() == "a table\n"
    assert json.loads((fake_benchmarks / "partial" / "bench_alpha.json").read_text())["rows"][1]["value"] == 1.0
    monkeypatch.setattr(sys, "argv", ["benchmarks.run"])
    bench_run.main()
    assert (fake_benchmarks / "alpha_table.md").read_text() == "a table\n"


def test_teleop_table_has_each_scene_and_mode_with_its_rows_figures() -> None:
    from benchmarks.bench_teleop import MODES, Summary, scenes, teleop_rows, teleop_table

    summaries = {(scene, mode): Summary(0.3, 4, k, -0.01 * k, k / 4, 4.0 + k if k else math.inf, 1.0 - 0.1 * k)
                 for scene in scenes() for k, mode in enumerate(MODES)}
    lines = teleop_table(summaries).splitlines()
    assert len(lines) == 2 + len(scenes()) * len(MODES)
    rows = {row.name: row for row in teleop_rows(summaries)}
    for line, ((scene, mode), s) in zip(lines[2:], summaries.items(), strict=True):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[:3] == [scene, mode, f"{s.collisions}/4"]
        for cell, figure in zip(cells[3:], ("min clearance", "success", "median time to goal", "agreement"),
                                strict=True):
            assert float(cell) == pytest.approx(rows[f"{scene} / {mode}: {figure}"].value, abs=6e-3)
    # pfield's time target: 0.8 x Servo's 5.0 s = 4.0 s, above the straight line at 0.08 m/s (3.5 s)
    assert rows["spheres / pfield: median time to goal"].target == pytest.approx(4.0)
    assert rows["spheres / pfield: success"].target == 0.25


def test_teleop_time_target_is_left_out_only_where_no_mode_can_meet_it() -> None:
    from benchmarks.bench_teleop import Summary, _time_target

    fastest = 4.18
    assert _time_target(Summary(0.35, 50, 0, 0.07, 1.0, 4.60, 1.0), fastest)[0] is None  # 3.68 s < 4.18 s
    assert _time_target(Summary(0.35, 50, 0, 0.0, 0.44, 13.88, 1.0), fastest)[0] == pytest.approx(11.104)
    target, note = _time_target(Summary(0.35, 50, 0, 0.0, 0.0, math.inf, 1.0), fastest)
    assert target is None and "no Servo time" in note
