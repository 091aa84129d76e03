"""``pfield warmup``: compile every numba kernel now, with a progress bar, instead of on first use."""

from __future__ import annotations

import os
import time
from typing import Annotated

import typer


def warmup(jobs: Annotated[int, typer.Option(
        min=1, help="2 or more: compile in two processes side by side when the cache is cold (default: on 2+ cores)")]
        = min(os.cpu_count() or 1, 2)) -> None:
    """Compile every numba kernel of pfield once (field, planners, IK, autonomy, mobile, costmap, SDFs).

    With a filled cache this takes seconds; after an install or an edit of pfield, 3-10 minutes (two processes
    compile side by side on a 2-core machine). `make demo` runs it first.
    """
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from pfield import warmup as warm_up

    console = Console(stderr=True)
    start = time.perf_counter()
    with Progress(TextColumn("compiling kernels: {task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=console) as progress:
        task = progress.add_task("", total=len(warm_up.STEPS))

        def report(done: int, total: int, name: str) -> None:
            progress.update(task, completed=done, description=name if done < total else "done")

        result = warm_up.warm(report, jobs=jobs)
    for name, error in result.failures.items():
        console.print(f"[red]{name} failed:[/red] {error}", markup=True, highlight=False)
    compiled = sum(1 for kernel in warm_up.kernels().values() if kernel.signatures)
    console.print(f"warm-up done in {time.perf_counter() - start:.1f} s "
                  f"({len(warm_up.STEPS) - len(result.failures)}/{len(warm_up.STEPS)} areas, "
                  f"{compiled} kernels loaded or compiled"
                  + (f"; {result.lanes} processes compiled side by side" if result.lanes else "")
                  + ")", highlight=False)
    if result.failures:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Add ``warmup`` to ``app``."""
    app.command("warmup")(warmup)
