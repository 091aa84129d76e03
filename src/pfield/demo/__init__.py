"""The built-in demo, one section per area, each writing its pictures into one output folder.

A section is a module with ``TITLE`` and ``run(out_dir, console) -> None``; it raises on failure.
"""

from __future__ import annotations

import importlib
import time
from pathlib import Path

from rich.rule import Rule

from pfield._console import console as make_console

SECTIONS = ("manipulator", "whole_body", "assisted", "node_session", "mobile", "costmap", "viewer")


def run_demo(out_dir: Path, only: list[str] | None = None) -> int:
    """Run the demo sections in order; return a process exit code (0 when all succeeded).

    ``only`` names the sections to run; an unknown name raises ``InvalidInput`` listing the known ones.
    """
    from pfield.errors import InvalidInput

    for name in only or []:
        if name not in SECTIONS:
            raise InvalidInput("--only", name, f"unknown demo section; known: {', '.join(SECTIONS)}")
    console = make_console()
    out_dir.mkdir(parents=True, exist_ok=True)
    failures = []
    for name in SECTIONS:
        if only and name not in only:
            continue
        module = importlib.import_module(f"pfield.demo.{name}")
        console.print(Rule(f"[bold]{module.TITLE}"))
        start = time.perf_counter()
        try:
            module.run(out_dir, console)
        except Exception as exc:  # a demo section failing must not hide the others
            failures.append(name)
            console.print(f"[red]section {name!r} failed:[/red] {type(exc).__name__}: {exc}")
        else:
            console.print(f"[dim]{name}: {time.perf_counter() - start:.1f} s[/dim]")
    console.print(Rule())
    console.print(f"Pictures are in [bold]{out_dir.resolve()}[/bold]")
    if failures:
        console.print(f"[red]failed sections: {', '.join(failures)}[/red]")
        return 1
    return 0
