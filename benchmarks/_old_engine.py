"""The numba engine timed beside the new one: each benchmark module, old and new, alternating in the same run.

``make old-engine`` (run by ``make bench`` when missing) puts the last all-numba commit (:data:`COMMIT`, the parent
of "The compiled core, stage 1") in a git worktree, ``build/old-engine``, with its own virtual environment installed
by that commit's Makefile and warmed up by its ``pfield warmup`` (numba's compile is never timed); the stamp
``build/old-engine/.venv/.old-engine-ready`` holds the commit once everything is in place.

For a module that exists in both trees, :func:`paired_rounds` runs it in new processes: the old commit's own harness
in the worktree (``python -m benchmarks.run --only NAME [--quick] --out DIR``, which writes the rows as JSON) and
this tree's the same way, alternating old, new, old, new … so that a slow minute of the shared machine falls on
both engines alike. :func:`merge` matches the rows by (section, name) and takes each figure's median over its
rounds (:func:`middle`; of two rounds, the better one): the new rows carry the old figure
(:attr:`BenchRow.old_value`); a row of the old engine only appears with no new figure (its name changed, or the
module no longer measures it).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from benchmarks._common import BenchRow

ROOT = Path(__file__).resolve().parents[1]
WORKTREE = ROOT / "build" / "old-engine"
COMMIT = "ebecf3d37b3cf7703a6465eb818098e2756d745f"
"""The numba engine: the parent of 8ee82a7 ("The compiled core, stage 1"). The Makefile's ``OLD_ENGINE_COMMIT``."""

Key = tuple[str, str, int]
"""A row's (section, name, occurrence): the occurrence tells apart rows a module repeats (none does today)."""


@dataclass(frozen=True)
class Engine:
    """A tree whose benchmarks run in new processes: its python, its root (the cwd) and its environment."""

    label: str
    python: Path
    root: Path
    env: dict[str, str]
    commit: str = ""

    def has_module(self, name: str) -> bool:
        return (self.root / "benchmarks" / f"{name}.py").is_file()


def old_engine(worktree: Path = WORKTREE) -> Engine | None:
    """The numba engine when ``make old-engine`` completed (its stamp exists), else None."""
    stamp = worktree / ".venv" / ".old-engine-ready"
    python = worktree / ".venv" / "bin" / "python"
    if not stamp.is_file() or not python.is_file():
        return None
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env |= {"VIRTUAL_ENV": str(worktree / ".venv"), "PATH": f"{worktree / '.venv' / 'bin'}{os.pathsep}{env['PATH']}",
            "PFIELD_NO_ANCHOR": "1"}  # its C++ reference figures are not used: the new run times the C++ original
    return Engine("numba engine", python, worktree, env, stamp.read_text().strip())


def new_engine() -> Engine:
    """This tree, run by this interpreter (its ``--no-old`` run times one engine only)."""
    return Engine("new engine", Path(sys.executable), ROOT, dict(os.environ))


@dataclass
class Round:
    """One run of a module in one engine: its saved payload (None when it failed) and the tail of its output."""

    engine: Engine
    payload: dict[str, Any] | None
    log: str
    out: Path


def run_once(engine: Engine, name: str, quick: bool, out: Path, extra: Iterable[str] = ()) -> Round:
    """``python -m benchmarks.run --only NAME`` in ``engine``'s tree, writing to ``out``; the module's JSON payload."""
    out.mkdir(parents=True, exist_ok=True)
    command = [str(engine.python), "-m", "benchmarks.run", "--only", name.removeprefix("bench_"), "--out", str(out),
               *(["--quick"] if quick else []), *extra]
    done = subprocess.run(command, cwd=engine.root, env=engine.env, capture_output=True, text=True, check=False)
    log = (done.stdout + done.stderr)[-4000:]
    saved = out / f"{name}.json"
    if done.returncode != 0 or not saved.is_file():
        return Round(engine, None, f"exit {done.returncode}: {log}", out)
    return Round(engine, json.loads(saved.read_text()), log, out)


def paired_rounds(old: Engine, new: Engine, name: str, quick: bool, rounds: int, scratch: Path,
                  progress: Callable[[str], object] = lambda _: None) -> tuple[list[Round], list[Round]]:
    """``rounds`` runs of module ``name`` in each engine, alternating old, new, old, new …"""
    olds, news = [], []
    for k in range(rounds):
        progress(f"{name}: numba engine {k + 1}/{rounds}")
        olds.append(run_once(old, name, quick, scratch / f"old-{k}"))
        progress(f"{name}: new engine {k + 1}/{rounds}")
        news.append(run_once(new, name, quick, scratch / f"new-{k}", ["--no-old"]))
    return olds, news


def _keyed(rows: list[dict[str, Any]]) -> dict[Key, dict[str, Any]]:
    seen: dict[tuple[str, str], int] = {}
    keyed = {}
    for row in rows:
        pair = (row["section"], row["name"])
        seen[pair] = seen.get(pair, -1) + 1
        keyed[(*pair, seen[pair])] = row
    return keyed


def middle(values: Iterable[float | None], higher_is_better: bool = False) -> float | None:
    """The median of the figures given; of an even count, the better of the two middle ones (the lower one unless
    higher is better), for both engines alike: on a shared machine the worse one is the more disturbed (a parallel
    kernel whose thread waited for a busy core), and the mean of the two would carry that disturbance in half."""
    present = sorted(v for v in values if v is not None)
    if not present:
        return None
    half = len(present) // 2
    return present[half] if len(present) % 2 or higher_is_better else present[half - 1]


FIELDS = set(BenchRow.__dataclass_fields__)


def merge(olds: list[list[dict[str, Any]]], news: list[list[dict[str, Any]]],
          old_label: str = "the numba engine") -> tuple[list[BenchRow], dict[str, dict[str, list[float]]]]:
    """The rows of the new rounds with each figure the median over its rounds (:func:`middle`), carrying the old
    rounds' median (``old_value``) of the row with the same (section, name); rows only in the old rounds follow the
    last row of their section, with no new figure (NaN). Also each row's figures per round:
    ``{"section / name": {"new": […], "old": […]}}``."""
    old_keyed, new_keyed = [_keyed(r) for r in olds], [_keyed(r) for r in news]
    order: list[Key] = []
    for keyed in new_keyed:
        order += [k for k in keyed if k not in order]
    for keyed in old_keyed:
        for key in keyed:
            if key in order:
                continue
            same_section = [i for i, k in enumerate(order) if k[0] == key[0]]
            order.insert(same_section[-1] + 1 if same_section else len(order), key)
    rows, figures = [], {}
    for key in order:
        new_rows = [keyed[key] for keyed in new_keyed if key in keyed]
        old_values = [keyed[key]["value"] for keyed in old_keyed if key in keyed]
        name = f"{key[0]} / {key[1]}" + (f" #{key[2] + 1}" if key[2] else "")
        figures[name] = {"new": [r["value"] for r in new_rows], "old": old_values}
        if new_rows:
            row = BenchRow(**{k: v for k, v in new_rows[-1].items() if k in FIELDS})
            value = middle((r["value"] for r in new_rows), row.higher_is_better)
            row = replace(row, value=value if value is not None else math.nan, old_value=middle(
                old_values, row.higher_is_better), reference=middle(r.get("reference") for r in new_rows))
        else:
            last = [keyed[key] for keyed in old_keyed if key in keyed][-1]
            row = BenchRow(**{k: v for k, v in last.items() if k in FIELDS} | {
                "value": math.nan, "reference": None, "target": None, "note": f"only in {old_label}"})
            row = replace(row, old_value=middle(old_values, row.higher_is_better))
        rows.append(row)
    return rows, figures


def copy_files(source: Path, out: Path, module: str) -> None:
    """The other files a module wrote beside its rows (its Report files) in ``source``, copied to ``out``."""
    for path in source.iterdir():
        if path.is_file() and path.name not in (f"{module}.json", "latest.md"):
            shutil.copy2(path, out / path.name)


def scratch_folder() -> tempfile.TemporaryDirectory[str]:
    return tempfile.TemporaryDirectory(prefix="pfield-bench-pair-")
