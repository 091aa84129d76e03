"""``python -m benchmarks.run``: a partial run (``--only``/``--quick``) never rewrites the tracked results."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # benchmarks/ is a top-level package beside src/, run as ``python -m``
    sys.path.insert(0, str(REPO))

from benchmarks import run as bench_run  # noqa: E402
from benchmarks._common import HOST_CHECK, BenchRow  # noqa: E402


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


def test_side_tables_go_where_the_run_writes(fake_benchmarks: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    module = sys.modules["benchmarks.bench_alpha"]
    monkeypatch.setattr(module, "side_tables", lambda rows: {"alpha_table.md": f"{len(rows)} rows\n"}, raising=False)
    before = _snapshot(fake_benchmarks)
    monkeypatch.setattr(sys, "argv", ["benchmarks.run", "--only", "alpha"])
    bench_run.main()
    assert _snapshot(fake_benchmarks) == before
    assert (fake_benchmarks / "partial" / "alpha_table.md").read_text() == "2 rows\n"  # with the host check
    monkeypatch.setattr(sys, "argv", ["benchmarks.run"])
    bench_run.main()
    assert (fake_benchmarks / "alpha_table.md").read_text() == "2 rows\n"


def test_teleop_side_table_lays_each_scene_and_mode_on_one_line() -> None:
    from benchmarks.bench_teleop import MODES, scenes, side_tables, teleop_rows

    rows = teleop_rows(2)
    table = side_tables(rows)["teleop_table.md"].splitlines()
    assert len(table) == 2 + len(scenes()) * len(MODES)
    by_name = {row.name: row.value for row in rows}
    scene, mode, collisions, clearance, success, time, agreement = (c.strip() for c in table[2].strip("|").split("|"))
    assert float(success) == by_name["seed / none: success"]
    assert float(agreement) == pytest.approx(by_name["seed / none: agreement"], abs=5e-4)
    assert (scene, mode) == ("seed", "none")
    assert collisions == f"{by_name['seed / none: runs with a collision']:.0f}/2"
    assert float(clearance) == pytest.approx(by_name["seed / none: min clearance"], abs=5e-5)
    assert float(time) == pytest.approx(by_name["seed / none: median time to goal"], abs=5e-3)
