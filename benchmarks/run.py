"""Run every ``benchmarks/bench_*.py`` module and print one Markdown table per section.

Usage: ``python -m benchmarks.run [--quick] [--only NAME ...] [--out DIR]`` (``make bench``). Each module
exposes ``run(quick: bool)`` returning its rows (``list[BenchRow]``) or a :class:`benchmarks._common.Report`
(the rows and other views of them, written beside them). A full run writes ``benchmarks/results/<module>.json`` (the
tracked figures) and rebuilds ``benchmarks/results/latest.md`` from all saved modules. A partial run
(``--only`` or ``--quick``) leaves those files alone: its JSON files and a ``latest.md`` of its own rows go
to ``--out`` (default ``benchmarks/results/partial/``, not tracked). Each module's first section opens with
the host check (:func:`benchmarks._common.host_check_ms`, timed just before the module): a single-thread figure
of two runs that moved by about the same factor as the host check most likely moved with the host.
Reference figures: ``../shared/benchmarks/REFERENCE.md``.
"""

from __future__ import annotations

import argparse
import importlib
import json
import platform
import sys
import time
from pathlib import Path

from rich.console import Console
from rich.progress import Progress

from benchmarks._common import HOST_CHECK, BenchRow, Report, host_check_ms

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
PARTIAL = "partial"
"""Folder under :data:`RESULTS` of partial runs (ignored by git)."""


def _fmt(value: float | None) -> str:
    if value is None:
        return "—"
    if value == 0:
        return "0"
    if abs(value) >= 100:
        return f"{value:.0f}"
    if abs(value) >= 1:
        return f"{value:.2f}"
    return f"{value:.3g}"


def to_markdown(rows: list[BenchRow]) -> str:
    lines: list[str] = []
    section = None
    for row in rows:
        if row.section != section:
            section = row.section
            lines += ["", f"### {section}", "",
                      "| figure | pfield | unit | C++ original | ratio | target | met | note |",
                      "|---|---:|---|---:|---:|---:|:---:|---|"]
        met = {True: "yes", False: "**no**", None: ""}[row.meets_target()]
        lines.append(
            f"| {row.name} | {_fmt(row.value)} | {row.unit} | {_fmt(row.reference)} | {_fmt(row.ratio())} | "
            f"{_fmt(row.target)} | {met} | {row.note} |"
        )
    return "\n".join(lines).lstrip() + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer repetitions (smoke run)")
    parser.add_argument("--only", nargs="*", default=[], help="module names without bench_ prefix")
    parser.add_argument("--out", type=Path, default=None,
                        help="where a partial run writes (default: benchmarks/results/partial)")
    args = parser.parse_args()
    partial = bool(args.only or args.quick)
    out = RESULTS if not partial and args.out is None else (args.out or RESULTS / PARTIAL)
    console = Console(width=None if sys.stdout.isatty() else 200)  # tables, not 80-column wraps, in logs
    modules = sorted(p.stem for p in HERE.glob("bench_*.py"))
    if args.only:
        modules = [m for m in modules if m.removeprefix("bench_") in args.only]
    out.mkdir(parents=True, exist_ok=True)
    all_rows: list[BenchRow] = []
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task("benchmarks", total=len(modules))
        for name in modules:
            progress.update(task, description=name)
            host = host_check_ms()
            start = time.perf_counter()
            module = importlib.import_module(f"benchmarks.{name}")
            result = module.run(args.quick)
            rows, tables = (result.rows, result.tables) if isinstance(result, Report) else (result, {})
            if rows:
                rows = [BenchRow(rows[0].section, HOST_CHECK, host, "ms",
                                 note=f"before {name}; single-thread figures of two runs compare through it"), *rows]
            all_rows.extend(rows)
            for file_name, text in tables.items():
                (out / file_name).write_text(text)
            payload = {"module": name, "seconds": time.perf_counter() - start, "machine": platform.processor()
                       or platform.machine(), "python": platform.python_version(),
                       "host_check_ms": host, "rows": [r.as_dict() for r in rows]}
            (out / f"{name}.json").write_text(json.dumps(payload, indent=2))
            progress.advance(task)
    console.print(to_markdown(all_rows), markup=False, highlight=False)
    # The tracked latest.md covers every module; a partial run's latest.md only its own rows.
    (out / "latest.md").write_text(to_markdown(all_rows if partial else _saved_rows(out)))


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
