"""``python -m benchmarks.run``: a partial run (``--only``/``--quick``) never rewrites the tracked results."""

from __future__ import annotations

import json
import math
import sys
import types
from pathlib import Path
from typing import Any

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
    picture = b"\x89PNG\r\n\x1a\n not decoded here"
    monkeypatch.setattr(module, "run", lambda quick: Report(rows, {"alpha_table.md": "a table\n",
                                                                   "alpha.png": picture}))
    before = _snapshot(fake_benchmarks)
    monkeypatch.setattr(sys, "argv", ["benchmarks.run", "--only", "alpha"])
    bench_run.main()
    assert _snapshot(fake_benchmarks) == before
    assert (fake_benchmarks / "partial" / "alpha_table.md").read_text() == "a table\n"
    assert (fake_benchmarks / "partial" / "alpha.png").read_bytes() == picture
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


def _row(name: str, value: float, section: str = "s", **more: object) -> dict[str, object]:
    return {"section": section, "name": name, "value": value, "unit": "ms", **more}


def test_old_and_new_rows_pair_by_section_and_name_with_the_median_of_their_rounds() -> None:
    from benchmarks._old_engine import merge, middle

    assert middle([3.0, None, 1.0, 2.0]) == 2.0 and middle([]) is None
    assert middle([5.0, 1.0]) == 1.0 and middle([5.0, 1.0], higher_is_better=True) == 5.0  # the better of two
    olds = [[_row("a", 4.0), _row("gone", 1.0), _row("x", 9.0, "t")], [_row("a", 6.0), _row("gone", 3.0)]]
    news = [[_row("a", 1.0, reference=2.0), _row("new", 5.0)], [_row("a", 3.0, reference=4.0), _row("new", 7.0)],
            [_row("a", 2.0, reference=3.0), _row("new", 6.0)]]
    rows, figures = merge(olds, news)
    assert [(r.section, r.name) for r in rows] == [("s", "a"), ("s", "new"), ("s", "gone"), ("t", "x")]
    a, new, gone, x = rows
    assert (a.value, a.reference, a.old_value, a.new_old()) == (2.0, 3.0, 4.0, 0.5)
    assert new.value == 6.0 and new.old_value is None and new.new_old() is None
    assert math.isnan(gone.value) and gone.old_value == 1.0 and gone.new_old() is None and "only in" in gone.note
    assert x.old_value == 9.0 and gone.meets_target() is None
    assert figures["s / a"] == {"new": [1.0, 3.0, 2.0], "old": [4.0, 6.0]}


def test_new_old_is_oriented_so_that_at_most_one_is_no_worse() -> None:
    assert BenchRow("s", "t", 2.0, "ms", old_value=4.0).new_old() == 0.5
    assert BenchRow("s", "plans", 2.0, "plans/s", higher_is_better=True, old_value=4.0).new_old() == 2.0
    assert BenchRow("s", "zero", 0.0, "%", higher_is_better=True, old_value=0.0).new_old() == 1.0


def test_the_table_gains_the_old_engine_columns_only_when_paired() -> None:
    plain = bench_run.to_markdown([BenchRow("s", "t", 2.0, "ms")])
    assert "numba engine" not in plain and "new/old" not in plain
    rows = [BenchRow("s", "fast", 2.0, "ms", old_value=4.0), BenchRow("s", "slow", 5.0, "ms", old_value=4.0),
            BenchRow("s", "rate", 3.0, "plans/s", higher_is_better=True, old_value=4.0),
            BenchRow("s", "gone", math.nan, "ms", old_value=1.0), BenchRow("s", "new only", 1.0, "ms")]
    lines = bench_run.to_markdown(rows).splitlines()
    assert lines[0] == bench_run.OLD_LEGEND and "| numba engine | new/old |" in lines[4]
    cells = {line.split(" | ")[0].strip("| "): line.split(" | ")[1:5] for line in lines[6:]}
    assert cells["fast"] == ["2.00", "ms", "4.00", "0.50"]
    assert cells["slow"] == ["5.00", "ms", "4.00", "**1.25**"]
    assert cells["rate"] == ["3.00", "plans/s", "4.00", "**1.33** (old/new)"]
    assert cells["gone"] == ["—", "ms", "1.00", "—"]
    assert cells["new only"] == ["1.00", "ms", "—", "—"]


def _outcome(success: bool, seconds: float, length: float = math.nan, contact: str = "", seed: int = 0) -> Any:
    import numpy as np
    from benchmarks.bench_fallback import Outcome

    status = "reached" if success else "global_time_limit"
    return Outcome(success, status, seconds, seconds, "pfield", np.zeros((2, 6)), np.zeros((2, 6)), np.zeros(2),
                   length=length, duration=2.0 if success else math.nan, contact=contact, seed=seed)


def test_the_mbm_table_pools_pfields_seeds_and_gives_each_seeds_median() -> None:
    from benchmarks.bench_fallback import Result, figures, plan_lines, problems_list, rows, table

    results = [Result("ur5", "cage", k, "", "", {"pfield": _outcome(True, 0.010 * k, 8.0),
                                                 "OMPL RRT-Connect": _outcome(True, 1.0, 7.0)},
                      [_outcome(True, 0.100 * k, 9.0, seed=1), _outcome(k != 2, 0.200 * k, 9.0, seed=2)])
               for k in (1, 2, 3)]
    pfield, ompl = figures(results)
    assert (pfield.valid, pfield.attempts, pfield.solved) == (3, 9, 8)
    assert pfield.success == pytest.approx(800 / 9)
    assert pfield.median_ms == pytest.approx(200.0)  # of 10 20 30 100 200 200 300 400 600 (ms)
    assert pfield.seed_medians == ((0, pytest.approx(20.0)), (1, pytest.approx(200.0)), (2, pytest.approx(400.0)))
    assert pfield.length == pytest.approx(9.0)
    assert (ompl.attempts, ompl.solved, ompl.seed_medians) == (3, 3, ())
    text = table([pfield, ompl], {})
    assert "| ur5 | cage | pfield | 3/3 | 8/9 (88.9 %) | 200.0 |" in text
    assert "seeds 0, 1, 2: median 20.0 / 200.0 / 400.0 ms" in text
    assert "| ur5 | cage | OMPL RRT-Connect | 3/3 | 3/3 (100.0 %) |" in text
    assert "| ur5 | cage | 2 | pfield (seed 2) | global_time_limit (0.40 s) |" in problems_list(results)
    median = {r.name: r for r in rows([pfield])}["ur5 cage: pfield median time"]
    assert median.note == "seeds 0, 1, 2: median 20.0 / 200.0 / 400.0 ms"
    lines = plan_lines(results)
    assert [(p.index, p.planner, p.seed) for p in lines[:4]] == [
        (1, "pfield", 0), (1, "pfield", 1), (1, "pfield", 2), (1, "OMPL RRT-Connect", 0)]


def test_the_mbm_table_counts_over_valid_problems_and_shows_colliding_claims() -> None:
    from benchmarks.bench_fallback import Result, figures, problems_list, table

    results = [Result("ur5", "box", 1, "", "", {"pfield": _outcome(True, 0.010, 4.0)}),
               Result("ur5", "box", 2, "", "", {"pfield": _outcome(True, 0.030, 6.0, "wrist_2_link/Can1 at 3")}),
               Result("ur5", "box", 3, "", "", {"pfield": _outcome(False, 2.0)}),
               Result("ur5", "box", 4, "forearm_link/table", "")]
    (line,) = figures(results)
    assert (line.problems, line.valid, line.solved, line.colliding) == (4, 3, 2, 1)
    assert line.success == pytest.approx(200 / 3) and line.median_ms == pytest.approx(30.0)
    assert line.length == pytest.approx(5.0) and line.duration == 2.0
    text = table([line], {"ur5": [], "panda": ["cage"]})
    assert "| ur5 | box | pfield | 3/4 | 2/3 (66.7 %) | 30.0 |" in text and "| **1** |" in text
    assert "panda: scenes cage are not in its archive" in text
    listed = problems_list(results)
    assert "| ur5 | box | 4 | — | invalid (start in contact: forearm_link/table) |" in listed
    assert "| ur5 | box | 3 | pfield | global_time_limit (2.00 s) |" in listed
    assert "claimed reached, in contact: wrist_2_link/Can1 at 3" in listed and "| ur5 | box | 1 |" not in listed


def test_the_mbm_table_adds_a_line_over_all_scenes_with_vamps_path_as_the_target() -> None:
    from benchmarks.bench_fallback import ALL_SCENES, Result, figures, rows

    results = [Result("ur5", "box", 1, "", "", {"pfield": _outcome(True, 0.010, 4.0)}),
               Result("ur5", "cage", 1, "", "", {"pfield": _outcome(True, 0.050, 8.0)}),
               Result("ur5", "cage", 2, "", "", {"pfield": _outcome(True, 0.070, 9.0)}),
               Result("ur5", "cage", 3, "", "forearm_link/table")]
    box, cage, every = figures(results)
    assert (box.scene, cage.scene, every.scene) == ("box", "cage", ALL_SCENES)
    assert (every.problems, every.valid, every.solved) == (4, 3, 3)
    assert every.length == pytest.approx(8.0) and every.median_ms == pytest.approx(50.0)
    path = {r.name: r for r in rows([cage, every]) if r.name.endswith("median path length")}
    assert path["ur5 cage: pfield median path length"].target is None
    assert path[f"ur5 {ALL_SCENES}: pfield median path length"].target == pytest.approx(1.1 * 6.52)
    (single,) = figures(results[:1])  # one scene: no line over all
    assert single.scene == "box"


def test_the_mbm_plans_round_trip_through_their_csv_and_draw_a_picture_per_robot(tmp_path: Path) -> None:
    from benchmarks import bench_fallback
    from benchmarks.bench_fallback import Result, plan_lines, plans_csv, read_plans_csv, times_picture
    from matplotlib.image import imread

    results = [Result("panda", "box", 1, "", "", {"pfield": _outcome(True, 0.004, 4.5),
                                                  "OMPL RRT-Connect": _outcome(False, 5.0)}),
               Result("ur5", "cage", 7, "", "", {"pfield": _outcome(True, 0.041, 8.0, "wrist_2_link/bar at 3")}),
               Result("ur5", "cage", 8, "forearm_link/bar", "")]  # invalid: no plan, no line
    lines = plan_lines(results)
    assert [(p.robot, p.scene, p.index, p.planner) for p in lines] == [
        ("panda", "box", 1, "pfield"), ("panda", "box", 1, "OMPL RRT-Connect"), ("ur5", "cage", 7, "pfield")]
    text = plans_csv(lines)
    assert text.splitlines()[1] == "panda,box,1,pfield,0,reached,1,4.000,4.000,4.5000,2.000,"
    assert text.splitlines()[2] == "panda,box,1,OMPL RRT-Connect,0,global_time_limit,0,5000.000,5000.000,,,"
    back = read_plans_csv(text)
    assert back[2].contact == "wrist_2_link/bar at 3" and back[2].ms == pytest.approx(41.0)
    assert math.isnan(back[1].path_rad) and not back[1].success and back[0].success
    with pytest.raises(ValueError, match="columns"):
        read_plans_csv("robot,scene\nur5,box\n")
    # a file written before the seed column: every plan is seed 0's
    older = "\n".join(line.replace(",pfield,0,", ",pfield,").replace(",OMPL RRT-Connect,0,", ",OMPL RRT-Connect,")
                      .replace(",planner,seed,", ",planner,") for line in text.splitlines())
    assert read_plans_csv(older) == back
    with pytest.raises(ValueError, match="line 3 has 4 of 12 cells"):
        read_plans_csv(text.splitlines()[0] + "\n" + text.splitlines()[1] + "\nur5,cage,7,pfield\n")
    picture = tmp_path / "mbm_times.png"
    picture.write_bytes(times_picture(back))
    height, width = imread(picture).shape[:2]
    assert width > height > 300  # two robots side by side
    (tmp_path / "mbm_plans.csv").write_text(text)
    (tmp_path / "mbm_times.png").unlink()
    bench_fallback.main(["--redraw", str(tmp_path / "mbm_plans.csv")])
    assert (tmp_path / "mbm_times.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("argv", [["--limit", "0"], ["--robot", "kuka"], ["--ompl-time", "0"], ["--scenes", "x"],
                                  ["--redraw", "/nonexistent/mbm_plans.csv"], ["--seeds", "-1"],
                                  ["--seeds", "1", "1"], ["--seeds", "x"]])
def test_the_mbm_bench_refuses_bad_arguments(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    from benchmarks import bench_fallback

    with pytest.raises(SystemExit) as exit_info:
        bench_fallback.main(argv)
    assert exit_info.value.code == 2
    assert argv[0] in capsys.readouterr().err
