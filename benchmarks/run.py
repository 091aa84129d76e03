"""Run every ``benchmarks/bench_*.py`` module and print one Markdown table per section.

Usage: ``python -m benchmarks.run [--quick] [--only NAME ...] [--out DIR] [--rounds N] [--no-old]``
(``make bench``, ``make bench BENCH_ARGS=...``). Each module
exposes ``run(quick: bool)`` returning its rows (``list[BenchRow]``) or a :class:`benchmarks._common.Report`
(the rows and other views of them, written beside them). A full run writes ``benchmarks/results/<module>.json`` (the
tracked figures) and rebuilds ``benchmarks/results/latest.md`` from all saved modules. A partial run
(``--only`` or ``--quick``) leaves those files alone: its JSON files and a ``latest.md`` of its own rows go
to ``--out`` (default ``benchmarks/results/partial/``, not tracked). Each module's first section opens with
the host check (:func:`benchmarks._common.host_check_ms`, timed just before the module): a single-thread figure
of two runs that moved by about the same factor as the host check most likely moved with the host.
Reference figures: ``../shared/benchmarks/REFERENCE.md``.

Beside the numba engine: when ``make old-engine`` has built it (``build/old-engine``: the last all-numba commit in
a git worktree with its own virtual environment) and unless ``--no-old``, every module that exists in both trees
runs in new processes, old and new alternating, ``--rounds`` times each (default 2); each figure is the median of
its rounds (of two, the better: :func:`benchmarks._old_engine.middle`) and the table gains the columns
``numba engine`` and ``new/old`` (≤ 1 is no worse, see :meth:`BenchRow.new_old`). Rows are matched by (section,
name); a row one engine lacks shows "—". A module the old commit lacks runs once in this process, as without the
numba engine. ``benchmarks/_old_engine.py``; docs/core.md, "Comparing with the numba engine".
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import Progress

from benchmarks import _old_engine
from benchmarks._common import HOST_CHECK, BenchRow, Report, host_check_ms

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
PARTIAL = "partial"
"""Folder under :data:`RESULTS` of partial runs (ignored by git)."""

HEADER = ("| figure | pfield | unit | C++ original | ratio | target | met | note |",
          "|---|---:|---|---:|---:|---:|:---:|---|")
PAIRED_HEADER = ("| figure | pfield | unit | numba engine | new/old | C++ original | ratio | target | met | note |",
                 "|---|---:|---|---:|---:|---:|---:|---:|:---:|---|")
OLD_LEGEND = ("numba engine: the same row of the last all-numba commit, measured in the same run (old and new "
              "alternating, each figure the median of its rounds, of two the better). new/old ≤ 1.00: the new engine "
              "is no slower (no worse); where higher is better (plans/s, success) the cell is old/new. Bold: above "
              "1.00.")


def _fmt(value: float | None) -> str:
    if value is None or math.isnan(value):
        return "—"
    if value == 0:
        return "0"
    if abs(value) >= 100:
        return f"{value:.0f}"
    if abs(value) >= 1:
        return f"{value:.2f}"
    return f"{value:.3g}"


def _new_old(row: BenchRow) -> str:
    ratio = row.new_old()
    if ratio is None:
        return "—"
    text = f"{ratio:.2f}" if 0.01 <= ratio < 100 else _fmt(ratio)
    text = f"**{text}**" if round(ratio, 2) > 1.0 else text
    return f"{text} (old/new)" if row.higher_is_better else text


def to_markdown(rows: list[BenchRow]) -> str:
    """One table per section; with the columns ``numba engine`` and ``new/old`` when any row has an old figure."""
    paired = any(row.old_value is not None for row in rows)
    lines: list[str] = [OLD_LEGEND] if paired else []
    section = None
    for row in rows:
        if row.section != section:
            section = row.section
            lines += ["", f"### {section}", "", *(PAIRED_HEADER if paired else HEADER)]
        met = {True: "yes", False: "**no**", None: ""}[row.meets_target()]
        old = f"{_fmt(row.old_value)} | {_new_old(row)} | " if paired else ""
        lines.append(
            f"| {row.name} | {_fmt(row.value)} | {row.unit} | {old}{_fmt(row.reference)} | {_fmt(row.ratio())} | "
            f"{_fmt(row.target)} | {met} | {row.note} |"
        )
    return "\n".join(lines).lstrip() + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer repetitions (smoke run)")
    parser.add_argument("--only", nargs="*", default=[], help="module names without bench_ prefix")
    parser.add_argument("--out", type=Path, default=None,
                        help="where a partial run writes (default: benchmarks/results/partial)")
    parser.add_argument("--rounds", type=int, default=2,
                        help="beside the numba engine: runs of each module per engine, alternating (default 2)")
    parser.add_argument("--no-old", action="store_true",
                        help="time this tree only, not beside the numba engine (make old-engine)")
    parser.add_argument("--old-engine", type=Path, default=_old_engine.WORKTREE,
                        help="the numba engine's worktree (default build/old-engine)")
    args = parser.parse_args()
    partial = bool(args.only or args.quick)
    out = RESULTS if not partial and args.out is None else (args.out or RESULTS / PARTIAL)
    console = Console(width=None if sys.stdout.isatty() else 200)  # tables, not 80-column wraps, in logs
    modules = sorted(p.stem for p in HERE.glob("bench_*.py"))
    if args.only:
        modules = [m for m in modules if m.removeprefix("bench_") in args.only]
    rounds = max(args.rounds, 1)
    old = None if args.no_old else _old_engine.old_engine(args.old_engine)
    if old is not None:
        absent = [m for m in modules if not old.has_module(m)]
        console.print(f"beside the numba engine ({old.root}, commit {old.commit[:12]}): {rounds} rounds each, "
                      "alternating" + (f"; not at that commit: {', '.join(absent)}" if absent else ""),
                      markup=False, highlight=False)
    elif not args.no_old:
        console.print(f"no numba engine in {args.old_engine} (make old-engine): no old/new columns",
                      markup=False, highlight=False)
    out.mkdir(parents=True, exist_ok=True)
    all_rows: list[BenchRow] = []
    failed: list[str] = []
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task("benchmarks", total=len(modules))
        for name in modules:
            progress.update(task, description=name)
            if old is not None and old.has_module(name):
                rows, payload = _paired(name, old, args.quick, rounds, out, console,
                                        lambda text: progress.update(task, description=text))
            else:
                rows, payload = _in_process(name, args.quick, out)
            if payload is None:
                failed.append(name)
            else:
                all_rows.extend(rows)
                (out / f"{name}.json").write_text(json.dumps(payload, indent=2))
            progress.advance(task)
    console.print(to_markdown(all_rows), markup=False, highlight=False)
    # The tracked latest.md covers every module; a partial run's latest.md only its own rows.
    (out / "latest.md").write_text(to_markdown(all_rows if partial else _saved_rows(out)))
    if failed:
        raise SystemExit(f"failed in this tree (every round): {', '.join(failed)}")


def _payload(name: str, seconds: float, host: float | None, rows: list[BenchRow]) -> dict[str, Any]:
    return {"module": name, "seconds": seconds, "machine": platform.processor() or platform.machine(),
            "python": platform.python_version(), "host_check_ms": host, "rows": [r.as_dict() for r in rows]}


def _in_process(name: str, quick: bool, out: Path) -> tuple[list[BenchRow], dict[str, Any]]:
    """Module ``name`` run once in this process, after the host check: its rows and its JSON payload."""
    host = host_check_ms()
    start = time.perf_counter()
    module = importlib.import_module(f"benchmarks.{name}")
    result = module.run(quick)
    rows, files = (result.rows, result.files) if isinstance(result, Report) else (result, {})
    if rows:
        rows = [BenchRow(rows[0].section, HOST_CHECK, host, "ms",
                         note=f"before {name}; single-thread figures of two runs compare through it"), *rows]
    for file_name, content in files.items():
        if isinstance(content, bytes):
            (out / file_name).write_bytes(content)
        else:
            (out / file_name).write_text(content)
    return rows, _payload(name, time.perf_counter() - start, host, rows)


def _paired(name: str, old: _old_engine.Engine, quick: bool, rounds: int, out: Path, console: Console,
            progress: Callable[[str], object]) -> tuple[list[BenchRow], dict[str, Any] | None]:
    """Module ``name`` run ``rounds`` times in each engine, alternating, each run a new process: the merged rows
    and the JSON payload, which also keeps every round's figures. No payload when every round of this tree
    failed; a failed round is reported with the end of its output."""
    start = time.perf_counter()
    with _old_engine.scratch_folder() as scratch:
        olds, news = _old_engine.paired_rounds(old, _old_engine.new_engine(), name, quick, rounds, Path(scratch),
                                               progress)
        for runs in (olds, news):
            for k, run in enumerate(runs):
                if run.payload is None:
                    console.print(f"{name}: {run.engine.label}, round {k + 1}, failed\n{run.log}", markup=False,
                                  highlight=False)
        old_payloads = [r.payload for r in olds if r.payload is not None]
        new_runs = [r for r in news if r.payload is not None]
        if not new_runs:
            return [], None
        _old_engine.copy_files(new_runs[-1].out, out, name)
    new_payloads = [r.payload for r in new_runs if r.payload is not None]
    rows, figures = _old_engine.merge([p["rows"] for p in old_payloads], [p["rows"] for p in new_payloads])
    hosts = [p["host_check_ms"] for p in new_payloads if p.get("host_check_ms")]
    payload = _payload(name, time.perf_counter() - start, statistics.median(hosts) if hosts else None, rows)
    payload["old_engine"] = {"path": str(old.root), "commit": old.commit, "quick": quick, "rounds": rounds,
                             "rounds_done": {"old": len(old_payloads), "new": len(new_payloads)},
                             "figures": figures}
    return rows, payload


def _saved_rows(folder: Path) -> list[BenchRow]:
    """Rows of every saved ``bench_*.json`` in ``folder``, in module order."""
    fields = set(BenchRow.__dataclass_fields__)
    rows = []
    for path in sorted(folder.glob("bench_*.json")):
        for row in json.loads(path.read_text())["rows"]:
            rows.append(BenchRow(**{k: v for k, v in row.items() if k in fields}))
    return rows


if __name__ == "__main__":
    main()
